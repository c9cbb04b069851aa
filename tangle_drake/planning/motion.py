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

from tangle_drake.common.failures import FailureKind


class PlanningError(Exception):
    """A grasp the manipulator cannot execute; the planner records it and tries the next one."""

    def __init__(self, kind: FailureKind, detail: str) -> None:
        super().__init__(f"{kind.value}: {detail}")
        self.kind = kind
        """``UNREACHABLE`` (no IK solution within the limits) or ``COLLISION``."""
        self.detail = detail


@dataclass(frozen=True)
class ShakeSettings:
    """The up-and-down shake that makes a second part let go of the one held (SI units)."""

    amplitude: float = 0.02
    """How far the tool goes up and down from where it was, m."""
    cycles: int = 2
    acceleration: float = 6.0
    """The tool centre's acceleration limit, m/s² (well under g, so a held part stays put)."""
    speed: float = 0.5
    """The tool centre's speed limit, m/s."""

    def __post_init__(self) -> None:
        if not (self.amplitude > 0 and self.cycles >= 1 and self.acceleration > 0
                and self.speed > 0):
            raise ValueError("ShakeSettings: amplitude, acceleration and speed must be "
                             "positive, cycles at least 1")

    def offsets(self) -> list[float]:
        """The vertical offsets the tool visits, in order, ending at 0."""
        return [*[sign * self.amplitude for _ in range(self.cycles) for sign in (-1, 1)], 0.0]


@dataclass(frozen=True)
class PickMotion:
    """One planned pick: a trajectory of commands per moving phase, each starting at t = 0.

    The approach ends with the open fingers above the grasp, the descent at the grasp, the
    lift clear of the bin, the transfer over the place location (the output tray), home where
    the robot waits while the camera looks, and the retreat goes from the top of the lift
    straight home (after an empty grasp, or a load put back). The back-out goes from the grasp
    the way the descent and the approach came, back to where the approach began: for fingers
    found closed on nothing early in the lift, which then need not go up and over to home.
    It begins as the lift does (the slow stretch up from the grasp), so the planner can switch
    to it there without a jump.
    """

    approach: PiecewisePolynomial
    descend: PiecewisePolynomial
    lift: PiecewisePolynomial
    transfer: PiecewisePolynomial
    home: PiecewisePolynomial
    retreat: PiecewisePolynomial
    back_out: PiecewisePolynomial
    X_WT: np.ndarray
    """The grasp pose used (4x4): the candidate's, or its twin turned 180° about the approach,
    pressed a little deeper (:mod:`tangle_drake.planning.grasp_poses`)."""


@dataclass(frozen=True)
class StirMotion:
    """A planned stir of the bin, each leg starting at t = 0: to above the sweep's start,
    the sweep itself (down into the bin, along its floor, back up), and home."""

    approach: PiecewisePolynomial
    sweep: PiecewisePolynomial
    home: PiecewisePolynomial


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

    def tool_height(self, measured: np.ndarray) -> float:
        """The world height of the tool centre (T) where ``measured`` puts it, m."""

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray,
                  tips_above: float | None = None) -> PickMotion:
        """The whole pick for tool pose ``X_WT`` from the state ``measured``, the lift taking
        the fingertips up to the world height ``tips_above`` where given and the manipulator
        can (else as high as the approach's settings say); raises :class:`PlanningError`
        when it cannot be done."""

    def plan_shake(self, hold: np.ndarray) -> PiecewisePolynomial:
        """A shake of the tool about the command ``hold`` (up and down, :class:`ShakeSettings`),
        ending where it began; raises :class:`PlanningError`."""

    def plan_lower(self, hold: np.ndarray, X_WT: np.ndarray,
                   clearance: float) -> PiecewisePolynomial:
        """From ``hold`` straight down, slowly, to ``clearance`` above the grasp pose ``X_WT``
        (to put a load back on the pile); raises :class:`PlanningError`."""

    def plan_line(self, start: np.ndarray, end: np.ndarray) -> PiecewisePolynomial:
        """A short move between two commands near each other (back up after a put-back)."""

    def plan_stir(self, hold: np.ndarray, poses: list[np.ndarray], speed: float) -> StirMotion:
        """From ``hold`` to the first of the tool poses ``poses`` (4x4, a sweep through the
        bin: :func:`~tangle_drake.pick.stir.stir_poses`), straight from each to the next with
        the tool centre at ``speed`` m/s, then home; raises :class:`PlanningError`."""
