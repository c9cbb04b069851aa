"""What is left in the bin, as the top camera sees it: the height of the top surface above the
bin's floor on a metric grid over the floor.

The closed loop needs this where graspability has nothing to offer: a look with no candidate
(or none that can be picked) means "the bin is empty" only if the bin looks empty; otherwise
parts are left that no grasp reaches (against a wall, under the palm's overhang) and the
planner stirs the bin (:mod:`.stir`) instead of stopping. It reads the depth image only, so
it is the same on hardware.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.perception.camera import CameraModel
from tangle_drake.scenario import BinConfig

CELL = 0.004
"""Grid spacing over the bin's floor, m (a wire is 4-6 mm thick)."""
WALL_MARGIN = 0.004
"""Points this close to a wall are left out, m: near a wall a pixel may see the wall's inner
face, which is not a part."""


@dataclass(frozen=True)
class BinContents:
    """The top surface over the bin's inner floor.

    ``heights[i, j]`` is the highest point seen above the floor in the cell centred at world
    ``(x0 + i cell, y0 + j cell)``, m; NaN where the camera saw nothing there.
    """

    heights: np.ndarray
    origin: tuple[float, float]
    """World (x, y) of cell (0, 0)'s centre, m."""
    cell: float
    bin: BinConfig
    """The bin they lie in."""

    def occupied(self, min_height: float) -> np.ndarray:
        """Cells whose top is more than ``min_height`` above the floor."""
        with np.errstate(invalid="ignore"):
            return np.nan_to_num(self.heights, nan=0.0) > min_height

    def area(self, min_height: float) -> float:
        """Floor area covered by something taller than ``min_height``, m²."""
        return float(self.occupied(min_height).sum()) * self.cell ** 2

    def cell_xy(self, i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        """World (x, y) of cell centres, (..., 2)."""
        return np.stack(np.broadcast_arrays(self.origin[0] + np.asarray(i) * self.cell,
                                            self.origin[1] + np.asarray(j) * self.cell), -1)

    def top(self, stray_cells: int = 2) -> float:
        """The pile's top, m above the floor (0 where nothing was seen), the highest
        ``stray_cells`` cells left out: a real sensor's stray pixels do not raise it, while a
        wire standing up (a few cells) still does."""
        seen = np.sort(self.heights[np.isfinite(self.heights)])
        return float(seen[-1 - stray_cells]) if seen.size > stray_cells else 0.0

    def top_within(self, xy: np.ndarray, radius: float) -> float:
        """The highest point seen within ``radius`` of world ``xy``, m above the floor (0 where
        nothing was seen)."""
        i, j = np.indices(self.heights.shape)
        near = np.linalg.norm(self.cell_xy(i, j) - np.asarray(xy)[:2], axis=-1) <= radius
        values = np.nan_to_num(self.heights[near], nan=0.0)
        return float(values.max(initial=0.0))


def bin_contents(depth: np.ndarray, camera: CameraModel, bin_config: BinConfig,
                 cell: float = CELL, stride: int = 2) -> BinContents:
    """The bin's contents from a depth image (metres along the optical axis; NaN or 0 where
    nothing was seen) of ``camera``; every ``stride``-th pixel is used."""
    depth = np.asarray(depth, dtype=float)
    if depth.ndim == 3:
        depth = depth[:, :, 0]
    v, u = np.mgrid[0:depth.shape[0]:stride, 0:depth.shape[1]:stride]
    d = depth[v, u]
    seen = np.isfinite(d) & (d > 0)
    points = camera.pixel_to_world(u[seen], v[seen], d[seen])
    half = np.asarray(bin_config.inner_size, float) / 2
    centre = np.asarray(bin_config.center, float)
    shape = np.maximum(np.floor(2 * half / cell).astype(int), 1)
    origin = centre - half + cell / 2
    index = np.floor((points[:, :2] - (centre - half)) / cell).astype(int)
    inside = np.all(np.abs(points[:, :2] - centre) <= half - WALL_MARGIN, axis=1) & np.all(
        (index >= 0) & (index < shape), axis=1)
    heights = np.full(tuple(shape), np.nan)
    rise = points[inside, 2] - bin_config.floor_height
    flat = np.ravel_multi_index(tuple(index[inside].T), tuple(shape))
    top = np.full(heights.size, -np.inf)
    np.maximum.at(top, flat, rise)
    heights.flat[np.isfinite(top)] = np.maximum(top[np.isfinite(top)], 0.0)
    return BinContents(heights, (float(origin[0]), float(origin[1])), cell, bin_config)


class BinContentsSystem(LeafSystem):
    """Depth image in (``depth_image``), the bin's contents out (``bin_contents``, a
    :class:`BinContents`), computed on demand from the image (cached by Drake)."""

    def __init__(self, camera: CameraModel, bin_config: BinConfig) -> None:
        super().__init__()
        self._camera, self._bin = camera, bin_config
        k = camera.intrinsics
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(k.width, k.height)))
        self.DeclareAbstractOutputPort(
            "bin_contents", lambda: AbstractValue.Make(
                BinContents(np.zeros((1, 1)), (0.0, 0.0), CELL, bin_config)),
            self._calc, prerequisites_of_calc={self._depth.ticket()})

    def _calc(self, context: Context, output: AbstractValue) -> None:
        depth = np.asarray(self._depth.Eval(context).data)[:, :, 0]
        output.set_value(bin_contents(depth, self._camera, self._bin))
