"""Why a candidate was turned down, or a pick not attempted: one enum, from where it arises
(the motion planners, the pick planner, the episode) to the benchmark's failure table.

Nothing parses messages: a ``PlanningError``, a ``Rejection`` and a failed ``PickRecord``
carry their kind, and the words for people (``detail``, ``reason``) are only for people.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable


class FailureKind(enum.Enum):
    """What went wrong; the value is the benchmark's name for it."""

    NO_CANDIDATE = "no candidate"
    """Graspability found no grasp in the bin."""
    UNREACHABLE = "unreachable"
    """No IK solution within the joint limits, or outside the carrier's travel."""
    COLLISION = "collision"
    """Every way there would hit the bin or the robot itself."""
    NO_POSE = "no pose"
    """The candidate has no world pose (the camera's pose was unknown)."""
    REPEAT = "repeat"
    """A grasp there came up empty before, and the pile there has not changed."""
    SAFETY_STOP = "safety stop"
    """The hardware station's safety supervisor stopped the robot during the pick."""
    STALE_IMAGE = "stale image"
    """Hardware: no camera image arrived after the arm's last motion (a frozen camera)."""
    TIMEOUT = "timeout"
    """The pick did not finish in the simulated time allowed."""
    GAVE_UP = "gave up"
    """Closed loop: too many grasps in a row delivered nothing; the planner stopped."""


_BLAME_ORDER = (FailureKind.UNREACHABLE, FailureKind.COLLISION, FailureKind.REPEAT,
                FailureKind.NO_POSE)
"""When every candidate was turned down, the pick failed for the first of these kinds that
any of them had (the benchmark's order since its first report)."""


def pick_failure(rejected: Iterable[FailureKind]) -> FailureKind:
    """The kind of a pick whose candidates were all turned down for ``rejected``."""
    kinds = set(rejected)
    return next((kind for kind in _BLAME_ORDER if kind in kinds), FailureKind.NO_CANDIDATE)
