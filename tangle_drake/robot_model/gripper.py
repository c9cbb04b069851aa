"""The parallel-jaw gripper's dimensions: the one place they are written down.

The gripper model (``models/nextage/sdf/parallel_jaw_gripper.sdf``, generated from this spec)
and the graspability hand model both read these numbers, so the index never plans for fingers
the robot does not have.

Gripper frame ``G`` (the gripper model's ``gripper_base`` body frame, welded to the arm's flange):
  - origin on the flange face, centre of the palm's back;
  - +z is the approach direction (from the flange towards the fingertips);
  - +y is the closing direction: the two fingers slide along y, symmetrically about z;
  - +x completes the right-handed frame (along each finger's width).
The grasp (tool centre) frame ``T`` is G shifted by ``tcp_offset`` along +z: the point midway
between the finger pads, where the target's centre should be when the gripper closes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class GripperSpec:
    """Geometry and actuation of a symmetric two-finger parallel gripper (SI units)."""

    max_opening: float = 0.045
    """Distance between the fingers' inner faces when fully open (the stroke), m."""
    finger_width: float = 0.012
    """Extent of each finger along x (across the closing direction), m."""
    finger_thickness: float = 0.008
    """Extent of each finger along y (the closing direction), m."""
    finger_length: float = 0.055
    """Extent of each finger along z, from the palm's face to the fingertip, m."""
    palm_size: tuple[float, float, float] = (0.04, 0.09, 0.03)
    """Palm box (x, y, z); z is its depth along the approach direction, m."""
    pad_length: float = 0.02
    """Length of the finger pad that grips, measured up from the fingertip, m."""
    grip_force: float = 40.0
    """Force limit of each finger's actuator, N."""
    palm_mass: float = 0.35
    finger_mass: float = 0.04

    def __post_init__(self) -> None:
        for name in ("max_opening", "finger_width", "finger_thickness", "finger_length",
                     "pad_length", "grip_force", "palm_mass", "finger_mass"):
            value = getattr(self, name)
            if not value > 0:
                raise ValueError(f"GripperSpec.{name} must be positive, got {value!r}")
        if self.pad_length > self.finger_length:
            raise ValueError("GripperSpec.pad_length cannot exceed finger_length")
        if self.palm_size[1] < self.max_opening + 2 * self.finger_thickness:
            raise ValueError("GripperSpec.palm_size[1] must span both fingers when fully open")

    @property
    def finger_stroke(self) -> float:
        """Travel of one finger from closed to fully open, m."""
        return self.max_opening / 2

    @property
    def tcp_offset(self) -> float:
        """Distance from the flange (G origin) to the grasp point (T origin) along +z, m."""
        return self.palm_size[2] + self.finger_length - self.pad_length / 2

    @property
    def reach(self) -> float:
        """Distance from the flange to the fingertips along +z, m."""
        return self.palm_size[2] + self.finger_length

    @property
    def outer_width_open(self) -> float:
        """Outer extent of the open fingers along y, m (what must fit between obstacles)."""
        return self.max_opening + 2 * self.finger_thickness

    @staticmethod
    def from_dict(data: Mapping[str, Any]) -> GripperSpec:
        """The spec a dataset manifest or checkpoint stores (``asdict``, lists for tuples);
        ``TypeError``/``ValueError`` on a bad dict."""
        values = dict(data)
        if "palm_size" in values:
            values["palm_size"] = tuple(values["palm_size"])
        return GripperSpec(**values)


DEFAULT_GRIPPER = GripperSpec()
