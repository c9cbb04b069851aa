"""The work map: the scene's top surface on a metric grid in the camera's x-y plane.

Why not work on the image itself: the hand approaches along the camera's +z, parallel to the
optical axis, not along the pixel rays. In a perspective image a finger footprint covers a
different set of pixels at every height (pixel size = depth / f) and, away from the image
centre, a tall neighbour also appears shifted by parallax (15 mm at the edge of a 0.3 m bin for
a 5 cm height difference, two finger thicknesses). Re-projecting the depth pixels onto a grid
of fixed metric cells in the camera's x-y plane removes both: the hand's masks are the same
cells at every depth level, so nothing is approximated by one "representative" depth. A height
map seen from straight above is already such a grid (an orthographic view); it goes through the
same code with a constant pixel size.

Building the map:
  1. pixels are min-pooled in blocks (never finer than a cell) and back-projected to (x, y, z);
  2. each cell keeps the smallest depth (the highest point) that falls in it;
  3. cells nothing fell in (missing pixels, occlusion shadows) take the value of the nearest
     cell that has one;
  4. a 3x3 median removes speckle (single cells far above or below their neighbours).
The grid is centred on the optical axis, so flipping or quarter-turning the image about its
centre flips or turns the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tangle_drake.perception.camera import CameraIntrinsics


@dataclass(frozen=True)
class View:
    """How image pixels relate to camera-frame points: perspective or orthographic.

    Perspective: ``x = (u - cx) z / fx``. Orthographic (a height map): ``x = (u - cx) / fx``,
    ``fx`` then being pixels per metre.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    perspective: bool

    @staticmethod
    def of_camera(k: CameraIntrinsics) -> View:
        return View(k.width, k.height, k.fx, k.fy, k.cx, k.cy, perspective=True)

    @staticmethod
    def of_height_map(shape: tuple[int, int], pixel_size_m: float) -> View:
        """A height map's pixels, centred on its middle, ``pixel_size_m`` apart."""
        height, width = shape
        return View(width, height, 1 / pixel_size_m, 1 / pixel_size_m,
                    (width - 1) / 2, (height - 1) / 2, perspective=False)

    def metres_per_pixel(self, z: np.ndarray | float) -> tuple[np.ndarray | float, ...]:
        """Size of one pixel along u and v for a surface at depth ``z``."""
        scale = z if self.perspective else 1.0
        return scale / self.fx, scale / self.fy

    def to_pixel(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """Pixel (u, v) of camera-frame point(s) (x, y, z)."""
        sx, sy = self.metres_per_pixel(z)
        return x / sx + self.cx, y / sy + self.cy


@dataclass(frozen=True)
class WorkMap:
    """Depth (m, camera +z) of the scene's top surface per cell; cell ``(row, col)`` is centred
    at ``x = (col - (nx - 1) / 2) * cell_m``, ``y = (row - (ny - 1) / 2) * cell_m``."""

    z: np.ndarray
    cell_m: float
    view: View
    allowed: np.ndarray | None = None
    """Cells inside the region of interest (bool), ``None`` for all."""

    def cell_xy(self, row: np.ndarray | float, col: np.ndarray | float) -> tuple[np.ndarray, ...]:
        """Camera-frame x, y of cell centres (fractional rows/columns allowed)."""
        ny, nx = self.z.shape
        return (col - (nx - 1) / 2) * self.cell_m, (row - (ny - 1) / 2) * self.cell_m

    def pixel_mask_to_cells(self, mask: np.ndarray) -> np.ndarray:
        """Which cells' surface points are seen inside ``mask`` (an image-sized boolean mask)."""
        ny, nx = self.z.shape
        rows, cols = np.mgrid[0:ny, 0:nx]
        x, y = self.cell_xy(rows, cols)
        u, v = self.view.to_pixel(x, y, self.z)
        inside = cv2.remap(mask.astype(np.uint8), u.astype(np.float32), v.astype(np.float32),
                           cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return inside > 0


def build_work_map(depth: np.ndarray, view: View, cell_m: float) -> WorkMap:
    """The work map of a checked depth image (float32, +inf = missing, one valid at least)."""
    z_far = _far_depth(depth)
    pixel_m = max(view.metres_per_pixel(z_far))
    cell_m = max(cell_m, pixel_m)
    block = max(1, math.floor(cell_m / pixel_m + 1e-9))
    pooled = _min_pool(depth, block)

    # Cells cover the image's footprint at the far depth, symmetric about the optical axis;
    # a grid as fine as an orthographic image's pixels puts cells on the pixels.
    sx, sy = view.metres_per_pixel(z_far)
    nx = _cells_spanning(max(view.cx, view.width - 1 - view.cx) * sx, cell_m, view.width)
    ny = _cells_spanning(max(view.cy, view.height - 1 - view.cy) * sy, cell_m, view.height)
    # Cell index = pixel offset from the principal point, scaled by depth / f / cell (or by
    # 1 / f / cell for a height map). Missing pixels (+inf) and points beyond the grid (from
    # depths past z_far) are dropped by scattering +inf, which never wins the minimum.
    u = np.arange(pooled.shape[1]) * block + (block - 1) / 2
    v = np.arange(pooled.shape[0]) * block + (block - 1) / 2
    per_col = ((u - view.cx) / view.fx / cell_m).astype(np.float32)[None, :]
    per_row = ((v - view.cy) / view.fy / cell_m).astype(np.float32)[:, None]
    scale = _finite_or_zero(pooled) if view.perspective else np.float32(1)
    col = np.rint(scale * per_col + np.float32((nx - 1) / 2)).astype(np.int32)
    row = np.rint(scale * per_row + np.float32((ny - 1) / 2)).astype(np.int32)
    inside = (col >= 0) & (col < nx) & (row >= 0) & (row < ny)
    cells = np.where(inside, row * nx + col, 0)
    grid = np.full(ny * nx, np.inf, np.float32)
    np.minimum.at(grid, cells.ravel(), np.where(inside, pooled, np.float32(np.inf)).ravel())
    grid = _fill_from_nearest(grid.reshape(ny, nx))
    return WorkMap(cv2.medianBlur(grid, 3), cell_m, view)


def _far_depth(depth: np.ndarray) -> float:
    """The far end of the scene: the 99th percentile of valid depths (of every 4th pixel),
    so a few stray far readings neither coarsen the cells nor blow up the grid."""
    sample = depth[::4, ::4]
    valid = sample[sample < np.inf]
    if valid.size == 0:  # the valid pixels all fell between the samples
        valid = depth[depth < np.inf]
    return float(np.percentile(valid, 99))


def _finite_or_zero(image: np.ndarray) -> np.ndarray:
    """``image`` with +inf replaced by 0."""
    return cv2.threshold(image, float(np.finfo(np.float32).max), 0, cv2.THRESH_TOZERO_INV)[1]


def _min_pool(image: np.ndarray, block: int) -> np.ndarray:
    """Minimum over ``block`` x ``block`` pixel blocks (a partial last block included)."""
    if block == 1:
        return image
    lowest = cv2.erode(image, np.ones((block, block), np.uint8), anchor=(0, 0),
                       borderType=cv2.BORDER_CONSTANT, borderValue=float("inf"))
    return np.ascontiguousarray(lowest[::block, ::block])


def _cells_spanning(half_extent_m: float, cell_m: float, pixels: int) -> int:
    """Cells covering ``[-half_extent, half_extent]``, with the parity of the image's pixels."""
    n = max(1, math.ceil(2 * half_extent_m / cell_m - 1e-9))
    return n + (n - pixels) % 2


def _fill_from_nearest(grid: np.ndarray) -> np.ndarray:
    """Give each empty (+inf) cell the value of its nearest non-empty cell."""
    empty = ~np.isfinite(grid)
    if not empty.any():
        return grid
    _, labels = cv2.distanceTransformWithLabels(empty.astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    values = grid[~empty]  # raster order, the order in which the labels were given
    return values[labels - 1].astype(np.float32)
