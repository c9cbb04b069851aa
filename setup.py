"""The package list: every package under tangle_drake/ as found, plus models/ and diagrams/,
which pyproject.toml's package-dir maps into the package (setuptools cannot find a mapped
package, nor mix a found list with named ones in pyproject.toml)."""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["tangle_drake", "tangle_drake.*"]),
                "tangle_drake.models", "tangle_drake.diagrams"])
