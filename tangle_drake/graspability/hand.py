"""The hand as the graspability index sees it, derived from :class:`GripperSpec`.

The index never reads its own finger sizes: they come from the gripper spec, so the candidates
are planned for the fingers the robot really has. In the work map (a metric grid, see
:mod:`.workmap`) the hand becomes three rectangles of cells, written in the hand's own 2-D
frame: ``a`` along the closing direction, ``b`` across it (along the fingers' width).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec

_EPS = 1e-9
"""Slack for cell centres that fall exactly on a mask's edge (they belong to the mask)."""


@dataclass(frozen=True)
class HandModel:
    """A parallel-jaw hand's cross-section and reach, in metres."""

    opening_m: float
    """Distance between the open fingers' inner faces: the closing region's length."""
    finger_thickness_m: float
    """Each finger footprint's extent along the closing direction."""
    finger_width_m: float
    """Each finger footprint's (and the closing region's) extent across the closing direction."""
    finger_length_m: float
    """How deep the fingers can go past the top of what they grasp (bounds the insertion)."""
    tcp_above_tips_m: float
    """Height of the tool centre T above the fingertips (half the pad length)."""

    def __post_init__(self) -> None:
        for name in ("opening_m", "finger_thickness_m", "finger_width_m", "finger_length_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"HandModel.{name} must be positive, got {getattr(self, name)!r}")
        if not 0 <= self.tcp_above_tips_m <= self.finger_length_m:
            raise ValueError("HandModel.tcp_above_tips_m must lie within the finger length")

    @classmethod
    def from_gripper(cls, spec: GripperSpec = DEFAULT_GRIPPER) -> HandModel:
        """The hand of ``spec``: fully open, T midway along the pads (gripper.py's T frame)."""
        return cls(
            opening_m=spec.max_opening,
            finger_thickness_m=spec.finger_thickness,
            finger_width_m=spec.finger_width,
            finger_length_m=spec.finger_length,
            tcp_above_tips_m=spec.pad_length / 2,
        )

    def in_cells(self, cell_m: float) -> HandCells:
        """The hand's masks on a grid of ``cell_m`` cells: a cell belongs to a mask when its
        centre lies inside the mask's (closed) rectangle."""
        half_open = self.opening_m / 2 / cell_m
        contact_half = math.floor(half_open + _EPS)
        finger_inner = contact_half + 1
        finger_outer = math.floor(half_open + self.finger_thickness_m / cell_m + _EPS)
        half_width = math.floor(self.finger_width_m / 2 / cell_m + _EPS)
        if finger_outer < finger_inner:
            raise ValueError(f"cell size {cell_m} m is coarser than the finger thickness")
        return HandCells(contact_half, finger_inner, finger_outer, half_width)


@dataclass(frozen=True)
class HandCells:
    """The hand's masks in cells, as integer offsets from the hand's centre.

    Closing region: ``|a| <= contact_half``; finger footprints: ``finger_inner <= |a| <=
    finger_outer``; all three: ``|b| <= half_width``.
    """

    contact_half: int
    finger_inner: int
    finger_outer: int
    half_width: int

    @property
    def reach(self) -> int:
        """The farthest cell offset any mask reaches, along either axis."""
        return max(self.finger_outer, self.half_width)


def as_hand(hand: HandModel | GripperSpec) -> HandModel:
    """Accept either the gripper spec or a ready hand model."""
    return HandModel.from_gripper(hand) if isinstance(hand, GripperSpec) else hand
