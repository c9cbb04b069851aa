"""How deep a settled pile is, in layers: how many parts lie over one point of the floor.

Each part's surface points are projected onto a grid of ``CELL_M`` cells on the floor; a
cell's count is the number of distinct parts whose shadow covers it. Over the cells the
pile covers, ``layers`` is the 99th percentile of the count (the depth at the pile's deepest
points, robust to one odd cell) and ``max_layers`` its maximum. A pile of parts lying side by
side is one layer deep whatever its size; wire parts crossing in three levels make three.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CELL_M = 0.002


@dataclass(frozen=True)
class PileDepth:
    layers: float
    """99th percentile, over the covered floor, of the number of parts over one point."""
    max_layers: int
    height_m: float
    """Height of the pile's highest point above the bin floor."""


def pile_depth(poses: np.ndarray, points_B: np.ndarray, floor_height: float,
               in_bin: np.ndarray | None = None) -> PileDepth:
    """Depth of the pile of parts at world ``poses`` (N, 4, 4) sharing surface ``points_B``;
    ``in_bin`` (N,) bool leaves out parts that are not in the bin (parked ones)."""
    cover: dict[tuple[int, int], int] = {}
    top = floor_height
    for n, X in enumerate(poses):
        if in_bin is not None and not in_bin[n]:
            continue
        p = points_B @ X[:3, :3].T + X[:3, 3]
        top = max(top, float(p[:, 2].max()))
        for cell in set(map(tuple, np.floor(p[:, :2] / CELL_M).astype(np.int64).tolist())):
            cover[cell] = cover.get(cell, 0) + 1
    counts = np.fromiter(cover.values(), dtype=np.int64, count=len(cover))
    if counts.size == 0:
        return PileDepth(0.0, 0, 0.0)
    return PileDepth(layers=float(np.percentile(counts, 99)), max_layers=int(counts.max()),
                     height_m=top - floor_height)
