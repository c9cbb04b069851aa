"""The tangle dataset on disk: append-only ``.npz`` shards plus a manifest.

A dataset directory holds ``manifest.json`` (what made the data: part, crop, gripper, settings)
and one shard ``shard_<task>.npz`` per finished task (one settled pile and its lifts). Shards
are written to a temporary name and renamed, so a killed run leaves only whole shards; a resumed
run skips the tasks whose shards exist, so no sample is lost or duplicated. The shards are the
truth; the manifest's ``samples`` count is a summary rebuilt from them. A shard damaged on disk
afterwards (truncated by a full disk, a bad copy) fails the zip's CRC check when read: readers
skip it with a notice naming it, and a resumed collection moves it aside and collects its task
again.

Every shard holds the same arrays, one row per sample (see ``SAMPLE_FIELDS``).
"""

from __future__ import annotations

import json
import os
import sys
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tangle_drake.common.errors import TangleDrakeError

FORMAT_VERSION = 1
MANIFEST = "manifest.json"

SAMPLE_FIELDS: dict[str, np.dtype] = {
    "crop": np.dtype(np.float32),           # (S, S) metric depth crop, metres (crops.py)
    "label": np.dtype(np.int8),             # 1 = tangled, 0 = not tangled, -1 = no label
    "score": np.dtype(np.float32),          # graspability score in [0, 1]
    "u": np.dtype(np.float32),              # candidate pixel column
    "v": np.dtype(np.float32),              # candidate pixel row
    "angle_deg": np.dtype(np.float32),      # closing direction in the image
    "depth_m": np.dtype(np.float32),        # fingertip depth along the optical axis
    "width_m": np.dtype(np.float32),        # opening width
    "rank": np.dtype(np.int16),             # candidate's rank in the graspability top-k
    "pile_seed": np.dtype(np.int64),        # seed of the pile (train/validation split key)
    "task": np.dtype(np.int64),             # task index (one pile per task)
    "num_in_region": np.dtype(np.int16),    # parts in the closing region
    "num_lifted": np.dtype(np.int16),       # other parts that rose above the threshold
    "num_hanging": np.dtype(np.int16),      # of those, how many hang from the target
    "target": np.dtype(np.int16),           # pile index of the lifted part, -1 if none
}
OPTIONAL_FIELDS: dict[str, np.dtype] = {
    "full_depth": np.dtype(np.float32),     # (H, W) whole depth image, if asked for
    # What the labelling simulator saw (tangle_drake.tangle_data.samples); -1 / NaN = no lift.
    "num_riding": np.dtype(np.int16),       # of the lifted parts, how many ride on the target
    "lifted_mask": np.dtype(np.int64),      # bit n = pile part n rose above the threshold
    "hanging_mask": np.dtype(np.int64),     # bit n = pile part n hangs from the target
    "riding_mask": np.dtype(np.int64),      # bit n = pile part n rides on the target
    "max_rise_m": np.dtype(np.float32),     # largest rise of another part during the lift
    "target_rise_m": np.dtype(np.float32),  # how far the target rose by the lift's end
    "stalled": np.dtype(np.int8),           # 1 = the pile held the target down
    "pose": np.dtype(np.float64),           # (4, 4) candidate's tool pose X_WT
    "part": np.dtype("U64"),                # part type (built-in name or mesh file stem)
    "repeat_tangled": np.dtype(np.int16),   # with --repeat K: how many of K lifts said tangled
    # A pick log's (tangle_drake.pick.pick_log): the grasp's weighing, and the simulation's
    # counts to score it by (-1 on hardware).
    "outcome": np.dtype(np.int8),           # 0 nothing, 1 one part, 2 several, -1 not sure
    "weighed_parts": np.dtype(np.float32),  # the first weighing, in parts (NaN: none)
    "sim_lifted": np.dtype(np.int16),       # parts the simulation saw brought up
    "sim_held": np.dtype(np.int16),         # parts held up through contacts
}


def rows_to_arrays(rows: dict[str, list], shapes: dict[str, tuple[int, ...]]
                   ) -> dict[str, np.ndarray]:
    """A task's rows (a list of values per field) as shard arrays of the fields' dtypes;
    ``shapes`` gives each non-scalar field's row shape, so a task without samples still
    writes arrays of the right shape."""
    dtypes = SAMPLE_FIELDS | OPTIONAL_FIELDS
    return {name: np.asarray(values, dtype=dtypes[name]) if values else
            np.zeros((0, *shapes.get(name, ())), dtype=dtypes[name])
            for name, values in rows.items()}


def shard_name(task: int) -> str:
    return f"shard_{task:07d}.npz"


