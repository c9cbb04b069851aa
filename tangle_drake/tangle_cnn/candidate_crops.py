"""The crops of all grasp candidates of one depth image, as ``extract_crop`` makes them, fast.

``extract_crop`` fills missing pixels with the image's deepest valid depth, which costs a few
milliseconds per call on a 640x480 image. Here that fill is computed once per image, and each
candidate's crop is cut from a small window around it (missing pixels already filled, the
outside of the image already the fill value) that contains every pixel the crop samples, so
the window's own fill never shows. The crops equal ``extract_crop`` on the whole image up to
float rounding in the interpolation (a few micrometres).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np

from tangle_drake.camera import CameraIntrinsics
from tangle_drake.crops import CropSpec, extract_crop
from tangle_drake.errors import TangleDrakeError

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
    # cv2's masked maximum is ~20x faster than numpy's boolean indexing on a 640x480 image.
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
