"""Where the project's files live: shipped models, trained weights and the generated-model cache.

Models are found through Drake's ``PackageMap`` (``package://nextage/...``), never by absolute
paths, so the same scenario files work from a source checkout and from a non-editable install.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from pydrake.multibody.parsing import PackageMap, Parser

from tangle_drake.common.errors import TangleDrakeError

_PACKAGE_DIR = Path(__file__).resolve().parent.parent
"""The ``tangle_drake`` package."""


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


PLACEHOLDER = "DATA"
"""What a recorded path outside the repository and the working directory is written under."""


def shown_path(path: str | os.PathLike) -> str:
    """``path`` as a result records it (a report's command, an evaluation's dataset, a
    checkpoint's data): with nothing of the machine that made it, so that committed results
    name no one's home or scratch directories, and a reader still sees what to pass.

    A relative path stays as given. An absolute one inside the repository (the directory
    holding the ``tangle_drake`` package) is written relative to it, else one inside the
    working directory relative to that, else as its name under :data:`PLACEHOLDER`
    (``/scratch/runs/u_hook_test`` -> ``DATA/u_hook_test``).
    """
    path = Path(path)
    if not path.is_absolute():
        return path.as_posix()
    path = Path(os.path.normpath(path))
    try:
        bases = (_PACKAGE_DIR.parent, Path.cwd())
    except OSError:  # the working directory was removed
        bases = (_PACKAGE_DIR.parent,)
    for candidate in (path, path.resolve()):
        for base in bases:
            if candidate.is_relative_to(base):
                return candidate.relative_to(base).as_posix()
    return f"{PLACEHOLDER}/{path.name}"


def check_writable(path: Path, what: str, directory: bool = False) -> None:
    """Refuse, before any long work, an output ``path`` (a file, or with ``directory`` a
    directory) that could not be written: an existing path of the other kind, or a nearest
    existing ancestor that is no writable directory. Creates nothing that stays."""
    path = Path(path)
    if path.exists() and path.is_dir() != directory:
        kind = "a file" if directory else "a directory"
        raise TangleDrakeError(f"{what} {path}: is {kind}")
    ancestor = path if directory and path.is_dir() else path.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise TangleDrakeError(f"{what} {path}: {ancestor} is not a directory")
    try:  # os.access says yes to root on any directory, even a read-only mount
        tempfile.TemporaryFile(dir=ancestor).close()
    except OSError as error:
        raise TangleDrakeError(f"{what} {path}: cannot write in {ancestor}: "
                               f"{error.strerror}") from error
