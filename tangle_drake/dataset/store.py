"""A collection's dataset directory: shards, their task records, and the manifest.

Layout (``tangle_drake.dataset`` plus one record per task)::

    manifest.json          what made the data (the collection's identity) and the counts
    shard_0000012.npz      task 12's samples (possibly none)
    shard_0000012.json     task 12's record: candidates, skips, lifts, pile depth, timings

The record is written before the shard, both atomically, so a task counts as finished
exactly when its ``.npz`` exists, and every finished task has its record. Only the process
that drives the collection writes here (workers return their results to it), so a Ray
cluster's nodes need no shared disk; a lock file keeps a second collection out of a
directory while one runs, and temporary files a killed run left behind are removed. A shard
damaged on disk since (``tangle_drake.dataset.shard_problem``), or one without its record, is
moved aside as ``*.damaged`` with a notice, and its task is collected again.
"""

from __future__ import annotations

import fcntl
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import (
    MANIFEST,
    finished_tasks,
    read_manifest,
    shard_name,
    shard_problem,
    write_manifest,
)
from tangle_drake.dataset import write_shard as write_shard_arrays

COUNTED = ("samples", "tangled", "immediate", "lifts", "empty_region", "lift_errors",
           "candidates", "repeat_lifts", "repeat_all_agree", "repeat_majority", "cpu_s",
           "one", "none", "failed")
"""Task record fields the manifest sums over all finished tasks (those a kind of data
lacks count 0: ``one``, ``none`` and ``failed`` are the physical picks')."""


@dataclass
class TaskResult:
    """One finished task: its samples (dataset arrays) and what happened on the way."""

    task: int
    samples: dict[str, np.ndarray]
    stats: dict = field(default_factory=dict)


def record_name(task: int) -> str:
    return f"shard_{task:07d}.json"


class DatasetStore:
    """Opens (or starts) a dataset bound to ``identity`` and appends finished tasks to it."""

    def __init__(self, directory: Path, identity: dict) -> None:
        self.directory = Path(directory)
        self.identity = json.loads(json.dumps(identity))  # as it reads back from JSON
        created = self._check_or_create()
        self._lock = self._take_lock()
        for stale in self.directory.glob(".tmp_*"):
            stale.unlink()
        self.notices: list[str] = []
        """What was repaired on opening (damaged shards moved aside), for the user."""
        self.finished = finished_tasks(self.directory)
        self.totals = {name: 0 for name in COUNTED} | {"tasks": 0}
        for task in sorted(self.finished):
            record, problem = self._read_record(task)
            problem = problem or shard_problem(self.directory / shard_name(task))
            if problem is None:
                self._count(record)
            else:
                self._set_aside(task, problem)
        if created:
            self.write_manifest()

    def _check_or_create(self) -> bool:
        """Check an existing dataset's identity, or make the directory; True if made."""
        if self.directory.exists() and not self.directory.is_dir():
            raise TangleDrakeError(f"--out {self.directory} exists and is not a directory")
        if (self.directory / MANIFEST).exists():
            manifest = read_manifest(self.directory)
            stored = {key: manifest.get(key) for key in self.identity}
            differences = _differences(stored, self.identity)
            if differences:
                raise TangleDrakeError(
                    f"{self.directory} holds a dataset made with other settings "
                    f"({'; '.join(differences[:6])}); collect into another --out directory, "
                    "or repeat the original settings to continue it")
            return False
        if self.directory.is_dir() and any(self.directory.iterdir()):
            raise TangleDrakeError(f"--out {self.directory} is not empty and holds no "
                                   f"{MANIFEST}: not a tangle dataset; give a new or empty "
                                   "directory")
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise TangleDrakeError(f"cannot create --out {self.directory}: "
                                   f"{error.strerror}") from error
        return True

    def _take_lock(self):
        """Hold ``.lock`` for as long as this store lives (released when the process ends)."""
        handle = open(self.directory / ".lock", "w")  # noqa: SIM115 (held open on purpose)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            raise TangleDrakeError(f"another collection is writing to {self.directory}; wait "
                                   "for it to finish or stop it first") from None
        return handle

    def close(self) -> None:
        """Release the directory for other collections."""
        self._lock.close()

    def _read_record(self, task: int) -> tuple[dict, str | None]:
        """The task's record, or why it cannot be read."""
        path = self.directory / record_name(task)
        try:
            return json.loads(path.read_text()), None
        except FileNotFoundError:
            return {}, f"its record {path.name} is missing"
        except (OSError, json.JSONDecodeError) as error:
            return {}, f"its record {path.name} is unreadable ({error})"

    def _set_aside(self, task: int, problem: str) -> None:
        """Move a damaged task's files to ``*.damaged`` so the task is collected again."""
        for name in (shard_name(task), record_name(task)):
            path = self.directory / name
            if path.exists():
                os.replace(path, path.with_name(path.name + ".damaged"))
        self.finished.discard(task)
        self.notices.append(f"{self.directory / shard_name(task)} was damaged ({problem}): "
                            "moved aside as *.damaged; its pile is collected again")

    def _count(self, record: dict) -> None:
        for name in COUNTED:
            self.totals[name] += record.get(name, 0)
        self.totals["tasks"] += 1

    def add(self, result: TaskResult) -> None:
        """Write a finished task (record, then shard) and update the manifest's counts."""
        if result.task in self.finished:
            raise TangleDrakeError(f"task {result.task} is already in {self.directory}")
        _write_json_atomic(self.directory / record_name(result.task), result.stats)
        write_shard_arrays(self.directory, result.task, result.samples)
        self.finished.add(result.task)
        self._count(result.stats)
        self.write_manifest()

    def write_manifest(self) -> None:
        write_manifest(self.directory, {**self.identity, "counts": self.counts()})

    def counts(self) -> dict:
        """The totals so far, with the derived class balance and label agreement."""
        t = self.totals
        out = {name: round(value, 3) if isinstance(value, float) else value
               for name, value in t.items()}
        out["not_tangled"] = t["samples"] - t["tangled"]
        out["tangled_fraction"] = round(t["tangled"] / t["samples"], 4) if t["samples"] else None
        if t["repeat_lifts"]:
            out["repeat_all_agree_fraction"] = round(t["repeat_all_agree"] / t["repeat_lifts"], 4)
            out["repeat_majority_agreement"] = round(t["repeat_majority"] / t["repeat_lifts"], 4)
        return out


def _differences(stored: dict, wanted: dict, prefix: str = "") -> list[str]:
    """Human-readable ``key: stored -> wanted`` lines for every differing leaf."""
    lines = []
    for key in wanted:
        a, b = stored.get(key), wanted[key]
        path = f"{prefix}{key}"
        if isinstance(a, dict) and isinstance(b, dict):
            lines.extend(_differences(a, b, path + "."))
        elif a != b:
            lines.append(f"{path}: {a!r} there, {b!r} now")
    return lines


def _write_json_atomic(path: Path, data: dict) -> None:
    tmp = path.with_name(".tmp_" + path.name)
    with open(tmp, "w") as handle:
        json.dump(data, handle, indent=1, sort_keys=True)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)
