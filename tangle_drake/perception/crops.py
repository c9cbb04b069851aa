"""The depth crop the tangle CNN sees: centred on a grasp candidate, closing direction horizontal.

One function for the data simulator and for inference, so training and use never disagree.
The crop covers a fixed *metric* square (not a pixel count), so a camera mounted higher or
lower gives the same crop of the same pile: pixels per metre at the grasp depth are f / depth.

``extract_crop`` fills missing pixels with the image's deepest valid depth, which costs a few
milliseconds per call on a 640x480 image. ``candidate_crops`` (all the candidates of one image,
for inference) computes that fill once per image and cuts each crop from a small window around
its candidate (missing pixels already filled, the outside of the image already the fill value)
that contains every pixel the crop samples, so the window's own fill never shows. Its crops
equal ``extract_crop`` on the whole image up to float rounding in the interpolation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec


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


_MARGIN_PX = 2
"""Extra window pixels beyond the crop's footprint: bilinear sampling reads one neighbour."""


def candidate_crops(depth: np.ndarray, intrinsics: CameraIntrinsics, candidates: Sequence[Any],
                    spec: CropSpec) -> np.ndarray:
    """(N, S, S) float32 crops for candidates with ``u``, ``v``, ``angle_deg``, ``depth_m``."""
    depth = np.asarray(depth, dtype=np.float32)
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise TangleDrakeError(f"depth image is {depth.shape[::-1]} (w, h) but the camera "
                               f"intrinsics say {intrinsics.width}x{intrinsics.height}")
    valid = np.isfinite(depth) & (depth > 0)
    # cv2's masked maximum is much faster than numpy's boolean indexing on a full image.
    image_fill = cv2.minMaxLoc(depth, valid.view(np.uint8))[1] if valid.any() else None
    crops = np.empty((len(candidates), spec.size_px, spec.size_px), dtype=np.float32)
    for i, candidate in enumerate(candidates):
        u, v = float(candidate.u), float(candidate.v)
        angle, grasp_depth = float(candidate.angle_deg), float(candidate.depth_m)
        if not (math.isfinite(u) and math.isfinite(v) and math.isfinite(angle)
                and grasp_depth > 0 and math.isfinite(grasp_depth)):
            raise TangleDrakeError(f"grasp candidate {i} has a non-finite pixel or angle, or a "
                                   f"non-positive depth: u={u}, v={v}, angle_deg={angle}, "
                                   f"depth_m={grasp_depth}")
        fill = grasp_depth if image_fill is None else image_fill
        # Half the crop's diagonal in image pixels: the farthest pixel the crop samples.
        reach = spec.size_m * intrinsics.fx / grasp_depth / math.sqrt(2)
        radius = math.ceil(reach) + _MARGIN_PX
        u0, v0 = math.floor(u) - radius, math.floor(v) - radius
        window = _window(depth, valid, u0, v0, 2 * radius + 1, fill)
        crops[i] = extract_crop(window, intrinsics, u - u0, v - v0, angle, grasp_depth, spec)
    return crops


def _window(depth: np.ndarray, valid: np.ndarray, u0: int, v0: int, side: int,
            fill: float) -> np.ndarray:
    """``depth[v0:v0+side, u0:u0+side]`` with missing and outside pixels set to ``fill``."""
    window = np.full((side, side), fill, dtype=np.float32)
    rows = slice(max(v0, 0), min(v0 + side, depth.shape[0]))
    cols = slice(max(u0, 0), min(u0 + side, depth.shape[1]))
    if rows.start < rows.stop and cols.start < cols.stop:
        window[rows.start - v0:rows.stop - v0, cols.start - u0:cols.stop - u0] = np.where(
            valid[rows, cols], depth[rows, cols], np.float32(fill))
    return window
