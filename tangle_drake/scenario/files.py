"""Finding scenario files: a user's path, or the scenarios shipped with the package."""

from __future__ import annotations

from pathlib import Path

from tangle_drake.paths import diagrams_dir
from tangle_drake.scenario import Scenario, load_scenario

DEFAULT_SCENARIO_NAME = "pick_demo.yaml"


def resolve_scenario(path: str | Path | None) -> Scenario:
    """Load ``path``; ``None`` loads the shipped default, and a bare shipped name such as
    ``pick_demo.yaml`` that does not exist locally is looked up among the shipped scenarios."""
    return load_scenario(scenario_path(path))


def scenario_path(path: str | Path | None) -> Path:
    """The file :func:`resolve_scenario` reads for ``path``."""
    if path is None:
        return diagrams_dir() / DEFAULT_SCENARIO_NAME
    path = Path(path)
    if not path.exists() and (diagrams_dir() / path.name).is_file() \
            and path.parent in (Path("."), Path("diagrams")):
        return diagrams_dir() / path.name
    return path
