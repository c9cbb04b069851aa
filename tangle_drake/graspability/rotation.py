"""Resampling the work map into hand-aligned canvases and back.

Rotating the image once per orientation, instead of rotating the hand's masks, makes every
mask an axis-aligned rectangle, so each test "is anything in this rectangle" becomes a
separable running minimum. A canvas for orientation ``theta`` has its +X axis along the closing
direction ``(cos theta, sin theta)`` of the grid and +Y along ``(-sin theta, cos theta)``.

Sampling is nearest-neighbour about integer centres, so multiples of 90 degrees are exact and
each canvas value is one real cell's value. The canvas of ``theta + 90 deg`` is the canvas of
``theta`` turned by a quarter (``np.rot90``); only orientations below 90 degrees are
resampled. Everything outside the grid reads ``border`` (the index uses level 0, "above
everything").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class _Frame:
    to_grid: np.ndarray
    """2x3 affine map from canvas pixel to grid cell coordinates."""
    to_canvas: np.ndarray
    """2x3 affine map from grid cell to canvas pixel coordinates."""
    canvas_size: tuple[int, int]
    """(width, height) of the canvas."""


class HandFrames:
    """The canvases of ``n`` orientations, ``k * 180 / n`` degrees, for one grid shape."""

    def __init__(self, grid_shape: tuple[int, int], n_orientations: int, pad: int) -> None:
        """``pad``: canvas cells beyond the turned grid, at least the hand's reach."""
        self.grid_shape = grid_shape
        self.n = n_orientations
        self.angles_deg = np.arange(n_orientations) * 180.0 / n_orientations
        self._quarter = n_orientations // 2 if n_orientations % 2 == 0 else n_orientations
        self._frames = [_make_frame(grid_shape, float(a), pad)
                        for a in self.angles_deg[: self._quarter]]

    @property
    def bases(self) -> range:
        """Orientations whose canvas is resampled; ``k + n/2`` (if any) reuses ``k``'s."""
        return range(self._quarter)

    def turned(self, base: int) -> int | None:
        """The orientation 90 degrees from ``base`` that shares its canvas, if there is one."""
        k = base + self._quarter
        return k if k < self.n else None

    def base_canvas(self, grid: np.ndarray, base: int, border: int | float) -> np.ndarray:
        """``grid`` resampled into the canvas of orientation ``base`` (a base orientation)."""
        frame = self._frames[base]
        return cv2.warpAffine(grid, frame.to_grid, frame.canvas_size,
                              flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=border)

    def base_to_grid(self, canvas: np.ndarray, base: int,
                     offset: tuple[int, int] = (0, 0)) -> np.ndarray:
        """A map on the canvas of orientation ``base`` resampled back onto the grid.

        ``canvas`` may be a part of the canvas whose top-left pixel is ``offset`` (x, y);
        grid cells outside it read 0.
        """
        frame = self._frames[base]
        to_part = frame.to_canvas - np.array([[0, 0, offset[0]], [0, 0, offset[1]]])
        ny, nx = self.grid_shape
        return cv2.warpAffine(canvas, to_part, (nx, ny),
                              flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=0)

    def canvas(self, grid: np.ndarray, k: int, border: int | float) -> np.ndarray:
        """``grid`` in the canvas of any orientation ``k``, closing direction along +X."""
        base = k % self._quarter
        canvas = self.base_canvas(grid, base, border)
        return canvas if base == k else np.ascontiguousarray(np.rot90(canvas, 1))

    def to_grid(self, canvas: np.ndarray, k: int) -> np.ndarray:
        """A map on orientation ``k``'s canvas (from :meth:`canvas`) back onto the grid."""
        base = k % self._quarter
        if base != k:
            canvas = np.ascontiguousarray(np.rot90(canvas, -1))
        return self.base_to_grid(canvas, base)


def _make_frame(grid_shape: tuple[int, int], angle_deg: float, pad: int) -> _Frame:
    ny, nx = grid_shape
    c, s = _cos_sin(angle_deg)
    gx, gy = nx // 2, ny // 2  # integer centres keep quarter turns exact
    corners = np.array([[-gx, -gy], [nx - 1 - gx, -gy], [-gx, ny - 1 - gy],
                        [nx - 1 - gx, ny - 1 - gy]], float)
    X = corners @ np.array([c, s])
    Y = corners @ np.array([-s, c])
    cx = math.ceil(-X.min() - 1e-9) + pad
    cy = math.ceil(-Y.min() - 1e-9) + pad
    width = cx + math.ceil(X.max() - 1e-9) + pad + 1
    height = cy + math.ceil(Y.max() - 1e-9) + pad + 1
    # grid point p = g + (P - C).x * (c, s) + (P - C).y * (-s, c), and its inverse.
    to_grid = np.array([[c, -s, gx - c * cx + s * cy], [s, c, gy - s * cx - c * cy]])
    to_canvas = np.array([[c, s, cx - c * gx - s * gy], [-s, c, cy + s * gx - c * gy]])
    return _Frame(to_grid, to_canvas, (width, height))


def _cos_sin(angle_deg: float) -> tuple[float, float]:
    """cos and sin, exactly 0 or +-1 at multiples of 90 degrees."""
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    return (0.0 if abs(c) < 1e-12 else c), (0.0 if abs(s) < 1e-12 else s)
