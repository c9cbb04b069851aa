"""One task's samples as the dataset's arrays (``tangle_drake.dataset``), row by row.

Beyond ``SAMPLE_FIELDS`` every sample records how the label came about: which parts came up
(bit ``n`` of a mask = pile part ``n``), which of them hang from the target or ride on it
(:mod:`.support`), how far the highest other part and the target rose, whether the target
stalled, the candidate's pose, the part type, and with ``--repeat`` how many of the K lifts
said *tangled*. Fields that only a lift can measure read -1 (counts, masks, flags) or NaN
(heights) when the label needed no lift.
"""

from __future__ import annotations

import numpy as np

from tangle_drake.dataset import SAMPLE_FIELDS, rows_to_arrays
from tangle_drake.graspability import GraspCandidate
from tangle_drake.tangle_data.labels import PickLabel
from tangle_drake.tangle_data.settings import CollectSettings

EXTRA_FIELDS = ("num_riding", "lifted_mask", "hanging_mask", "riding_mask", "max_rise_m",
                "target_rise_m", "stalled", "pose", "part")
"""The optional dataset fields every collection writes (``repeat_tangled`` and
``full_depth`` only when asked for)."""


def _mask(indices: tuple[int, ...]) -> int:
    return sum(1 << n for n in indices)


class SampleRows:
    """Accumulates a task's samples; :meth:`arrays` gives the shard's arrays."""

    def __init__(self, settings: CollectSettings, part_name: str,
                 full_depth: np.ndarray | None) -> None:
        self.settings = settings
        self.part_name = part_name
        self.full_depth = full_depth
        self.names = [*SAMPLE_FIELDS, *EXTRA_FIELDS]
        if settings.repeat > 1:
            self.names.append("repeat_tangled")
        if settings.full_depth:
            self.names.append("full_depth")
        self.rows: dict[str, list] = {name: [] for name in self.names}

    def add(self, crop: np.ndarray, candidate: GraspCandidate, rank: int, pile_seed: int,
            task: int, label: PickLabel, votes: int | None) -> None:
        lift = label.lift
        others = None if lift is None else np.delete(lift.rise, lift.target)
        row = {
            "crop": crop, "label": int(label.tangled), "score": candidate.score,
            "u": candidate.u, "v": candidate.v, "angle_deg": candidate.angle_deg,
            "depth_m": candidate.depth_m, "width_m": candidate.width_m, "rank": rank,
            "pile_seed": pile_seed, "task": task, "num_in_region": len(label.in_region),
            "num_lifted": -1 if lift is None else len(lift.lifted),
            "num_hanging": -1 if lift is None else len(lift.hanging),
            "target": label.target,
            "num_riding": -1 if lift is None else len(lift.riding),
            "lifted_mask": -1 if lift is None else _mask(lift.lifted),
            "hanging_mask": -1 if lift is None else _mask(lift.hanging),
            "riding_mask": -1 if lift is None else _mask(lift.riding),
            "max_rise_m": np.nan if lift is None else
            (float(others.max()) if others.size else 0.0),
            "target_rise_m": np.nan if lift is None else lift.target_rise,
            "stalled": -1 if lift is None else int(lift.stalled),
            "pose": candidate.pose, "part": self.part_name,
            "repeat_tangled": -1 if votes is None else votes,
            "full_depth": self.full_depth,
        }
        for name in self.names:
            self.rows[name].append(row[name])

    def arrays(self) -> dict[str, np.ndarray]:
        """The shard's arrays, with the right dtypes and shapes even when empty."""
        return rows_to_arrays(self.rows, {
            "crop": (self.settings.crop.size_px,) * 2, "pose": (4, 4),
            "full_depth": () if self.full_depth is None else self.full_depth.shape})
