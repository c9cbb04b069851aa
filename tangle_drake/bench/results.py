"""The benchmark's results on disk: what the run is, and one line per finished trial.

An output directory holds ``bench.json`` (the run's identity: parts, methods and their models
by content, mode, seed, scenario, pile size; not the trial count, which a later run may raise),
``scenario.yaml`` (the scenario itself) and ``results.jsonl``, one JSON line per finished trial
appended with a single write and an fsync. A run killed at any moment leaves every finished
trial on disk, at worst with a last line cut short, which the next run drops (and redoes that
trial); running the same command again resumes, and a different run pointed at the same
directory is refused.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError

IDENTITY_FILE = "bench.json"
SCENARIO_FILE = "scenario.yaml"
"""The scenario the run picked in, as one text (its base and overlays merged): the result
holds all it was made with, and its digest is the identity's ``scenario_sha256``."""
RESULTS_FILE = "results.jsonl"


class ResultStore:
    """The results of one run in ``directory``; created, or resumed if ``identity`` matches."""

    def __init__(self, directory: Path, identity: dict) -> None:
        self.directory = Path(directory)
        if self.directory.exists() and not self.directory.is_dir():
            raise TangleDrakeError(f"--out {self.directory} is a file, not a directory")
        self.directory.mkdir(parents=True, exist_ok=True)
        self.notices: list[str] = []
        self._check_identity(identity)
        self.trials: dict[tuple[str, int], dict] = {}
        self._load()

    @property
    def path(self) -> Path:
        return self.directory / RESULTS_FILE

    def _check_identity(self, identity: dict) -> None:
        path = self.directory / IDENTITY_FILE
        if not path.exists():
            if self.path.exists():
                raise TangleDrakeError(f"{self.directory} holds results without {IDENTITY_FILE}: "
                                       "choose another --out")
            _write_atomic(path, json.dumps(identity, indent=2, sort_keys=True) + "\n")
            return
        try:
            stored = json.loads(path.read_text())
        except json.JSONDecodeError as error:
            raise TangleDrakeError(f"{path} is corrupt ({error}): choose another --out") \
                from error
        if stored != identity and not self._has_trials():
            # A run that finished no trial (it failed at once, say on a corrupt model) binds
            # nothing: this one starts over in its place.
            self.notices.append(f"{self.directory} held a run with other settings and no "
                                "finished trial: starting over")
            _write_atomic(path, json.dumps(identity, indent=2, sort_keys=True) + "\n")
            return
        if stored != identity:
            keys = sorted(k for k in set(stored) | set(identity)
                          if stored.get(k) != identity.get(k))
            raise TangleDrakeError(
                f"{self.directory} holds a benchmark run with other settings (differing: "
                f"{', '.join(keys)}); run it with the same arguments to resume it, or choose "
                "another --out")

    def _has_trials(self) -> bool:
        """Whether the results file holds at least one readable trial."""
        if not self.path.exists():
            return False
        for line in self.path.read_text().splitlines():
            try:
                json.loads(line)["part"]
            except (json.JSONDecodeError, KeyError, TypeError):
                continue
            return True
        return False

    def _load(self) -> None:
        if not self.path.exists():
            return
        good: list[str] = []
        dropped = 0
        for line in self.path.read_text().splitlines():
            try:
                trial = json.loads(line)
                key = (trial["part"], int(trial["trial"]))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                dropped += 1
                continue
            self.trials[key] = trial
            good.append(line)
        if dropped:
            self.notices.append(f"{self.path}: dropped {dropped} unreadable line(s) (a run "
                                "stopped while writing); those trials run again")
            _write_atomic(self.path, "".join(line + "\n" for line in good))

    def keep_scenario(self, text: str) -> None:
        """Write :data:`SCENARIO_FILE` (the identity check made sure a resumed run's is the
        same)."""
        _write_atomic(self.directory / SCENARIO_FILE, text)

    def add(self, trial: dict) -> None:
        """Append one finished trial: one write, then fsync."""
        line = (json.dumps(trial, sort_keys=True) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)
        self.trials[(trial["part"], int(trial["trial"]))] = trial


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
