"""The tool poses of one pick, derived from the grasp candidate's pose ``X_WT``.

The grasp itself goes a few millimetres deeper than the candidate (never into the bin's floor):
the graspability index puts the fingertips just below the middle of the top wire, where the
compliant pads' lower edge squeezes a round wire out under the tips, so at the candidate's own
depth most grasps come up empty (``docs/results/history.md``). Above the grasp: a pre-grasp
back along the approach axis, high enough that the fingertips clear the bin's rim; a point a
few centimetres above the grasp where the slow part of the descent starts; after the grasp, the
lift pose above the pre-grasp, moved in from the walls where the pre-grasp is near one: a part
hanging from the gripper (or from the part it holds), or dropping off it at the top of the lift
where the load is weighed and shaken, then comes down in the bin, not over its wall (in bin
clearing, most lost parts left the bin during a lift). The parallel gripper is symmetric, so a
grasp turned 180° about the approach axis is the same grasp: the twin whose closing direction
is nearer the tool's current one needs the least wrist travel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix

from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import BinConfig


@dataclass(frozen=True)
class ApproachSettings:
    """Distances of the pick's waypoints, m."""

    approach_height: float = 0.06
    """The pre-grasp is at least this far back from the grasp along the approach axis."""
    rim_clearance: float = 0.02
    """...and its fingertips at least this far above the bin's rim."""
    slow_distance: float = 0.03
    """The last stretch of the descent (and the first of the lift) that is run slowly."""
    lift_height: float = 0.12
    """After the lift the tool centre is at least this far above the rim: a part hanging from
    the grasped one is then out of the bin too, where it can be counted (in a one-layer pile of
    short parts; a deeper pile or longer parts need ``pick_poses``'s ``tips_above``)."""
    lift_margin: float = 0.06
    """...and at least this far in from every wall (or over the bin's middle, where the bin
    is narrower than twice this), m."""
    press_depth: float = 0.004
    """The grasp goes this much deeper along the approach than the candidate says..."""
    floor_clearance: float = 0.001
    """...but keeps the fingertips this far above the bin's floor."""

    def __post_init__(self) -> None:
        if self.press_depth < 0 or self.floor_clearance < 0:
            raise ValueError("ApproachSettings.press_depth and floor_clearance must be >= 0")
        for name in ("approach_height", "rim_clearance", "slow_distance", "lift_height"):
            if not getattr(self, name) > 0:
                raise ValueError(f"ApproachSettings.{name} must be positive")
        if self.lift_margin < 0:
            raise ValueError("ApproachSettings.lift_margin must be >= 0")
        if self.slow_distance > self.approach_height:
            raise ValueError("ApproachSettings.slow_distance cannot exceed approach_height")


@dataclass(frozen=True)
class PickPoses:
    """Tool poses X_WT of one pick, in the order the descent passes them (then the lift)."""

    pregrasp: RigidTransform
    slow_start: RigidTransform
    grasp: RigidTransform
    lift: RigidTransform


def pick_poses(X_WT: RigidTransform, bin_config: BinConfig,
               settings: ApproachSettings | None = None,
               spec: GripperSpec = DEFAULT_GRIPPER, tips_above: float | None = None) -> PickPoses:
    """The waypoints for the grasp candidate at ``X_WT`` in the bin ``bin_config``; the lift
    also takes the fingertips up to the world height ``tips_above``, where given (the pile's
    top plus what may hang from the grasp, so that it is weighed clear of the pile)."""
    settings = settings or ApproachSettings()
    R = X_WT.rotation()
    approach = R.col(2)
    tips_below_tcp = spec.reach - spec.tcp_offset
    p_grasp = X_WT.translation()
    press = settings.press_depth
    if approach[2] < -0.1:  # pointing down: the floor limits how deep the tips go
        tips_over_floor = (p_grasp[2] + tips_below_tcp * approach[2] - bin_config.floor_height
                           - settings.floor_clearance)
        press = float(np.clip(tips_over_floor / -approach[2], 0.0, press))
    p_grasp = p_grasp + press * approach
    back = settings.approach_height
    rim_height = bin_config.floor_height + bin_config.wall_height
    if approach[2] < -0.1:  # go back until the fingertips clear the rim
        clear_z = rim_height + settings.rim_clearance + tips_below_tcp
        back = max(back, (clear_z - p_grasp[2]) / -approach[2])
    p_pre = p_grasp - back * approach
    centre = np.asarray(bin_config.center, float)
    room = np.maximum(np.asarray(bin_config.inner_size, float) / 2 - settings.lift_margin, 0.0)
    lift_z = max(p_pre[2], rim_height + settings.lift_height)
    if tips_above is not None:
        lift_z = max(lift_z, tips_above + tips_below_tcp)
    p_lift = np.array([*np.clip(p_pre[:2], centre - room, centre + room), lift_z])
    return PickPoses(RigidTransform(R, p_pre),
                     RigidTransform(R, p_grasp - settings.slow_distance * approach),
                     RigidTransform(R, p_grasp), RigidTransform(R, p_lift))


def symmetric_grasps(X_WT: RigidTransform, current: RotationMatrix) -> list[RigidTransform]:
    """``X_WT`` and its twin turned 180° about the approach axis (T's z), the one whose
    closing direction (T's y) is nearer that of the tool's ``current`` orientation first."""
    twin = X_WT @ RigidTransform(RotationMatrix.MakeZRotation(np.pi))
    nearer = float(X_WT.rotation().col(1) @ current.col(1)) >= 0.0
    return [X_WT, twin] if nearer else [twin, X_WT]


def pointing_down(p_W: np.ndarray) -> RigidTransform:
    """A tool pose at ``p_W`` with the approach axis straight down (yaw arbitrary)."""
    return RigidTransform(RotationMatrix.MakeXRotation(np.pi), np.asarray(p_W, float))
