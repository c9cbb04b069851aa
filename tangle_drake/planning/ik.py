"""Inverse kinematics of the left arm for a tool pose, seeded from the current configuration.

One nonlinear program per pose (Drake's ``InverseKinematics``, solved by SNOPT where the build
has it): the tool frame T on the target position, its orientation within a tolerance (or only
its approach axis, for poses where the rotation about it does not matter), the arm's joints
within their limits less a margin, every other joint fixed at the seed's value, and a cost that
keeps the arm near the seed, so consecutive waypoints get consecutive solutions. A failed local
solve is retried from a few fixed seeds before the pose counts as unreachable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import Solve

from tangle_drake.planning.planning_model import PlanningModel
from tangle_drake.robot_model.nextage import HOME, INIT_RTM

_INFLUENCE_MARGIN = 0.02
"""Pairs closer than the bound plus this shape the distance constraint's gradient, m."""


@dataclass(frozen=True)
class IkSettings:
    """Tolerances and freedoms of the arm's IK."""

    position_tolerance: float = 5e-4
    """Half-width of the box the tool centre must land in, m."""
    angle_tolerance: float = 0.01
    """Largest rotation between the tool's and the target's orientation, rad."""
    joint_margin: float = 0.02
    """Joint limits are shrunk by this at both ends, rad: the servos track a little behind."""
    use_chest: bool = False
    """Let CHEST_JOINT0 turn too (off: the chest stays where the seed has it)."""


class ArmIk:
    """IK for the left arm's tool frame on one :class:`PlanningModel`."""

    def __init__(self, model: PlanningModel, settings: IkSettings | None = None) -> None:
        self.model = model
        self.settings = settings or IkSettings()
        free = list(model.arm_indices)
        if self.settings.use_chest:
            free.append(model.chest_index)
        self.free = np.array(sorted(free))
        """Indices in the full q that IK may move."""
        margin = self.settings.joint_margin
        self._lower = model.lower[self.free] + margin
        self._upper = model.upper[self.free] - margin
        self._fallback_seeds = [model.full_q(HOME), model.full_q(INIT_RTM)]

    def solve(self, X_WT: RigidTransform, seed: np.ndarray, free_yaw: bool = False,
              min_distance: float | None = None) -> np.ndarray | None:
        """A full q putting T at ``X_WT``, or ``None`` where no seed leads to one.

        ``free_yaw``: only T's position and approach axis (+z) count, any rotation about it.
        ``min_distance``: every unfiltered geometry pair (robot-bin, robot-robot) keeps at
        least this signed distance, m; slower, so callers try without it first. Joints IK
        may not move keep the values of ``seed``.
        """
        for start in [seed, *self._fallback_seeds]:
            start = start.copy()
            start[self.free] = np.clip(start[self.free], self._lower, self._upper)
            q = self._solve_from(X_WT, seed, start, free_yaw, min_distance)
            if q is not None:
                return q
        return None

    def _solve_from(self, X_WT: RigidTransform, seed: np.ndarray, start: np.ndarray,
                    free_yaw: bool, min_distance: float | None) -> np.ndarray | None:
        model = self.model
        ik = InverseKinematics(model.plant, model.plant_context, with_joint_limits=False)
        q = ik.q()
        prog = ik.get_mutable_prog()
        lower, upper = seed.copy(), seed.copy()
        lower[self.free], upper[self.free] = self._lower, self._upper
        prog.AddBoundingBoxConstraint(lower, upper, q)
        tol = self.settings.position_tolerance
        p = X_WT.translation()
        ik.AddPositionConstraint(model.tcp, np.zeros(3), model.plant.world_frame(), p - tol,
                                 p + tol)
        if free_yaw:
            ik.AddAngleBetweenVectorsConstraint(
                model.plant.world_frame(), X_WT.rotation().col(2), model.tcp,
                np.array([0.0, 0.0, 1.0]), 0.0, self.settings.angle_tolerance)
        else:
            ik.AddOrientationConstraint(model.plant.world_frame(), X_WT.rotation(), model.tcp,
                                        RotationMatrix(), self.settings.angle_tolerance)
        if min_distance is not None:
            ik.AddMinimumDistanceLowerBoundConstraint(min_distance,
                                                      min_distance + _INFLUENCE_MARGIN)
        prog.AddQuadraticErrorCost(np.eye(len(self.free)), seed[self.free], q[self.free])
        result = Solve(prog, start)
        return result.GetSolution(q) if result.is_success() else None
