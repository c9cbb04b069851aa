"""How a scenario's run picks: the loop, the selection, and the tunings of the pick diagram's
systems (the planner's waits, the closed loop's patience, the weighing, graspability).

A tuning left out (``None``) keeps what the system's own settings class says, or what the pick
diagram derives from the pile and the camera (the empty-grasp width from the thinnest wire,
graspability's insertion from it, the margin for the palm): each default is written once, in
the class named beside the section. An overlay such as ``pick: {recovery: {max_shakes: 2}}``
changes that one value.
"""

# No `from __future__ import annotations`: Drake's YAML loader needs real field types.

import dataclasses
from dataclasses import dataclass, field

from tangle_drake.common.errors import TangleDrakeError


@dataclass
class PlannerTuning:
    """The planner's waits and thresholds (``pick.modes.PickSettings``), s and m."""

    settle_time: float | None = None
    close_delay: float | None = None
    close_time: float | None = None
    check_time: float | None = None
    release_time: float | None = None
    update_period: float | None = None
    empty_width: float | None = None
    """``None``: derived from the pile's thinnest wire."""
    image_timeout: float | None = None


@dataclass
class RecoveryTuning:
    """How hard the closed loop tries (``pick.recovery.RecoverySettings``)."""

    max_reweighs: int | None = None
    max_shakes: int | None = None
    max_attempts: int | None = None
    max_stirs: int | None = None
    tare_timeout: float | None = None
    weigh_timeout: float | None = None


@dataclass
class PayloadTuning:
    """How the closed loop weighs (``pick.payload.PayloadSettings``; the part's mass and the
    sensor's noise and period come from the pile and ``force_torque_sensors.wrist``)."""

    settle_time: float | None = None
    window: float | None = None
    max_window: float | None = None
    target_std: float | None = None
    max_fraction: float | None = None
    min_confidence: float | None = None


@dataclass
class GraspabilityTuning:
    """The graspability index (``graspability.params.GraspabilityParams``; picking doubles
    its ``top_k``, turns the grip test on and derives the insertion and the palm's margin)."""

    n_orientations: int | None = None
    top_k: int | None = None
    cell_size_m: float | None = None
    insertion_depth_m: float | None = None
    blur_sigma_m: float | None = None
    min_distance_m: float | None = None
    roi_margin_px: int | None = None
    max_grip_span_m: float | None = None


@dataclass
class PickConfig:
    """How the pick diagram picks, as a run of this scenario does unless a command's flag says
    otherwise (``--open-loop``, ``--rule``, ``--model``)."""

    closed_loop: bool = True
    """Weigh every lift, shake or put back what is not one part (needs the ``wrist`` sensor and
    a tray); false: the paper's open loop, one look and one grasp per pick."""
    hanging_parts: float = 2.0
    """Closed loop: the longest chain the weighing must see whole, in lengths of the pile's
    longest part: the held part and one hooked on it (a third is rare, and a shake drops most
    seconds); the lift goes that high over the pile. 0: the approach's fixed lift."""
    rule: str | None = None
    """The demo's selection rule (``tangle-drake demo --help`` lists them); ``None``: the
    paper's harmonic rule with a model, else graspability alone."""
    model: str | None = None
    """The demo's model checkpoint; ``None``: the part's shipped one."""
    planner: PlannerTuning = field(default_factory=PlannerTuning)
    recovery: RecoveryTuning = field(default_factory=RecoveryTuning)
    payload: PayloadTuning = field(default_factory=PayloadTuning)
    graspability: GraspabilityTuning = field(default_factory=GraspabilityTuning)

    def validate(self, where: str) -> None:
        """Signs here; the settings classes check the rest when the pick diagram is built."""
        checks = {"hanging_parts": self.hanging_parts}
        for section in ("planner", "recovery", "payload", "graspability"):
            tuning = getattr(self, section)
            checks.update({f"{section}.{f.name}": getattr(tuning, f.name)
                           for f in dataclasses.fields(tuning)})
        for name, value in checks.items():
            if value is not None and not value >= 0:
                raise TangleDrakeError(f"scenario field '{where}.{name}' must be >= 0")


def tuned(settings: object, tuning: object, where: str) -> object:
    """``settings`` (a frozen or plain settings dataclass) with the fields ``tuning`` sets;
    a value the settings class refuses is refused naming the scenario field."""
    changes = {f.name: getattr(tuning, f.name) for f in dataclasses.fields(tuning)
               if getattr(tuning, f.name) is not None}
    try:
        return dataclasses.replace(settings, **changes)
    except ValueError as error:
        raise TangleDrakeError(f"scenario field '{where}': {error}") from error
