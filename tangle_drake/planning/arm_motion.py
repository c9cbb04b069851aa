"""``ArmMotion``: one whole pick for the Nextage's left arm, as the pick planner's ``Motion``.

For a grasp pose it solves IK for the pre-grasp, the start of the slow stretch, the grasp, the
lift and the place pose (each seeded from the one before, starting at the measured
configuration), checks every configuration and the joint-space lines between them against
the bin and the robot itself on the planning plant, and turns the lines into rest-to-rest
trajectories within the planning limits. The descent and the lift are Cartesian: their lines
are split (by IK at the midpoint) until the tool centre strays less than a tolerance from the
straight segment, run through without stopping, and their speed is capped in metres per
second (slowest next to the pile).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydrake.math import RigidTransform
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.common.failures import FailureKind
from tangle_drake.planning.grasp_poses import (
    ApproachSettings,
    pick_poses,
    pointing_down,
    symmetric_grasps,
)
from tangle_drake.planning.ik import ArmIk, IkSettings
from tangle_drake.planning.motion import PickMotion, PlanningError, ShakeSettings, StirMotion
from tangle_drake.planning.planning_model import PlanningModel
from tangle_drake.planning.trajectory import (
    chain,
    first_violation,
    rest_to_rest,
    through_waypoints,
)
from tangle_drake.robot_model.nextage import (
    HOME,
    NEXTAGE_JOINTS,
    PLANNING_ACCELERATION_LIMIT,
    PLANNING_SLOW_SPEED,
    PLANNING_VELOCITY_LIMIT,
)
from tangle_drake.scenario import BinConfig

_NUM_JOINTS = len(NEXTAGE_JOINTS)
_BOUND_MARGIN = 0.001
"""Added to IK's distance bound, m, so the solver's tolerance does not fail the check."""


@dataclass(frozen=True)
class ArmMotionSettings:
    """Limits, speeds and clearances of the arm's picks (SI units)."""

    velocity_limit: float = PLANNING_VELOCITY_LIMIT
    """Per joint, rad/s."""
    acceleration_limit: float = PLANNING_ACCELERATION_LIMIT
    """Per joint, rad/s²."""
    slow_speed: float = PLANNING_SLOW_SPEED
    """Tool-centre speed over the slow stretch next to the pile, m/s."""
    cartesian_speed: float = 0.2
    """Tool-centre speed over the rest of the descent and lift, m/s."""
    free_clearance: float = 0.01
    """Distance the robot keeps from the bin on free moves (approach, transfer, home), m."""
    near_clearance: float = 0.0
    """...and on the descent and lift, where the fingers go into the bin: no contact, m."""
    self_clearance: float = 0.001
    """Distance the robot keeps from itself, m."""
    straightness: float = 0.002
    """How far the tool centre may stray from the straight descent and lift, m."""
    free_step: float = 0.02
    """Joint-space spacing of collision checks on free moves, rad (the wrist moves about
    1 cm per 0.02 rad, covered by ``free_clearance``)."""
    near_step: float = 0.005
    """...on the descent and lift, rad."""
    place_position: tuple[float, float, float] | None = None
    """Where the tool centre releases the part (pointing down), world m. Default: where it
    is at ``home``, beside the bin to the robot's left, out of the camera's view; a released
    part falls to the floor there."""
    home: np.ndarray = field(default_factory=lambda: HOME.copy())
    """Where the robot waits while the camera looks (15 joints)."""
    shake: ShakeSettings = field(default_factory=ShakeSettings)
    """The shake's amplitude and cycles (its joint limits: ``velocity_limit`` and
    ``shake_acceleration``)."""
    shake_acceleration: float = 6.0
    """Per joint during a shake, rad/s²: brisker than the planning limit, within the robot's."""
    approach: ApproachSettings = field(default_factory=ApproachSettings)
    ik: IkSettings = field(default_factory=IkSettings)


