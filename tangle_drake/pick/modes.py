"""The pick state machine's modes, settings and state (:mod:`.planner` runs them)."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.drivers.parallel_jaw import empty_grasp_width
from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.choose import EmptyGrasp, RepeatRule
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.pick.payload import PayloadRequest
from tangle_drake.pick.recovery import RecoverySettings
from tangle_drake.planning.motion import PickMotion
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER


class Mode(enum.Enum):
    """The state machine's modes, in the order one pick passes them."""

    SETTLE = "settle"
    PERCEIVE = "perceive"
    APPROACH = "approach"
    TARE = "tare"
    DESCEND = "descend"
    CLOSE = "close"
    LIFT = "lift"
    CHECK = "check"
    WEIGH = "weigh"
    SHAKE = "shake"
    PUT_BACK = "put back"
    OPEN = "open"
    WEIGH_OPEN = "weigh open"
    SHAKE_OFF = "shake off"
    RAISE = "raise"
    TRANSFER = "transfer"
    RELEASE = "release"
    HOME = "home"
    RETREAT = "retreat"
    STIR = "stir"
    """Closed loop: the closed fingers sweep through what is left in the bin (nothing could
    be picked as it lay), then home for a fresh look."""
    STOPPED = "stopped"
    """The station reported a safety stop: the pick in progress was abandoned."""
    DONE = "done"




@dataclass(frozen=True)
class PickSettings:
    """Timing and thresholds of the state machine (SI units)."""

    max_picks: int = 5
    """Open loop: picks to make; closed loop: parts to deliver."""
    settle_time: float = 0.3
    """Wait before each look, for the pile (and a part just dropped) to come to rest, s."""
    close_delay: float = 0.2
    """Wait at the bottom of the descent before closing, s: the arm tracks its command with a
    lag (servos, and on hardware the drivers' latency), and closing while it is still a few
    millimetres up closes on the top of the wire, which then slips out under the fingertips."""
    close_time: float = 0.4
    """From the close command to the lift, s (the fingers close in ~0.1 s, then squeeze)."""
    check_time: float = 0.3
    """Open loop: hold at the top of the lift before judging, so a loose part has time to
    drop, s."""
    release_time: float = 0.3
    """From the open command to the move away, s."""
    empty_width: float = empty_grasp_width(None)
    """Fingers closed further than this hold nothing, m (the rule of
    :func:`~tangle_drake.drivers.parallel_jaw.empty_grasp_width`; ``pick.diagram.pick_settings``
    gives it for the pile's own wire)."""
    open_width: float = DEFAULT_GRIPPER.max_opening
    """Opening for the approach, m."""
    update_period: float = 0.02
    """Period of the state machine's updates, s."""
    repeat_distance: float = 0.01
    """A candidate within this distance (m) of a grasp that came up empty, closing within
    ``repeat_angle_deg`` of it, with its fingertips within ``repeat_depth`` of that grasp's,
    repeats it and is skipped: an empty grasp leaves the pile much as it was, so the same
    candidate would come back, and fail again, until the pile there changes."""
    repeat_angle_deg: float = 20.0
    repeat_depth: float = 0.005
    image_timeout: float = 1.0
    """With the planner's ``camera.image_time`` input connected: wait after ``settle_time``
    this long at most (s) for an image that arrived after the arm's last motion ended, then
    stop with a ``STALE_IMAGE`` failure. An older image shows the pile as it was before the
    last pick: a frozen camera must not drive a pick."""
    recovery: RecoverySettings | None = None
    """``None``: open loop (the paper's). Else weigh every lift and act on it."""
    record_crop: CropSpec | None = None
    """Keep the tried candidate's depth crop of this size in its record (for a pick log);
    needs the planner's ``depth_image`` input and its camera's intrinsics."""
    record_view: bool = False
    """Keep what each look saw in its record (``PickRecord.view``: the depth image and the
    first candidates in the rule's order, for a picture per pick); needs ``depth_image``."""

    def __post_init__(self) -> None:
        if self.max_picks < 1:
            raise ValueError("PickSettings.max_picks must be at least 1")
        if self.close_delay < 0:
            raise ValueError("PickSettings.close_delay must be >= 0")
        for name in ("settle_time", "close_time", "check_time", "release_time",
                     "empty_width", "open_width", "update_period", "repeat_distance",
                     "repeat_depth", "image_timeout"):
            if not getattr(self, name) > 0:
                raise ValueError(f"PickSettings.{name} must be positive")

    @property
    def repeat_rule(self) -> RepeatRule:
        return RepeatRule(self.repeat_distance, self.repeat_angle_deg, self.repeat_depth)


@dataclass(frozen=True)
class Loop:
    """What the closed loop counts within one grasp, and across grasps."""

    request: PayloadRequest = field(default_factory=PayloadRequest)
    reweighs: int = 0
    shakes: int = 0
    shakes_off: int = 0
    support: float = float("nan")
    """The last weighing's support force, N: the put-back stops below it."""
    resting: int = 0
    """Looks in a row, during the put-back, that found the load resting on the pile."""
    deliveries: int = 0
    attempts: int = 0
    """Grasps since the last delivery or stir."""
    stirs: int = 0
    """Stirs of the bin since the last delivery."""
    stir_due: bool = False
    """The next look stirs the bin instead of picking (too many grasps delivered nothing;
    the last one's record waits in ``PlannerState.record`` until the stir is over)."""
    sweep: tuple[float, float] = (0.0, 0.0)
    """When the stir in progress is in the bin (from its start, s): the force limit holds
    then."""
    backing_out: bool = False
    """The stir met too much force and goes back the way it came."""
    can_stir: bool = False
    """The planner sees the bin's contents (its ``bin_contents`` input is connected) and
    may stir (``RecoverySettings.max_stirs``)."""


@dataclass(frozen=True)
class PlannerState:
    """Everything the planner remembers (one abstract state value)."""

    mode: Mode
    since: float
    """Time the mode began, s."""
    hold: np.ndarray
    """The manipulator's command while no trajectory plays."""
    width: float
    """The gripper's command, m."""
    trajectory: PiecewisePolynomial | None = None
    """The mode's motion, played from ``since``."""
    plan: PickMotion | None = None
    record: PickRecord | None = None
    """The pick in progress."""
    started: float = 0.0
    """Time the pick in progress began to move, s."""
    picks: tuple[PickRecord, ...] = ()
    empty_grasps: tuple[EmptyGrasp, ...] = ()
    """Grasps that came up empty: later looks skip repeats while the pile there is unchanged."""
    loop: Loop = field(default_factory=Loop)

    def __deepcopy__(self, memo: dict) -> PlannerState:
        """The value itself: Drake copies abstract state at every update (deep copies of the
        plan's trajectories were a fifth of an arm pick's CPU), and this one is never changed
        in place (every change is a ``replace``, its records included), so it may be shared."""
        return self
