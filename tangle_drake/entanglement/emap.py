"""The entanglement map of one depth image (Zhang et al., CASE 2021, arXiv 2106.00943).

A training-free prior for where a grasp would bring up tangled parts, after the paper's
pipeline and the parameter values of its authors' code (``bpbot/tangle_solution`` of
xinyiz0931/bin-picking-robot; nothing here is tuned on our benchmark's piles):

1. The bin's region of the image becomes a height image, brighter = higher, scaled so its
   highest point is 255 (so the image's units drop out), median-blurred (5 px) and resized
   to 250 x 250 px.
2. Line segments are fitted to it (OpenCV's LSD here; the authors' Fast Line Detector is in
   opencv-contrib only) and those shorter than 15 px dropped; each end point gets as height
   the highest grey level within 10 px, so a segment is a piece of wire in 3-D (pixels,
   pixels, grey levels).
3. Every pair of segments gets its writhe (:mod:`.writhe`); the map sums its magnitude as
   the solid angle ``4 pi |Wr|``, the authors' code's scale, against which the weights below
   were set.
4. A 125 px window slides in 25 px steps (6 x 6 windows). In each, over the segments whose
   middle lies in it: ``w`` = the pairs' summed writhe over the number of segments, ``d`` =
   the share of pairs whose writhe is at least the window's mean, and ``c`` = 255 if the
   window's centre lies in the bounding box of the image's most writhed pair, else 0.
   ``E = 0.8 w + 0.2 d + 0.001 c``.
5. The 6 x 6 values are resized to the region (bilinear) and scaled to [0, 1] over it:
   a candidate's entanglement is the map at its centre (1: the most entangled place in view).

A segment belongs to a window when its middle does (the paper does not say; the code's
windows cut the image). Windows without two segments score 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.entanglement.writhe import writhe_matrix


@dataclass(frozen=True)
class EmapParams:
    """The pipeline's parameters (the authors' code's values; pixels of the resized image)."""

    image_size: int = 250
    median_blur: int = 5
    min_length: float = 15.0
    endpoint_radius: int = 10
    window: int = 125
    stride: int = 25
    weights: tuple[float, float, float] = (0.8, 0.2, 0.001)
    """Of the window's writhe ``w``, density ``d`` and centre mask ``c``."""

    def __post_init__(self) -> None:
        if not 0 < self.window <= self.image_size or self.stride < 1:
            raise ValueError("EmapParams: the window must fit the image and the stride be >= 1")