class ArmMotion:
    """Plans picks for the Nextage's left arm over ``bin_config`` (see the module docstring).

    Commands are the station's ``nextage.position`` (15 joints); the measured state is
    ``nextage.state_measured`` (15 positions, 15 velocities).
    """

    command_port = "nextage.position"
    command_size = _NUM_JOINTS
    measured_port = "nextage.state_measured"
    measured_size = 2 * _NUM_JOINTS

    def __init__(self, bin_config: BinConfig, settings: ArmMotionSettings | None = None,
                 model: PlanningModel | None = None, tray: BinConfig | None = None) -> None:
        self.settings = settings or ArmMotionSettings()
        self.model = model or PlanningModel(bin_config, tray=tray)
        self.ik = ArmIk(self.model, self.settings.ik)
        self.bin = bin_config
        self.q_home = self.model.full_q(self.settings.home)
        place = self.settings.place_position
        self.X_place = None if place is None else pointing_down(place)

    def hold_command(self, measured: np.ndarray) -> np.ndarray:
        return np.asarray(measured[:_NUM_JOINTS], float).copy()

    def tool_height(self, measured: np.ndarray) -> float:
        q = self.model.full_q(np.asarray(measured[:_NUM_JOINTS], float))
        return float(self.model.tcp_pose(q).translation()[2])

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray,
                  tips_above: float | None = None) -> PickMotion:
        """Plan the grasp or its 180° twin, the one nearer the current wrist angle first."""
        q_now = self.model.full_q(measured[:_NUM_JOINTS])
        current = self.model.tcp_pose(q_now).rotation()
        errors = []
        for X_grasp in symmetric_grasps(RigidTransform(np.asarray(X_WT, float)), current):
            try:
                return self._plan(X_grasp, q_now, tips_above)
            except PlanningError as error:
                errors.append(error)
        # A twin that got as far as a collision says more than one that was out of reach.
        raise next((e for e in errors if e.kind is FailureKind.COLLISION), errors[0])

    def _plan(self, X_grasp: RigidTransform, q_now: np.ndarray,
              tips_above: float | None) -> PickMotion:
        poses = pick_poses(X_grasp, self.bin, self.settings.approach, self.model.spec)
        q_pre = self._solve(poses.pregrasp, q_now, "pre-grasp", free=True)
        q_slow = self._solve(poses.slow_start, q_pre, "slow-start", free=False)
        q_grasp = self._solve(poses.grasp, q_slow, "grasp", free=False)
        q_lift = self._lift(X_grasp, q_pre, tips_above) if tips_above is not None else None
        if q_lift is None:
            q_lift = self._solve(poses.lift, q_pre, "lift", free=True)
        q_place = self.q_home if self.X_place is None else self._solve(
            self.X_place, q_lift, "place", free=True, free_yaw=True)

        approach = self._free_path([q_now, q_pre], [q_now, q_lift, q_pre], "approach")
        s = self.settings
        fast = self._straight(q_pre, q_slow, "descent")
        slow = self._straight(q_slow, q_grasp, "descent")
        # Planned in this order, so the first leg that fails is the one reported.
        descend = chain([self._legs(fast, s.cartesian_speed), self._legs(slow, s.slow_speed)])
        up_slowly = self._legs(slow[::-1], s.slow_speed)
        lift = chain([up_slowly,
                      self._legs(self._straight(q_slow, q_lift, "lift"), s.cartesian_speed)])
        back_out = chain([up_slowly, self._legs(fast[::-1], s.cartesian_speed),
                          self._legs(approach[::-1])])
        transfer = self._legs(self._free_path([q_lift, q_place], None, "transfer"))
        home = self._legs(self._free_path([q_place, self.q_home], None, "return home")
                          if self.X_place is not None else [self.q_home, self.q_home])
        try:  # straight home from the lift; else the way the transfer and return go
            retreat = self._legs(self._free_path([q_lift, self.q_home], None, "retreat"))
        except PlanningError:
            retreat = chain([transfer, home])
        return PickMotion(
            approach=self._legs(approach), descend=descend, lift=lift,
            transfer=transfer, home=home, retreat=retreat, back_out=back_out,
            X_WT=poses.grasp.GetAsMatrix4())

    def _lift(self, X_grasp: RigidTransform, q_pre: np.ndarray,
              tips_above: float) -> np.ndarray | None:
        """The top of a lift taking the fingertips up to ``tips_above``; ``None`` where the arm
        cannot reach it (the lift then goes as high as the approach's settings say)."""
        X_lift = pick_poses(X_grasp, self.bin, self.settings.approach, self.model.spec,
                            tips_above).lift
        try:
            return self._solve(X_lift, q_pre, "lift", free=True)
        except PlanningError:
            return None

    def plan_shake(self, hold: np.ndarray) -> PiecewisePolynomial:
        """Up and down by the shake's offsets, by IK from the held pose, checked clear."""
        q_hold = self.model.full_q(hold)
        X_hold = self.model.tcp_pose(q_hold)
        configurations = []
        for dz in self.settings.shake.offsets():
            X = RigidTransform(X_hold.rotation(), X_hold.translation() + np.array([0.0, 0.0, dz]))
            configurations.append(q_hold if dz == 0.0 else
                                  self._solve(X, q_hold, "shake", free=False))
        s = self.settings
        path = [self.model.nextage_q(q) for q in [q_hold, *configurations]]
        return chain([rest_to_rest(a, b, s.velocity_limit, s.shake_acceleration)
                      for a, b in itertools.pairwise(path)])

    def plan_lower(self, hold: np.ndarray, X_WT: np.ndarray,
                   clearance: float) -> PiecewisePolynomial:
        """Straight down to ``clearance`` above the grasp, at the slow speed."""
        q_hold = self.model.full_q(hold)
        X_hold = self.model.tcp_pose(q_hold)
        z = min(X_hold.translation()[2], float(np.asarray(X_WT)[2, 3]) + clearance)
        X_low = RigidTransform(X_hold.rotation(), [*X_hold.translation()[:2], z])
        q_low = self._solve(X_low, q_hold, "put-back", free=False)
        return self._legs(self._straight(q_hold, q_low, "put-back"), self.settings.slow_speed)

    def plan_line(self, start: np.ndarray, end: np.ndarray) -> PiecewisePolynomial:
        s = self.settings
        return rest_to_rest(start, end, s.velocity_limit, s.acceleration_limit)

    def plan_stir(self, hold: np.ndarray, poses: list[np.ndarray], speed: float) -> StirMotion:
        """The sweep or its 180° twin (the palm is symmetric), the one nearer the current
        wrist angle first: IK for each pose, straight Cartesian legs between them, checked
        clear of the bin and the robot, then home."""
        q_hold = self.model.full_q(hold)
        current = self.model.tcp_pose(q_hold).rotation()
        first = RigidTransform(np.asarray(poses[0], float))
        errors = []
        for twin in symmetric_grasps(first, current):
            turn = first.rotation().inverse() @ twin.rotation()
            turned = [RigidTransform(RigidTransform(np.asarray(X, float)).rotation() @ turn,
                                     np.asarray(X, float)[:3, 3]) for X in poses]
            try:
                return self._stir(q_hold, turned, speed)
            except PlanningError as error:
                errors.append(error)
        raise next((e for e in errors if e.kind is FailureKind.COLLISION), errors[0])

    def _stir(self, q_hold: np.ndarray, poses: list[RigidTransform], speed: float) -> StirMotion:
        above = self._solve(poses[0], q_hold, "stir's start", free=True)
        path = [above]
        for X in poses[1:-1]:
            path.append(self._solve(X, path[-1], "stir", free=False))
        path.append(self._solve(poses[-1], path[-1], "stir's end", free=True))
        sweep = chain([self._legs(self._straight(a, b, "stir"), speed)
                       for a, b in itertools.pairwise(path)])
        return StirMotion(
            self._legs(self._free_path([q_hold, above], None, "move to the stir")), sweep,
            self._legs(self._free_path([path[-1], self.q_home], None, "way home from the stir")))

    def _solve(self, X_WT: RigidTransform, seed: np.ndarray, name: str, free: bool,
               free_yaw: bool = False) -> np.ndarray:
        """IK for one pose, clear of the bin and the robot.

        Without the distance constraint first, as most poses come out clear. Only where the
        pose leaves the arm a free degree (a free yaw, or the chest) can the constraint find
        another solution; with six constraints on six joints it would only search in vain.
        """
        q = self.ik.solve(X_WT, seed, free_yaw=free_yaw)
        if q is None:
            raise PlanningError(FailureKind.UNREACHABLE, f"no IK solution for the {name} pose")
        if self._is_clear(q, free):
            return q
        if free_yaw or self.ik.settings.use_chest:
            s = self.settings
            bound = max(s.free_clearance if free else s.near_clearance, s.self_clearance)
            q = self.ik.solve(X_WT, seed, free_yaw=free_yaw, min_distance=bound + _BOUND_MARGIN)
            if q is not None and self._is_clear(q, free):
                return q
        raise PlanningError(FailureKind.COLLISION, f"the {name} pose hits the bin or the robot")

    def _is_clear(self, q: np.ndarray, free: bool) -> bool:
        s = self.settings
        clearance = self.model.clearance(q)
        return (clearance.to_bin >= (s.free_clearance if free else s.near_clearance)
                and clearance.to_self >= s.self_clearance)

    def _free_path(self, path: list[np.ndarray], detour: list[np.ndarray] | None,
                   name: str) -> list[np.ndarray]:
        """``path`` if its lines are clear, else ``detour`` if given and clear."""
        for candidate in (path, detour):
            if candidate is not None and first_violation(
                    candidate, self.settings.free_step, lambda q: self._is_clear(q, True)) is None:
                return candidate
        raise PlanningError(FailureKind.COLLISION, f"the {name} move hits the bin or the robot")

    def _straight(self, q0: np.ndarray, q1: np.ndarray, name: str,
                  depth: int = 0) -> list[np.ndarray]:
        """Waypoints from ``q0`` to ``q1`` whose lines keep the tool centre on the straight
        segment between their ends (split by IK at the midpoint, at most three times)."""
        p0, p1 = self.model.tcp_pose(q0).translation(), self.model.tcp_pose(q1).translation()
        if self._deviation(q0, q1, p0, p1) > self.settings.straightness and depth < 3:
            X_mid = RigidTransform(self.model.tcp_pose(q0).rotation(), (p0 + p1) / 2)
            q_mid = self.ik.solve(X_mid, (q0 + q1) / 2)
            if q_mid is None:
                raise PlanningError(FailureKind.UNREACHABLE, f"no IK solution along the {name}")
            return (self._straight(q0, q_mid, name, depth + 1)[:-1]
                    + self._straight(q_mid, q1, name, depth + 1))
        if first_violation([q0, q1], self.settings.near_step,
                           lambda q: self._is_clear(q, False)) is not None:
            raise PlanningError(FailureKind.COLLISION, f"the {name} hits the bin or the robot")
        return [q0, q1]

    def _deviation(self, q0: np.ndarray, q1: np.ndarray, p0: np.ndarray,
                   p1: np.ndarray) -> float:
        """Largest distance of the tool centre from segment p0-p1 along the joint line."""
        axis = p1 - p0
        length = float(np.linalg.norm(axis))
        worst = 0.0
        for s in (0.25, 0.5, 0.75):
            p = self.model.tcp_pose(q0 + s * (q1 - q0)).translation() - p0
            along = float(p @ axis) / length if length > 0 else 0.0
            worst = max(worst, float(np.linalg.norm(p - along * axis / max(length, 1e-12))))
        return worst

    def _legs(self, path: Sequence[np.ndarray], tcp_speed: float = np.inf) -> PiecewisePolynomial:
        """One move through the waypoints, in the station's 15 joints: a free move stops at
        each (its lines are what was checked), a Cartesian one (``tcp_speed`` finite) runs
        through its nearly collinear waypoints without stopping."""
        s = self.settings
        nextage = [self.model.nextage_q(q) for q in path]
        lengths = [float(np.linalg.norm(self.model.tcp_pose(q1).translation()
                                        - self.model.tcp_pose(q0).translation()))
                   for q0, q1 in itertools.pairwise(path)]
        if np.isfinite(tcp_speed):
            return through_waypoints(nextage, s.velocity_limit, s.acceleration_limit,
                                     sum(lengths), tcp_speed)
        return chain([rest_to_rest(q0, q1, s.velocity_limit, s.acceleration_limit)
                      for q0, q1 in itertools.pairwise(nextage)])
