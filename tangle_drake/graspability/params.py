"""Tuning of the graspability index: everything that is not the hand or the camera."""

from __future__ import annotations

import math
from dataclasses import dataclass

FINGER_GRIP_SPAN_M = 0.014
"""The grip test's span for picking with the project's gripper (the pick diagram uses it).
Candidates this test drops (the fingers would close along a wire, not across it) come up
empty far more often than the others when picked, so dropping them cuts the benchmark's empty
grasps and raises its single-part picks (figures: ``docs/graspability.md``, the grip test, and
``docs/results/history.md``). A 6 mm layer, or one as deep as the insertion, did worse on
development piles."""


@dataclass(frozen=True)
class GraspabilityParams:
    """Settings of :func:`~tangle_drake.graspability.compute_candidates` (SI units).

    Defaults suit 6-10 mm wire parts seen from ~0.5 m with the default gripper.
    """

    n_orientations: int = 16
    """Hand orientations, evenly spaced over 180 degrees starting at 0 (closing along +u)."""
    top_k: int = 5
    """How many candidates to return at most."""
    cell_size_m: float = 0.0025
    """Cell of the metric work map (about a third of the default finger's 8 mm thickness);
    made coarser if the image's own pixels are coarser. The cost goes as 1 / cell^2."""
    level_step_m: float = 0.001
    """Spacing of the depth levels scanned from the top of the pile down."""
    insertion_depth_m: float = 0.004
    """How far the fingertips go below the top of what they grasp (rounded to whole levels)."""
    blur_sigma_m: float = 0.0075
    """Gaussian blur of the graspable maps: a candidate's score is the Gaussian-weighted share
    of its neighbourhood where the same grasp also works, i.e. its tolerance to position error."""
    min_distance_m: float = 0.02
    """Minimum distance between two returned candidates' centres."""
    peak_tolerance: float = 0.02
    """Scores within this fraction of a peak's count as the peak's plateau; the candidate is put
    at the plateau's middle (a long bar is grasped at its centre, not wherever rounding wins)."""
    roi_margin_px: int = 0
    """Candidates keep at least this many pixels inside the region of interest's edge."""
    max_grip_span_m: float | None = None
    """The grip test, for real fingers (``None``, the default, is the plain index of Domae et
    al. that the paper uses): the top layer of what lies in the closing region
    (``grip_layer_m`` deep), which the finger pads squeeze first, may stretch at most this far
    along the closing direction, so the pads close across a wire instead of pushing on one
    that runs between them and squirts out sideways. See :data:`FINGER_GRIP_SPAN_M`."""
    grip_layer_m: float = 0.004
    """The grip test's layer depth (at most the insertion depth: nothing below the fingertips
    is squeezed)."""

    def __post_init__(self) -> None:
        if self.n_orientations < 1 or self.top_k < 1:
            raise ValueError("GraspabilityParams: n_orientations and top_k must be at least 1")
        for name in ("cell_size_m", "level_step_m", "insertion_depth_m", "blur_sigma_m",
                     "grip_layer_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"GraspabilityParams.{name} must be positive")
        if self.min_distance_m < 0 or self.roi_margin_px < 0:
            raise ValueError("GraspabilityParams: min_distance_m, roi_margin_px must be >= 0")
        if not 0 <= self.peak_tolerance < 1:
            raise ValueError("GraspabilityParams.peak_tolerance must lie in [0, 1)")
        if self.max_grip_span_m is not None and not self.max_grip_span_m >= 0:
            raise ValueError("GraspabilityParams.max_grip_span_m must be >= 0 (or None: off)")

    @property
    def insertion_levels(self) -> int:
        """The insertion depth in whole levels (at least one)."""
        return max(1, round(self.insertion_depth_m / self.level_step_m))

    @property
    def grip_layer_levels(self) -> int:
        """The grip test's layer in whole levels, one at least and the insertion at most."""
        return min(self.insertion_levels, max(1, round(self.grip_layer_m / self.level_step_m)))

    def grip_span_cells(self, cell_m: float) -> int | None:
        """The grip test's longest span, as the most work-map cells two squeezed cells may lie
        apart along the closing direction; ``None`` when the test is off."""
        if self.max_grip_span_m is None:
            return None
        return math.floor(self.max_grip_span_m / cell_m + 1e-9)
