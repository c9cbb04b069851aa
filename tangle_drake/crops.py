"""The depth crop the tangle CNN sees: centred on a grasp candidate, closing direction horizontal.

One function for the data simulator and for inference, so training and use never disagree.
The crop covers a fixed *metric* square (not a pixel count), so a camera mounted higher or
lower gives the same crop of the same pile: pixels per metre at the grasp depth are f / depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from tangle_drake.camera import CameraIntrinsics
from tangle_drake.gripper import DEFAULT_GRIPPER, GripperSpec


@dataclass(frozen=True)
class CropSpec:
    """Size of the crop: ``size_m`` metres square around the grasp, resampled to ``size_px``."""

    size_m: float
    size_px: int = 96

    @staticmethod
    def for_gripper(gripper: GripperSpec = DEFAULT_GRIPPER, margin: float = 0.02,
                    size_px: int = 96) -> CropSpec:
        """The open hand's outer width plus ``margin`` on each side."""
        return CropSpec(gripper.outer_width_open + 2 * margin, size_px)


DEFAULT_CROP = CropSpec.for_gripper()


def extract_crop(depth: np.ndarray, intrinsics: CameraIntrinsics, u: float, v: float,
                 angle_deg: float, grasp_depth: float, spec: CropSpec = DEFAULT_CROP) -> np.ndarray:
    """Metric depth crop (``spec.size_px`` square, float32, metres) around pixel (u, v).

    The image is rotated so the closing direction (``angle_deg`` from +u towards +v) runs along
    the crop's rows, left to right. Missing pixels (NaN, inf, 0) and the outside of the image
    read as the deepest valid depth, i.e. as empty floor.
    """
    depth = np.asarray(depth, dtype=np.float32)
    valid = np.isfinite(depth) & (depth > 0)
    fill = float(depth[valid].max()) if valid.any() else float(grasp_depth)
    filled = np.where(valid, depth, fill).astype(np.float32)
    pixels_per_metre = intrinsics.fx / grasp_depth
    scale = spec.size_px / (spec.size_m * pixels_per_metre)
    M = cv2.getRotationMatrix2D((float(u), float(v)), float(angle_deg), scale)
    centre = (spec.size_px - 1) / 2
    M[:, 2] += np.array([centre - u, centre - v])
    return cv2.warpAffine(filled, M, (spec.size_px, spec.size_px), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=fill)
