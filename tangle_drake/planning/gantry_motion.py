"""``GantryMotion``: picks for the floating gripper's 4-axis gantry, as the planner's ``Motion``.

The gantry (``models/gantry``: x, y, z slides and a yaw turn, each a PD servo) carries the
parallel-jaw gripper pointing straight down, so a grasp pose *is* a command: no IK, no arm to
collide with, straight legs. Fast to plan and to simulate, which is what the benchmark's many
trials need (``diagrams/floating_gripper.yaml``; ``examples/floating_gripper.py``).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from pydrake.math import RigidTransform
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.failures import FailureKind
from tangle_drake.drivers.joint_position import gantry_home
from tangle_drake.drivers.limits import RobotLimits
from tangle_drake.planning.grasp_poses import ApproachSettings, pick_poses
from tangle_drake.planning.motion import PickMotion, PlanningError, ShakeSettings, StirMotion
from tangle_drake.planning.trajectory import MIN_DURATION, chain, hold, rest_to_rest
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import PLANNING_SLOW_SPEED
from tangle_drake.scenario import BinConfig

VELOCITY = np.array([0.5, 0.5, 0.5, 2.0])
"""Gantry speeds near the pile and with a part: m/s for the slides, rad/s for the turn."""
ACCELERATION = np.array([2.0, 2.0, 2.0, 6.0])
"""m/s², rad/s²."""
FREE_VELOCITY = np.array([1.0, 1.0, 1.0, 4.0])
"""Limits of the empty gripper's moves that touch nothing (from home to above the grasp,
and down to where the slow stretch begins), so they may go faster."""
FREE_ACCELERATION = np.array([5.0, 5.0, 5.0, 15.0])
PLACE_DROP = 0.1
"""Without a tray, the part is released this far below the parked gantry and falls to the
floor, m."""


class GantryMotion:
    """``Motion`` for the gantry: a grasp pose *is* a command (no IK), legs are straight.

    ``limits`` are the gantry model's (``drivers.limits.station_limits`` of its scenario): its
    travel. ``return_home=False`` ends the pick at the top of the lift (the transfer, the way
    home and the retreat are empty): enough to count what came up, which is all the open-loop
    benchmark asks. ``place`` is where the tool centre releases a part (over the tray).
    """

    command_size = 4
    measured_size = 8

    def __init__(self, bin_config: BinConfig, limits: RobotLimits,
                 approach: ApproachSettings | None = None, return_home: bool = True,
                 model: str = "gantry", place: np.ndarray | None = None,
                 shake: ShakeSettings | None = None) -> None:
        if len(limits.joint_names) != self.command_size:
            raise TangleDrakeError(f"the gantry model {model!r} must have 4 joints")
        self.command_port = f"{model}.position"
        self.measured_port = f"{model}.state_measured"
        self.bin = bin_config
        self.home = gantry_home(bin_config)
        # Gantry coordinates: the yaw link sits above the tool centre by the TCP offset.
        self.place = self.home[:3] - np.array([0.0, 0.0, PLACE_DROP]) if place is None \
            else np.asarray(place, float) + np.array([0.0, 0.0, DEFAULT_GRIPPER.tcp_offset])
        self.approach = approach or ApproachSettings()
        self.shake = shake or ShakeSettings()
        self.return_home = return_home
        self.lower = limits.position_lower.copy()
        self.upper = limits.position_upper.copy()

    def hold_command(self, measured: np.ndarray) -> np.ndarray:
        return np.asarray(measured[:4], float).copy()

    def tool_height(self, measured: np.ndarray) -> float:
        return float(measured[2])  # the gantry's z is T's (command_for)

    def command_for(self, X_WT: RigidTransform, yaw_near: float) -> np.ndarray:
        """Gantry coordinates putting T at ``X_WT``, yaw the twin nearer ``yaw_near``."""
        if X_WT.rotation().col(2)[2] > -0.999:
            raise PlanningError(FailureKind.UNREACHABLE, "the gantry can only point straight down")
        y_axis = X_WT.rotation().col(1)  # T's y = (sin yaw, -cos yaw, 0) under this weld
        yaw = math.atan2(y_axis[0], -y_axis[1])
        twins = [a for a in (yaw, yaw - math.pi, yaw + math.pi)
                 if self.lower[3] <= a <= self.upper[3]]
        yaw = min(twins, key=lambda a: abs(a - yaw_near))  # atan2's range: one always fits
        q = np.array([*X_WT.translation(), yaw])
        q[2] += DEFAULT_GRIPPER.tcp_offset  # the yaw link sits above T by the TCP offset
        if np.any(q < self.lower) or np.any(q > self.upper):
            raise PlanningError(FailureKind.UNREACHABLE, "outside the gantry's travel")
        return q

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray,
                  tips_above: float | None = None) -> PickMotion:
        q_now = self.hold_command(measured)
        X_grasp = RigidTransform(np.asarray(X_WT, float))
        poses = pick_poses(X_grasp, self.bin, self.approach)
        pre, slow, grasp, lift = (self.command_for(X, q_now[3]) for X in
                                  (poses.pregrasp, poses.slow_start, poses.grasp, poses.lift))
        if tips_above is not None:  # higher, as far as the gantry's travel allows
            high = pick_poses(X_grasp, self.bin, self.approach, tips_above=tips_above).lift
            lift[2] = max(lift[2], min(high.translation()[2] + DEFAULT_GRIPPER.tcp_offset,
                                       self.upper[2]))

        leg = _leg
        if self.return_home:
            place = np.array([*self.place, lift[3]])
            transfer, home, retreat = leg(lift, place), leg(place, self.home), leg(lift, self.home)
        else:
            transfer = home = retreat = hold(lift, MIN_DURATION)
        up_slowly = leg(grasp, slow, PLANNING_SLOW_SPEED)
        return PickMotion(
            approach=leg(q_now, pre, free=True),
            descend=chain([leg(pre, slow, free=True), leg(slow, grasp, PLANNING_SLOW_SPEED)]),
            lift=chain([up_slowly, leg(slow, lift)]),
            transfer=transfer, home=home, retreat=retreat,
            back_out=chain([up_slowly, leg(slow, pre, free=True), leg(pre, q_now, free=True)]),
            X_WT=poses.grasp.GetAsMatrix4())

    def plan_shake(self, hold_command: np.ndarray) -> PiecewisePolynomial:
        s = self.shake
        points = [np.asarray(hold_command, float) + np.array([0.0, 0.0, dz, 0.0])
                  for dz in s.offsets()]
        if any(np.any(p < self.lower) or np.any(p > self.upper) for p in points):
            raise PlanningError(FailureKind.UNREACHABLE, "the shake leaves the gantry's travel")
        velocity = np.array([s.speed] * 3 + [VELOCITY[3]])
        acceleration = np.array([s.acceleration] * 3 + [ACCELERATION[3]])
        starts = [np.asarray(hold_command, float), *points[:-1]]
        return chain([rest_to_rest(a, b, velocity, acceleration)
                      for a, b in zip(starts, points, strict=True)])

    def plan_lower(self, hold_command: np.ndarray, X_WT: np.ndarray,
                   clearance: float) -> PiecewisePolynomial:
        start = np.asarray(hold_command, float)
        grasp_z = float(np.asarray(X_WT)[2, 3]) + DEFAULT_GRIPPER.tcp_offset
        end = start.copy()
        end[2] = min(start[2], grasp_z + clearance)
        return _leg(start, end, PLANNING_SLOW_SPEED)

    def plan_line(self, start: np.ndarray, end: np.ndarray) -> PiecewisePolynomial:
        return _leg(np.asarray(start, float), np.asarray(end, float))

    def plan_stir(self, hold_command: np.ndarray, poses: list[np.ndarray],
                  speed: float) -> StirMotion:
        start = np.asarray(hold_command, float)
        points = [self.command_for(RigidTransform(np.asarray(X, float)), start[3])
                  for X in poses]
        return StirMotion(_leg(start, points[0], free=True),
                          chain([_leg(a, b, speed) for a, b in itertools.pairwise(points)]),
                          _leg(points[-1], self.home))


def _leg(a: np.ndarray, b: np.ndarray, speed: float = math.inf,
         free: bool = False) -> PiecewisePolynomial:
    """A straight gantry move, the tool's speed capped at ``speed``; ``free``: an empty
    gripper's move that touches nothing, at the faster limits."""
    return rest_to_rest(a, b, FREE_VELOCITY if free else VELOCITY,
                        FREE_ACCELERATION if free else ACCELERATION,
                        float(np.linalg.norm(b[:3] - a[:3])), speed)

