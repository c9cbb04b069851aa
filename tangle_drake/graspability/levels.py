"""Depth levels: the scan from the top of the pile down, as one integer image.

Level ``k >= 1`` lies at depth ``z_top + (k - 1) * step`` (``z_top``: the work map's highest
point). Each cell's surface is snapped up to the level at or above it, so a surface counts as
"above level k" exactly when its level index is ``<= k``. Snapping up errs on the safe side
for the finger footprints (an obstacle is never seen lower than it is) and by less than one
step. Level 0 stands for "above everything": outside the map and outside the region of
interest (:mod:`.roi`), so no finger may go there and no closing region may hold it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.graspability.hand import HandModel
from tangle_drake.graspability.params import GraspabilityParams
from tangle_drake.graspability.workmap import WorkMap


@dataclass(frozen=True)
class Levels:
    """Level index per work-map cell (1 = the top), and what a level means in metres."""

    index: np.ndarray
    """(ny, nx) uint8 or uint16, from 1 (the top); the dtype leaves room for
    ``index + insertion``."""
    z_top: float
    step_m: float
    insertion: int
    """Fingertips go this many levels below the grasp level."""

    def tip_depth(self, level: int) -> float:
        """Depth of the fingertips for a grasp whose contact starts at ``level``."""
        return self.z_top + (level - 1 + self.insertion) * self.step_m


def quantize(work: WorkMap, hand: HandModel, params: GraspabilityParams) -> Levels:
    """The work map's depth levels, with the insertion depth checked against the fingers."""
    insertion = params.insertion_levels
    if (insertion + 1) * params.level_step_m > hand.finger_length_m:
        raise ValueError("insertion depth plus one level step exceeds the finger length: the "
                         "palm could touch what the fingers grasp")
    z_top = float(work.z.min())
    index = np.floor((work.z.astype(np.float64) - z_top) / params.level_step_m).astype(np.int64)
    index += 1
    if work.allowed is not None:
        index[~work.allowed] = 0
    top = int(index.max()) + insertion
    if top > np.iinfo(np.uint16).max:
        raise TangleDrakeError(f"the depth range {float(work.z.max()) - z_top:.3f} m holds too "
                               f"many levels of {params.level_step_m} m; use a coarser step")
    dtype = np.uint8 if top <= np.iinfo(np.uint8).max else np.uint16
    return Levels(index.astype(dtype), z_top, params.level_step_m, insertion)
