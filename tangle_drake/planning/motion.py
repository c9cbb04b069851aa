"""What the pick state machine needs from a manipulator, so the arm is a pluggable part.

The state machine (``PickPlanner``) decides *when* to move; a ``Motion`` decides *how*: it
names the command and measurement ports of its manipulator and plans one whole pick for a
grasp pose. The Nextage arm's ``ArmMotion`` (IK, collision checks, joint trajectories) is one;
the gantry's free-floating gripper, which takes pose commands directly, is another
(:mod:`tangle_drake.planning.gantry_motion`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.failures import FailureKind


class PlanningError(Exception):
    """A grasp the manipulator cannot execute; the planner records it and tries the next one."""

    def __init__(self, kind: FailureKind, detail: str) -> None:
        super().__init__(f"{kind.value}: {detail}")
        self.kind = kind
        """``UNREACHABLE`` (no IK solution within the limits) or ``COLLISION``."""
        self.detail = detail


@dataclass(frozen=True)
class PickMotion:
    """One planned pick: a trajectory of commands per moving phase, each starting at t = 0.

    The approach ends with the open fingers above the grasp, the descent at the grasp, the
    lift clear of the bin, the transfer over the place location, and home where the robot
    waits while the camera looks.
    """

    approach: PiecewisePolynomial
    descend: PiecewisePolynomial
    lift: PiecewisePolynomial
    transfer: PiecewisePolynomial
    home: PiecewisePolynomial
    X_WT: np.ndarray
    """The grasp pose used (4x4): the candidate's, or its twin turned 180° about the approach,
    pressed a little deeper (:mod:`tangle_drake.planning.grasp_poses`)."""


class Motion(Protocol):
    """A manipulator the pick state machine can drive."""

    command_port: str
    """Name of the planner's command output port (e.g. ``nextage.position``)."""
    command_size: int
    measured_port: str
    """Name of the planner's measured-state input port (e.g. ``nextage.state_measured``)."""
    measured_size: int

    def hold_command(self, measured: np.ndarray) -> np.ndarray:
        """The command that keeps the manipulator where ``measured`` says it is."""

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray) -> PickMotion:
        """The whole pick for tool pose ``X_WT`` from the state ``measured``; raises
        :class:`PlanningError` when it cannot be done."""
