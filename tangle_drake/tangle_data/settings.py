"""What a tangle-data collection is made of: the lift, the labelling rules, the whole run.

Every field that changes what a sample means or which samples a task makes is part of
:meth:`CollectSettings.identity`, which the manifest stores: a dataset only ever grows with
the settings it was started with.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

from tangle_drake.common.errors import TangleDrakeError, check_seed
from tangle_drake.perception.crops import DEFAULT_CROP, CropSpec
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.station.pile_freeze import FREEZE_BEYOND_RADII


@dataclass(frozen=True)
class LiftSettings:
    """The force-based lift of the target part (no fingers: a spatial spring pulls it up).

    The spring's set point starts at the target's settled pose and moves straight up (world
    +z) by ``height_m`` on a trapezoidal speed profile, then holds for ``hold_s``. Gains come
    from a natural frequency, so they scale with the part: translation ``k = m w^2``, rotation
    ``K = I_min w^2`` (smallest principal inertia, else thin parts go unstable). The spring is
    explicit in Drake's discrete step, so ``w * time_step`` must stay small (checked).
    """

    height_m: float = 0.12
    speed_m_s: float = 0.4
    accel_m_s2: float = 4.0
    hold_s: float = 0.05
    """Longest hold at the top; it ends early once every part has stopped moving."""
    frequency_hz: float = 30.0
    """Natural frequency of the spring on the target, Hz."""
    damping_ratio: float = 1.0
    max_force_n: float = 40.0
    """Cap on the spring's pull, about what the default gripper's pads hold in friction
    (2 fingers x 40 N x 0.5); a target held harder than this by the pile stalls."""
    freeze_beyond_radii: float = FREEZE_BEYOND_RADII
    """Parts whose centre lies farther than this many bounding radii (horizontally) from
    the target's are locked in place during the lift (why it is safe:
    :data:`~tangle_drake.station.pile_freeze.FREEZE_BEYOND_RADII`). Each step costs markedly less. 0
    keeps every part free."""
    early_exit: bool = True
    """End the lift as soon as its record cannot change any more (the target and what it
    lifted are above every part they could touch, nothing is on its way up), and the hold
    as soon as everything is at rest. Off for reference runs."""

    def validate(self, time_step: float) -> None:
        for name in ("height_m", "speed_m_s", "accel_m_s2", "frequency_hz", "damping_ratio",
                     "max_force_n"):
            _positive(f"lift.{name}", getattr(self, name))
        for name in ("hold_s", "freeze_beyond_radii"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise TangleDrakeError(f"lift.{name} must be >= 0, got {value!r}")
        omega_dt = 2 * math.pi * self.frequency_hz * time_step
        if omega_dt > 0.5:
            raise TangleDrakeError(
                f"lift.frequency_hz={self.frequency_hz:g} is too stiff for the plant's "
                f"{time_step * 1e3:g} ms step (2 pi f dt = {omega_dt:.2f} > 0.5): the explicit "
                "spring would oscillate; lower it")

    @property
    def ramp_s(self) -> float:
        """Time to reach full speed (shorter if the lift is too short to reach it)."""
        return min(self.speed_m_s / self.accel_m_s2, math.sqrt(self.height_m / self.accel_m_s2))

    @property
    def travel_s(self) -> float:
        """Duration of the moving part of the lift (before the hold)."""
        ramp = self.ramp_s
        peak = self.accel_m_s2 * ramp
        return 2 * ramp + (self.height_m - peak * ramp) / peak


@dataclass(frozen=True)
class LabelSettings:
    """The labelling rules' thresholds (paper, section III-B)."""

    rise_threshold_m: float = 0.03
    """Another part that rises more than this during the lift makes the pick *tangled*."""
    stall_fraction: float = 0.5
    """A target that rises less than this fraction of the lift height is held by the pile (a
    gripper could not take it out alone): *tangled*, whatever the others did."""
    region_margin_m: float = 0.001
    """A part is in the closing region if its surface reaches this far inside the region's
    sides and bottom; a part that only grazes the region does not count."""

    def validate(self) -> None:
        _positive("rise_threshold_m", self.rise_threshold_m)
        if not 0 <= self.stall_fraction < 1:
            raise TangleDrakeError(f"stall_fraction must lie in [0, 1), got {self.stall_fraction}")
        if not (math.isfinite(self.region_margin_m) and self.region_margin_m >= 0):
            raise TangleDrakeError(f"region_margin_m must be >= 0, got {self.region_margin_m}")


@dataclass(frozen=True)
class CollectSettings:
    """One collection: the part, the piles, the lifts, and what a sample holds."""

    part: str
    """A built-in part name, or a mesh file path (stored as given and by content hash)."""
    mesh_scale: float = 1.0
    parts_per_pile: int = 20
    lifts_per_pile: int = 5
    """Candidates labelled per settled pile, drawn at random from the graspability top-k.
    The default labels all of the top five: exactly the candidates the CNN scores when
    picking, and the settled pile (the costliest part of a task) serves five samples."""
    top_k: int = 5
    """Candidates the graspability index returns (the paper's top five)."""
    seed: int = 0
    lift: LiftSettings = field(default_factory=LiftSettings)
    labels: LabelSettings = field(default_factory=LabelSettings)
    crop: CropSpec = DEFAULT_CROP
    gripper: GripperSpec = DEFAULT_GRIPPER
    full_depth: bool = False
    """Also store each sample's whole depth image (large: ~1.2 MB per sample at 640x480)."""
    repeat: int = 1
    """Lifts re-run this many times with small perturbations, to measure label agreement."""

    def validate(self, time_step: float) -> None:
        _positive("mesh_scale", self.mesh_scale)
        if self.parts_per_pile < 1:
            raise TangleDrakeError(f"--parts-per-pile must be at least 1, got "
                                   f"{self.parts_per_pile}")
        if self.parts_per_pile > MAX_PARTS_PER_PILE:
            raise TangleDrakeError(f"--parts-per-pile must be at most {MAX_PARTS_PER_PILE} "
                                   f"(the samples record lifted parts as a 63-bit mask), got "
                                   f"{self.parts_per_pile}")
        if not 1 <= self.lifts_per_pile <= self.top_k:
            raise TangleDrakeError(f"--lifts-per-pile must be between 1 and the top-k "
                                   f"({self.top_k}), got {self.lifts_per_pile}")
        if self.repeat < 1:
            raise TangleDrakeError(f"--repeat must be at least 1, got {self.repeat}")
        _positive("--crop-size", self.crop.size_m)
        check_seed(self.seed, "--seed")
        self.lift.validate(time_step)
        self.labels.validate()

    def identity(self) -> dict:
        """The settings a dataset is bound to (JSON-ready): appending needs the same."""
        return asdict(self)


MAX_PARTS_PER_PILE = 63


def _positive(name: str, value: float) -> None:
    if isinstance(value, bool) or not (math.isfinite(value) and value > 0):
        raise TangleDrakeError(f"{name} must be a positive number, got {value!r}")