@dataclass(frozen=True)
class EntanglementMap:
    """One image's map: the window values and where they lie in the image."""

    grid: np.ndarray
    """(rows, columns) of raw window values E, top-left window first."""
    segments: np.ndarray
    """(N, 2, 3) line segments (u, v in image pixels; height 0-255)."""
    region: tuple[int, int, int, int]
    """The image region it covers, (u0, v0, u1, v1), pixels, end exclusive."""
    image_shape: tuple[int, int]

    @cached_property
    def _image(self) -> np.ndarray:
        u0, v0, u1, v1 = self.region
        out = np.zeros(self.image_shape, np.float32)
        grid = self.grid.astype(np.float32)
        span = grid.max() - grid.min()
        scaled = (grid - grid.min()) / span if span > 0 else np.zeros_like(grid)
        out[v0:v1, u0:u1] = cv2.resize(scaled, (u1 - u0, v1 - v0),
                                       interpolation=cv2.INTER_LINEAR)
        out = np.clip(out, 0.0, 1.0)
        out.flags.writeable = False  # shared by every caller
        return out

    def image(self) -> np.ndarray:
        """The map over the whole image, float32 in [0, 1] (0 outside the region; read-only);
        computed once per map, however often it is asked for."""
        return self._image

    def at(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The scaled map (0-1) at pixels ``(u, v)`` (clipped into the image)."""
        image = self._image
        rows = np.clip(np.rint(np.asarray(v, dtype=np.float64)).astype(int), 0,
                       image.shape[0] - 1)
        cols = np.clip(np.rint(np.asarray(u, dtype=np.float64)).astype(int), 0,
                       image.shape[1] - 1)
        return image[rows, cols].astype(np.float64)


def height_image(depth: np.ndarray, region: tuple[int, int, int, int]) -> np.ndarray:
    """The region of metric ``depth`` (any unit; farther = larger; inf/NaN/<=0 unseen) as
    heights above its farthest seen point, scaled to 0-255 (brighter = higher)."""
    u0, v0, u1, v1 = region
    part = np.asarray(depth, dtype=np.float64)[v0:v1, u0:u1]
    seen = np.isfinite(part) & (part > 0)
    if not seen.any():
        raise TangleDrakeError("entanglement map: no valid depth pixel in the region")
    height = np.where(seen, part[seen].max() - part, 0.0)
    top = height.max()
    return (255.0 * height / top if top > 0 else height).astype(np.float32)


def line_segments(height: np.ndarray, params: EmapParams) -> tuple[np.ndarray, float, float]:
    """Segments of the resized height image, (N, 2, 3) in its pixels and grey levels, and
    the resize's scale factors (region px per resized px) in u and v."""
    size = params.image_size
    small = cv2.resize(height, (size, size), interpolation=cv2.INTER_AREA)
    grey = cv2.medianBlur(np.clip(np.rint(small), 0, 255).astype(np.uint8), params.median_blur)
    found = cv2.createLineSegmentDetector().detect(grey)[0]
    lines = np.zeros((0, 4)) if found is None else found.reshape(-1, 4).astype(np.float64)
    lines = lines[np.hypot(lines[:, 2] - lines[:, 0], lines[:, 3] - lines[:, 1])
                  >= params.min_length]
    reach = 2 * params.endpoint_radius + 1
    top = cv2.dilate(grey, np.ones((reach, reach), np.uint8)).astype(np.float64)
    ends = lines.reshape(-1, 2, 2)
    cols = np.clip(np.rint(ends[..., 0]).astype(int), 0, size - 1)
    rows = np.clip(np.rint(ends[..., 1]).astype(int), 0, size - 1)
    segments = np.concatenate([ends, top[rows, cols][..., None]], axis=-1)
    return segments, height.shape[1] / size, height.shape[0] / size


def window_values(segments: np.ndarray, params: EmapParams) -> np.ndarray:
    """The raw map E for each window position, (rows, columns)."""
    starts = np.arange(0, params.image_size - params.window + 1, params.stride)
    k = len(starts)
    writhe = 4.0 * np.pi * np.abs(writhe_matrix(segments))  # |solid angle|, as the authors'
    middles = segments[:, :, :2].mean(axis=1)
    u0, v0 = np.tile(starts, k)[None, :], np.repeat(starts, k)[None, :]  # window r * k + c
    inside = ((middles[:, :1] >= u0) & (middles[:, :1] < u0 + params.window)
              & (middles[:, 1:] >= v0) & (middles[:, 1:] < v0 + params.window)).T.astype(float)
    count = inside.sum(axis=1)
    pairs = count * (count - 1) / 2
    total = np.einsum("kn,nm,km->k", inside, writhe, inside) / 2
    w = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
    mean = np.divide(total, pairs, out=np.zeros_like(total), where=pairs > 0)
    upper = np.triu(np.ones_like(writhe, dtype=bool), 1)
    strong = (writhe[None] >= mean[:, None, None]) & upper[None]
    in_pair = inside[:, :, None] * inside[:, None, :]
    d = np.divide((strong * in_pair).sum(axis=(1, 2)), pairs, out=np.zeros_like(total),
                  where=pairs > 0)
    c = np.zeros_like(total)
    if len(segments) >= 2 and writhe.max() > 0:
        i, j = np.unravel_index(np.argmax(writhe), writhe.shape)
        corners = np.concatenate([segments[i, :, :2], segments[j, :, :2]])
        low, high = corners.min(axis=0), corners.max(axis=0)
        centre = np.stack([u0[0], v0[0]], axis=1) + params.window / 2
        c = 255.0 * np.all((centre >= low) & (centre <= high), axis=1)
    ww, wd, wc = params.weights
    return (ww * w + wd * d + wc * c).reshape(k, k)


def entanglement_map(depth: np.ndarray, roi: np.ndarray | tuple[int, int, int, int] | None = None,
                     params: EmapParams | None = None) -> EntanglementMap:
    """The entanglement map of ``depth`` over ``roi``: a boolean mask (the bin's region, as
    :func:`~tangle_drake.graspability.roi.bin_roi` gives; pixels outside count as unseen and
    the map covers its bounding box), a box (u0, v0, u1, v1; end exclusive) or the image."""
    params = params or EmapParams()
    depth = np.asarray(depth, dtype=np.float64)
    if depth.ndim != 2 or depth.size == 0:
        raise TangleDrakeError(f"entanglement map: depth must be a 2-D image, got shape "
                               f"{depth.shape}")
    rows, cols = depth.shape
    if isinstance(roi, np.ndarray) and roi.dtype == bool:
        if roi.shape != depth.shape or not roi.any():
            raise TangleDrakeError("entanglement map: the region mask is empty or not the "
                                   "image's shape")
        vs, us = np.nonzero(roi)
        depth = np.where(roi, depth, np.nan)
        roi = (us.min(), vs.min(), us.max() + 1, vs.max() + 1)
    u0, v0, u1, v1 = roi if roi is not None else (0, 0, cols, rows)
    u0, v0, u1, v1 = max(int(u0), 0), max(int(v0), 0), min(int(u1), cols), min(int(v1), rows)
    if u1 - u0 < 2 or v1 - v0 < 2:
        raise TangleDrakeError(f"entanglement map: region {roi} holds no pixels of the "
                               f"{cols}x{rows} image")
    segments, su, sv = line_segments(height_image(depth, (u0, v0, u1, v1)), params)
    grid = window_values(segments, params)
    in_image = segments * np.array([su, sv, 1.0]) + np.array([u0, v0, 0.0])
    return EntanglementMap(grid, in_image, (u0, v0, u1, v1), (rows, cols))
