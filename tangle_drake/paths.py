"""Where the project's files live: shipped models, trained weights and the generated-model cache.

Models are found through Drake's ``PackageMap`` (``package://nextage/...``), never by absolute
paths, so the same scenario files work from a source checkout and from a non-editable install.
"""

from __future__ import annotations

import os
from pathlib import Path

from pydrake.multibody.parsing import PackageMap, Parser

from tangle_drake.errors import TangleDrakeError

_PACKAGE_DIR = Path(__file__).resolve().parent


def _shipped_dir(name: str, marker: str) -> Path:
    """A top-level directory of the repository that the wheel ships inside the package.

    An installed wheel carries it as ``tangle_drake/<name>``; a source checkout has it at the
    repository's top level. ``marker`` is a file that must exist in it.
    """
    for candidate in (_PACKAGE_DIR / name, _PACKAGE_DIR.parent / name):
        if (candidate / marker).is_file():
            return candidate
    raise TangleDrakeError(f"cannot find {name}/{marker} next to the tangle_drake package; "
                           "reinstall tangle_drake (pip install .)")


def models_dir() -> Path:
    """The directory holding ``nextage/package.xml``."""
    return _shipped_dir("models", "nextage/package.xml")


def diagrams_dir() -> Path:
    """The directory holding the shipped scenarios (``pick_demo.yaml``, ...)."""
    return _shipped_dir("diagrams", "pick_demo.yaml")


SHIPPED_PACKAGES = ("nextage", "gantry")
"""The model packages under ``models/``: the Nextage with its gripper, and the gantry."""


def register_packages(package_map: PackageMap) -> None:
    """Make ``package://nextage/...`` and ``package://gantry/...`` resolvable in
    ``package_map``."""
    for name in SHIPPED_PACKAGES:
        if not package_map.Contains(name):
            package_map.AddPackageXml(str(models_dir() / name / "package.xml"))


def make_parser(plant, scope_name: str | None = None) -> Parser:
    """A ``Parser`` for ``plant`` that resolves the project's packages."""
    parser = Parser(plant) if scope_name is None else Parser(plant, scope_name)
    register_packages(parser.package_map())
    return parser


def cache_dir() -> Path:
    """Directory for generated model files (parts, bins), keyed by content.

    ``TANGLE_DRAKE_CACHE`` overrides the default ``~/.cache/tangle_drake``.
    """
    root = os.environ.get("TANGLE_DRAKE_CACHE")
    path = Path(root) if root else Path.home() / ".cache" / "tangle_drake"
    path.mkdir(parents=True, exist_ok=True)
    return path