def write_shard(directory: Path, task: int, samples: dict[str, np.ndarray]) -> Path:
    """Atomically write one task's samples; all arrays must have the same first dimension."""
    lengths = {name: len(array) for name, array in samples.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"shard arrays differ in length: {lengths}")
    missing = set(SAMPLE_FIELDS) - set(samples)
    if missing:
        raise ValueError(f"shard lacks fields {sorted(missing)}")
    arrays = {name: np.asarray(array, dtype=(SAMPLE_FIELDS | OPTIONAL_FIELDS)[name])
              for name, array in samples.items()}
    path = directory / shard_name(task)
    # Opened by name, not with mkstemp, so the shard gets the user's umask (mkstemp: 0600).
    tmp = directory / f".tmp_{os.getpid()}_{path.name}"
    try:
        with open(tmp, "wb") as handle:
            np.savez(handle, **arrays)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def finished_tasks(directory: Path) -> set[int]:
    """Tasks whose shards are on disk (whole when written; see ``shard_problem``)."""
    return {int(p.stem.split("_")[1]) for p in directory.glob("shard_*.npz")}


UNREADABLE = (OSError, ValueError, EOFError, zipfile.BadZipFile)
"""What numpy and zipfile raise on a truncated or damaged ``.npz``."""


def read_shard(path: Path, fields: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The ``fields`` (default: all) of one shard, every byte read, so the zip's CRC check
    catches damage; raises one of ``UNREADABLE`` if the shard is damaged."""
    with np.load(path) as shard:
        arrays = {name: shard[name] for name in (shard.files if fields is None else fields)}
    if len({len(array) for array in arrays.values()}) > 1:
        raise ValueError("its arrays differ in length")
    return arrays


def shard_problem(path: Path) -> str | None:
    """Why the shard at ``path`` cannot be used (damaged, or lacking a field), or None."""
    try:
        arrays = read_shard(path)
    except UNREADABLE as error:
        return _reason(error)
    missing = set(SAMPLE_FIELDS) - set(arrays)
    return f"it lacks fields {sorted(missing)}" if missing else None


def _reason(error: BaseException) -> str:
    return f"{type(error).__name__}: {error}" if str(error) else type(error).__name__


def _print_notice(text: str) -> None:
    print(f"notice: {text}", file=sys.stderr)


def skipped_shard_notice(path: Path, reason: str) -> str:
    return (f"dataset shard {path} is damaged ({reason}) and was skipped; run the "
            "`tangle-drake collect` command that made the dataset again (same --out): it "
            "collects that pile again")


def stored_fields(directory: Path) -> set[str]:
    """The arrays the dataset's shards hold (those of its first readable shard; empty if
    none)."""
    directory = Path(directory)
    for task in sorted(finished_tasks(directory)):
        try:
            with np.load(directory / shard_name(task)) as shard:
                return set(shard.files)
        except UNREADABLE:
            continue
    return set()


def write_manifest(directory: Path, info: dict) -> None:
    """Write ``manifest.json`` atomically; ``info`` describes what made the data."""
    info = {"format": FORMAT_VERSION, **info}
    tmp = directory / (MANIFEST + ".tmp")
    tmp.write_text(json.dumps(info, indent=2, sort_keys=True))
    os.replace(tmp, directory / MANIFEST)


def read_manifest(directory: Path) -> dict:
    """The manifest of a dataset directory, with a clear error if there is none."""
    path = Path(directory) / MANIFEST
    try:
        info = json.loads(path.read_text())
    except FileNotFoundError as error:
        raise TangleDrakeError(f"{directory} is not a tangle dataset (no {MANIFEST}); make "
                               "one with `tangle-drake collect`") from error
    except json.JSONDecodeError as error:
        raise TangleDrakeError(f"{path} is corrupt: {error}") from error
    if info.get("format") != FORMAT_VERSION:
        raise TangleDrakeError(f"{path}: dataset format {info.get('format')!r} is not "
                               f"{FORMAT_VERSION}; re-collect it with this version")
    return info


def load_samples(directory: Path, fields: tuple[str, ...] | None = None,
                 notice: Callable[[str], None] = _print_notice) -> dict[str, np.ndarray]:
    """All samples of a dataset, concatenated in task order (fields default to SAMPLE_FIELDS);
    a damaged shard is skipped and ``notice`` told which and how to repair it."""
    directory = Path(directory)
    read_manifest(directory)
    fields = tuple(SAMPLE_FIELDS) if fields is None else fields
    parts: dict[str, list[np.ndarray]] = {name: [] for name in fields}
    for task in sorted(finished_tasks(directory)):
        path = directory / shard_name(task)
        try:
            arrays = read_shard(path, fields)
        except KeyError as error:  # a whole shard of another format: not damage
            raise TangleDrakeError(f"dataset shard {path} lacks the field {error}; it was "
                                   "made by another version: re-collect the dataset") from error
        except UNREADABLE as error:
            notice(skipped_shard_notice(path, _reason(error)))
            continue
        for name in fields:
            parts[name].append(arrays[name])
    return {name: (np.concatenate(chunks) if chunks else
                   np.zeros((0,), dtype=(SAMPLE_FIELDS | OPTIONAL_FIELDS)[name]))
            for name, chunks in parts.items()}
