"""The pick log: every grasp the pick diagram tried, with what the wrist weighed, as a dataset.

Closed loop, the robot weighs every lift, so each grasp labels itself, on hardware as in
simulation: the crop the tangle CNN saw and the weighing's verdict (several parts: tangled;
one part: not tangled; nothing, or not sure: no tangle label, ``label`` -1, kept for an
outcome model). The log is a dataset directory in the format of ``tangle-drake collect``
(``tangle_drake.dataset``; one shard per grasp, appended, so runs add to it and a killed run
loses at most the grasp in progress), which ``train`` and ``evaluate`` read; its manifest says
it is a pick log and binds it to the part, crop and gripper. In simulation each grasp also
keeps the simulation's counts (``sim_lifted``, ``sim_held``) to score the weighing by; on
hardware they are -1.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from tangle_drake.dataset.store import DatasetStore, TaskResult
from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.pick.recovery import Verdict
from tangle_drake.robot_model.gripper import GripperSpec

SOURCE = "pick log"
"""The manifest's ``source`` of a pick log (a collection has none)."""

OUTCOME_CODES = {Verdict.NONE: 0, Verdict.ONE: 1, Verdict.SEVERAL: 2, Verdict.UNSURE: -1}
"""The ``outcome`` field: what the first weighing said came up (-1: not sure)."""


def tangled_label(outcome: int) -> int:
    """The ``label`` (tangled) of an ``outcome`` code: several parts 1, one 0, else -1."""
    return {OUTCOME_CODES[Verdict.SEVERAL]: 1, OUTCOME_CODES[Verdict.ONE]: 0}.get(outcome, -1)


def pick_log_identity(part: str, crop: CropSpec, gripper: GripperSpec) -> dict:
    """What a pick log is bound to: a second run must log the same part, crop and gripper."""
    return {"source": SOURCE, "part": part, "crop": asdict(crop), "gripper": asdict(gripper),
            "labels": {"label": "the wrist's first weighing: 1 = several parts, 0 = one, "
                                "-1 = nothing or not sure"}}


def pick_sample(record: PickRecord, pile_seed: int, task: int, part: str) -> dict[str, np.ndarray]:
    """One logged grasp as dataset arrays (one row); the record must have a crop and a
    weighing."""
    c = record.candidate
    outcome = OUTCOME_CODES[record.verdict]
    estimate = record.estimate
    weighed = estimate.parts if estimate is not None and estimate.ready else math.nan

    def one(value, dtype=np.float32) -> np.ndarray:
        return np.array([value], dtype=dtype)

    return {
        "crop": record.crop[None].astype(np.float32),
        "label": one(tangled_label(outcome), np.int8),
        "score": one(c.score), "u": one(c.u), "v": one(c.v), "angle_deg": one(c.angle_deg),
        "depth_m": one(c.depth_m), "width_m": one(c.width_m),
        "rank": one(record.rank, np.int16), "pile_seed": one(pile_seed, np.int64),
        "task": one(task, np.int64),
        # What the labelling simulator of `collect` counts; a pick log does not.
        "num_in_region": one(-1, np.int16), "num_lifted": one(-1, np.int16),
        "num_hanging": one(-1, np.int16), "target": one(-1, np.int16),
        "outcome": one(outcome, np.int8), "weighed_parts": one(weighed),
        "sim_lifted": one(-1 if record.truth.lifted is None else record.truth.lifted, np.int16),
        "sim_held": one(-1 if record.truth.held is None else record.truth.held, np.int16),
        "pose": np.asarray(c.pose, dtype=np.float64)[None],
        "part": np.array([part]),
    }


class PickLog:
    """Appends each weighed grasp (with its crop) to the pick log at ``directory``."""

    def __init__(self, directory: Path, identity: dict) -> None:
        self._store = DatasetStore(Path(directory), identity)
        self._part = identity["part"]
        self.pile_seed = int(time.time())
        """The pile the grasps are made on (the training split's unit): a simulated pile's
        seed; on hardware, where one run empties one real bin, the run's start time."""
        self.logged = 0
        self.skipped = 0
        """Grasps that could not label themselves (no crop, or never weighed)."""

    @property
    def notices(self) -> list[str]:
        return self._store.notices

    @property
    def directory(self) -> Path:
        return self._store.directory

    def add(self, record: PickRecord) -> None:
        """Log ``record`` as the next task, if it was tried, cropped and weighed."""
        if record.crop is None or record.verdict is None or record.candidate is None:
            self.skipped += 1
            return
        task = max(self._store.finished, default=-1) + 1
        label = {Verdict.SEVERAL: 1, Verdict.ONE: 0}.get(record.verdict)
        self._store.add(TaskResult(task, pick_sample(record, self.pile_seed, task, self._part),
                                   {"samples": 1, "tangled": int(label == 1),
                                    "lifts": int(label is not None)}))
        self.logged += 1

    def close(self) -> None:
        self._store.close()
