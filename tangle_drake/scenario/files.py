"""Finding and composing scenarios: a base file (a user's path, or one shipped with the
package), overlay files merged onto it in order, then overlay texts, as Drake's
``hardware_sim`` takes ``--scenario_text``. A variant of a run is then the few lines it
changes, not a copy of the whole file."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.scenario import Scenario, load_scenario, parse_scenario
from tangle_drake.scenario.yaml_io import dump, merge, read_mapping

DEFAULT_SCENARIO_NAME = "pick_demo.yaml"

TEXT_SOURCE = "--scenario-text"
"""How an overlay given as text is named in errors and descriptions."""


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


@dataclass(frozen=True)
class ScenarioSource:
    """Where a run's scenario comes from: ``files`` as given (the base, then overlays; none:
    ``default``, a shipped name or a path) and ``texts`` (overlays merged last)."""

    files: tuple[Path, ...] = ()
    texts: tuple[str, ...] = ()
    default: str = DEFAULT_SCENARIO_NAME

    def with_default(self, default: str | Path) -> ScenarioSource:
        """This source, with ``default`` as the base when no file was given."""
        return ScenarioSource(self.files, self.texts, str(default))

    @property
    def given(self) -> tuple[Path, ...]:
        """The files as given, the default base when none was."""
        return self.files or (Path(self.default),)

    @property
    def name(self) -> str:
        """The scenario as errors and reports name it: its files and overlays, as given."""
        return " + ".join([str(path) for path in self.given] + [TEXT_SOURCE] * len(self.texts))

    def documents(self) -> list[tuple[str, str]]:
        """(name, text) of the base and each overlay, in the order they merge."""
        documents = []
        for given in self.given:
            path = scenario_path(given)
            try:
                documents.append((str(given), path.read_text()))
            except OSError as error:
                raise TangleDrakeError(
                    f"cannot read scenario file {path}: {error.strerror}") from error
        return documents + [(TEXT_SOURCE, text) for text in self.texts]

    def read(self) -> tuple[str, Scenario]:
        """The scenario's YAML text (a single file's own text, so its digest is the file's;
        else the documents merged into one) and the validated scenario. A field an overlay
        names wrongly is refused with the overlay's name and the field's."""
        documents = self.documents()
        if len(documents) == 1:
            name, text = documents[0]
            return text, parse_scenario(text, source=name)
        mappings = [(name, read_mapping(text, name)) for name, text in documents]
        merged: object = {}
        for _, mapping in mappings:
            merged = merge(merged, mapping)
        text = dump(merged)
        try:
            return text, parse_scenario(text, source=self.name)
        except TangleDrakeError as error:
            field = re.search(r"scenario field '([^']+)'", str(error))
            named = [name for name, mapping in mappings
                     if field and _names_field(mapping, field.group(1))]
            if not named:
                raise
            detail = str(error).removeprefix(f"{self.name}: ")
            raise TangleDrakeError(f"{named[-1]} (overlaid on {documents[0][0]}): "
                                   f"{detail}") from error

    def text(self) -> str:
        """The scenario's YAML text, checked (:meth:`read`)."""
        return self.read()[0]

    def load(self) -> Scenario:
        """The validated scenario (:meth:`read`)."""
        return self.read()[1]


def scenario_source(files: ScenarioSource | Sequence[str | Path] | str | Path | None = None,
                    texts: Sequence[str] = ()) -> ScenarioSource:
    """A :class:`ScenarioSource` from what a command or a caller was given (a source is
    returned as it is)."""
    if isinstance(files, ScenarioSource):
        return files
    if files is None:
        files = ()
    elif isinstance(files, str | Path):
        files = (files,)
    return ScenarioSource(tuple(Path(path) for path in files), tuple(texts))


def _names_field(raw: object, field: str) -> bool:
    """Whether the document ``raw`` sets the dotted ``field`` (list indices dropped)."""
    for key in re.sub(r"\[\d+\]", "", field).split("."):
        value = getattr(raw, "value", raw)  # a driver variant's fields
        if not isinstance(value, dict) or key not in value:
            return False
        raw = value[key]
    return True
