"""Where the hand may go: the bin's inner floor in image pixels, less a margin.

The whole hand (closing region and finger footprints, on the work map) must lie in the
region of interest: the fingers never hit a bin wall anyway (walls are tall, so a finger over
one collides), but a thin wall fits between open fingers as well as a part does. The region
also keeps the hand out of neighbouring bins and away from the image's edge, where the map is
guessed. On the work map, cells outside the region count as "above everything", like cells
outside the map (:mod:`.levels`), so this costs nothing and is exact for every orientation.
"""

from __future__ import annotations

import cv2
import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraModel

Rect = tuple[int, int, int, int]
"""``(u0, v0, u1, v1)``: pixels with ``u0 <= u < u1`` and ``v0 <= v < v1``."""


def roi_mask(roi: np.ndarray | Rect | None, width: int, height: int,
             margin_px: int) -> np.ndarray | None:
    """The allowed pixels as a boolean (height, width) mask, ``None`` if all are allowed.

    ``roi`` is a mask of the bin's inner floor (any non-zero pixel is inside), a rectangle, or
    ``None`` for the whole image; ``margin_px`` is taken off its edge (and the image's).
    """
    if roi is None:
        if margin_px == 0:
            return None
        mask = np.ones((height, width), bool)
    elif isinstance(roi, tuple):
        if len(roi) != 4 or not all(isinstance(value, (int, np.integer)) for value in roi):
            raise TangleDrakeError(f"ROI rectangle must be four integers (u0, v0, u1, v1), "
                                   f"got {roi!r}")
        u0, v0, u1, v1 = roi
        mask = np.zeros((height, width), bool)
        mask[max(v0, 0): max(v1, 0), max(u0, 0): max(u1, 0)] = True
    else:
        mask = np.asarray(roi)
        if mask.shape != (height, width) or mask.dtype.kind not in "biuf":
            raise TangleDrakeError(f"ROI mask must be a ({height}, {width}) array, got "
                                   f"{mask.dtype} {mask.shape}")
        mask = mask != 0
    if margin_px > 0:
        padded = np.pad(mask, 1).astype(np.uint8)  # the image's edge is an edge too
        distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        mask = distance[1:-1, 1:-1] > margin_px
    if not mask.any():
        raise TangleDrakeError("the region of interest (less its margin) holds no pixel")
    return mask


def bin_roi(camera: CameraModel, inner_corners_W: np.ndarray) -> np.ndarray:
    """The image region inside a bin: the convex hull of its inner corners' projections.

    ``inner_corners_W``: (N, 3) world points, e.g. the four inner corners of the bin's floor
    (or of its rim, to also allow parts leaning on the walls). Returns a boolean mask.
    """
    corners = np.asarray(inner_corners_W, float)
    if corners.ndim != 2 or corners.shape[1] != 3 or len(corners) < 3:
        raise TangleDrakeError(f"bin corners must be an (N >= 3, 3) array, got {corners.shape}")
    uvz = camera.world_to_pixel(corners)
    if not np.all(uvz[:, 2] > 0):
        raise TangleDrakeError("a bin corner lies behind the camera")
    hull = cv2.convexHull(np.rint(uvz[:, :2]).astype(np.int32))
    k = camera.intrinsics
    mask = np.zeros((k.height, k.width), np.uint8)
    cv2.fillConvexPoly(mask, hull, 1)
    return mask.astype(bool)

