"""Closed-loop picking: what the planner does with what it weighed at the top of the lift.

    one part        -> transfer to the tray and release (delivered)
    nothing         -> retreat home and look again, not at the same spot
    several         -> shake and weigh again; still several -> put back: lower slowly towards
                       the pile (stopping where the load starts to rest on it), open, weigh
                       (a part may stay hooked on a finger: shake it off), back up, retreat
    not sure        -> weigh again; still not sure -> as several (never deliver a doubt)

and with the bin: when a look finds nothing it can pick while the bin still holds something,
or ``max_attempts`` grasps in a row delivered nothing, the fingers stir the bin (:mod:`.stir`)
and the planner looks again; after ``max_stirs`` stirs without a delivery it gives up.

The rules here are pure functions of what the planner knows, so they are tested without a
simulator; :mod:`.planner` carries them out.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from tangle_drake.pick.payload import PayloadEstimate
from tangle_drake.pick.stir import StirSettings


class Verdict(enum.Enum):
    """What one weighing says came up."""

    NONE = "nothing"
    ONE = "one part"
    SEVERAL = "several parts"
    UNSURE = "not sure"


class Recovery(enum.Enum):
    """A step taken after a grasp that did not bring up one part, as weighed (or, for
    ``BACK_OUT``, as the fingers' opening said)."""

    BACK_OUT = "backed out"
    """The fingers closed on nothing while the lift still retraced the descent: back the way
    the pick came, unweighed."""
    REWEIGH = "weighed again"
    SHAKE = "shaken"
    PUT_BACK = "lowered to the pile and opened"
    SHAKE_OFF = "shaken off a finger"
    STIR = "stirred the bin"
    """Nothing could be picked from the pile as it lay (no candidate, none that could be
    picked, or ``max_attempts`` grasps without a delivery): the fingers swept through it."""


class Disposition(enum.Enum):
    """How a closed-loop grasp ended."""

    DELIVERED = "delivered"
    """Released over the tray, weighed as one part."""
    EMPTY = "empty"
    """Came up with nothing."""
    PUT_BACK = "put back"
    """Came up with several, and put them back on the pile."""


@dataclass(frozen=True)
class RecoverySettings:
    """How hard the closed loop tries (SI units)."""

    max_reweighs: int = 2
    """Weighings that may come out "not sure" before the load counts as several."""
    max_shakes: int = 1
    """Shakes of a load of several before it is put back."""
    max_attempts: int = 5
    """Grasps in a row without a delivery before the planner stirs the bin (or, with no stir
    left, gives up on it)."""
    max_stirs: int = 2
    """Stirs of the bin without a delivery between them before the planner gives up; 0 never
    stirs (a look that finds nothing to pick then ends the run)."""
    stir: StirSettings = field(default_factory=StirSettings)
    tare_timeout: float = 1.5
    """The longest wait at the pre-grasp for a tare, s (then it descends untared and the
    weighing cannot be trusted)."""
    weigh_timeout: float = 1.5
    """The longest wait for a weighing, s (then it is "not sure")."""
    put_back_clearance: float = 0.03
    """The put-back lowers the tool centre to this far above where it grasped, m..."""
    put_back_force: float = 0.5
    """...or until the support the load needs has dropped by this many part weights (the
    hanging parts rest on the pile), whichever comes first..."""
    put_back_samples: int = 3
    """...in this many of the planner's looks in a row (the sensor's noise is ~0.1 N)."""
    hanging_length: float = 0.0
    """How far a load of several may hang below the fingertips, m (a held part and one hooked
    on its far end): where the planner sees the bin (its ``bin_contents`` input), the lift
    takes the fingertips this far above the top of the pile, so that no hanging part rests on
    the pile at the weighing and reads light. 0: the lift goes only as high as
    ``ApproachSettings.lift_height`` above the rim, which is not enough for long parts or a
    pile that reaches the rim. ``pick.diagram.closed_loop_settings`` sets it from the pile's
    parts."""

    def __post_init__(self) -> None:
        if min(self.max_reweighs, self.max_shakes, self.max_stirs) < 0 or min(
                self.max_attempts, self.put_back_samples) < 1:
            raise ValueError("RecoverySettings: max_reweighs, max_shakes and max_stirs must be "
                             ">= 0, max_attempts and put_back_samples >= 1")
        for name in ("tare_timeout", "weigh_timeout", "put_back_clearance", "put_back_force"):
            if not getattr(self, name) > 0:
                raise ValueError(f"RecoverySettings.{name} must be positive")
        if not self.hanging_length >= 0:
            raise ValueError("RecoverySettings.hanging_length must be >= 0")


def judge(width: float, estimate: PayloadEstimate | None, empty_width: float) -> Verdict:
    """What came up: fingers closed past ``empty_width`` hold nothing; else the weighing."""
    if width < empty_width:
        return Verdict.NONE
    if estimate is None or not estimate.ready or not estimate.trusted:
        return Verdict.UNSURE
    if estimate.count == 0:
        return Verdict.NONE
    return Verdict.ONE if estimate.count == 1 else Verdict.SEVERAL


def after_weighing(verdict: Verdict, reweighs: int, shakes: int,
                   settings: RecoverySettings) -> Recovery | Disposition:
    """The next step after a weighing with the lift's load: a disposition ends the grasp
    (``DELIVERED``: transfer; ``EMPTY``: retreat), a recovery goes on with it."""
    if verdict is Verdict.UNSURE and reweighs < settings.max_reweighs:
        return Recovery.REWEIGH
    if verdict is Verdict.ONE:
        return Disposition.DELIVERED
    if verdict is Verdict.NONE:
        return Disposition.EMPTY
    return Recovery.SHAKE if shakes < settings.max_shakes else Recovery.PUT_BACK


def after_put_back(verdict: Verdict, shakes_off: int,
                   settings: RecoverySettings) -> Recovery | Disposition:
    """The next step after weighing the open gripper above the pile: shake off what still
    hangs on a finger (once per allowed shake), else go."""
    if verdict in (Verdict.ONE, Verdict.SEVERAL) and shakes_off < max(settings.max_shakes, 1):
        return Recovery.SHAKE_OFF
    return Disposition.PUT_BACK
