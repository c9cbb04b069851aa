"""From graspable maps to a few ranked grasps: Gaussian blur, local peaks, spacing.

A grasp's score is the Gaussian-weighted share of its neighbourhood where the same orientation
also grasps: 1 means the grasp survives a position error of a few sigma in any direction, a
value near 0 an isolated lucky cell. Each place keeps its best orientation.

Scores live on a grid twice as coarse as the work map: ``pyrDown`` (a binomial filter of one
cell's sigma, then every other cell) and a Gaussian for the rest of sigma. Sigma spans
several cells, so this loses nothing that matters for ranking, for a quarter of the cost.

Peaks are the coarse cells no 8-neighbour beats. A peak's plateau (connected cells whose
scores stay within ``peak_tolerance`` of its own) can be long, e.g. along a straight bar; the
candidate goes to the plateau's centroid, so a bar is grasped at its middle: to the work-map
cell nearest the centroid where the plateau's orientation really grasps; its score is the
peak's. Peaks are taken best
first; a plateau is passed over when its candidate would lie within ``min_distance_m`` of a
taken one or its closing region would leave the region of interest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tangle_drake.graspability.params import GraspabilityParams

_PYRDOWN_VARIANCE = 1.0
"""Variance (work-map cells^2) of pyrDown's [1 4 6 4 1] / 16 filter."""


@dataclass(frozen=True)
class Peak:
    """A chosen grasp: a work-map cell, an orientation, its score."""

    row: int
    col: int
    orientation: int
    score: float


def best_grasps(encoded: np.ndarray, cell_m: float, params: GraspabilityParams) -> list[Peak]:
    """Up to ``top_k`` grasps, best first (``encoded``: (n, ny, nx), 0 where not graspable)."""
    sigma = params.blur_sigma_m / cell_m
    scores = (coarse_blur(cv2.compare(grasp, 0, cv2.CMP_GT), sigma) for grasp in encoded)
    best = next(scores)
    orientation = np.zeros(best.shape, np.uint16)
    for k, score in enumerate(scores, start=1):
        orientation[score > best] = k
        np.maximum(best, score, out=best)
    return _spaced_peaks(best, orientation, encoded, cell_m, params)


def coarse_blur(mask: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur (``sigma`` in work-map cells) of a 0/255 mask, as a float32 share in
    [0, 1] on every other cell (cell ``(i, j)`` is the work map's ``(2i, 2j)``)."""
    half = cv2.pyrDown(mask).astype(np.float32)
    half_sigma = math.sqrt(max(sigma**2 - _PYRDOWN_VARIANCE, 0.0)) / 2
    if half_sigma > 0.3:
        half = cv2.GaussianBlur(half, (2 * math.ceil(3 * half_sigma) + 1,) * 2, half_sigma)
    return half * np.float32(1 / 255)


def _spaced_peaks(best: np.ndarray, orientation: np.ndarray, encoded: np.ndarray,
                  cell_m: float, params: GraspabilityParams) -> list[Peak]:
    is_peak = (best > 0) & (best >= cv2.dilate(best, np.ones((3, 3), np.uint8)))
    rows, cols = np.nonzero(is_peak)
    order = np.argsort(-best[rows, cols], kind="stable")
    rows, cols = rows[order], cols[order]
    min_distance_sq = (params.min_distance_m / cell_m) ** 2
    reach = math.ceil(3 * params.blur_sigma_m / cell_m)
    peaks: list[Peak] = []
    while len(peaks) < params.top_k and rows.size:
        score = float(best[rows[0], cols[0]])
        (r0, c0), plateau = _plateau(best, int(rows[0]), int(cols[0]), params.peak_tolerance)
        r, c = np.nonzero(plateau)
        centre = np.array([r.mean() + r0, c.mean() + c0])
        nearest = np.argmin((r + r0 - centre[0]) ** 2 + (c + c0 - centre[1]) ** 2)
        k = int(orientation[r[nearest] + r0, c[nearest] + c0])
        cell = _nearest_grasp(encoded[k], 2 * centre, reach)
        keep = np.ones(rows.shape, bool)
        if cell is not None:
            row, col = cell
            spaced = all((p.row - row) ** 2 + (p.col - col) ** 2 >= min_distance_sq
                         for p in peaks)
            if spaced:
                peaks.append(Peak(row, col, k, score))
                keep = (2 * rows - row) ** 2 + (2 * cols - col) ** 2 >= min_distance_sq
        inside = ((rows >= r0) & (rows < r0 + plateau.shape[0])
                  & (cols >= c0) & (cols < c0 + plateau.shape[1]))
        keep[inside] &= ~plateau[rows[inside] - r0, cols[inside] - c0]
        rows, cols = rows[keep], cols[keep]
    return peaks


def _plateau(best: np.ndarray, row: int, col: int,
             tolerance: float) -> tuple[tuple[int, int], np.ndarray]:
    """Cells 8-connected to ``(row, col)`` whose scores stay within ``tolerance`` (a fraction)
    of its score, as the top-left corner and the mask of their bounding box."""
    mask = np.zeros((best.shape[0] + 2, best.shape[1] + 2), np.uint8)
    diff = float(best[row, col]) * tolerance
    flags = 8 | cv2.FLOODFILL_FIXED_RANGE | cv2.FLOODFILL_MASK_ONLY | (1 << 8)
    _, _, _, (x, y, w, h) = cv2.floodFill(best, mask, (col, row), 0, diff, diff, flags)
    return (y, x), mask[y + 1: y + 1 + h, x + 1: x + 1 + w] == 1


def _nearest_grasp(grasp: np.ndarray, centre: np.ndarray, reach: int) -> tuple[int, int] | None:
    """The graspable work-map cell nearest ``centre`` (row, col), within ``reach`` cells."""
    r0, c0 = (max(0, math.floor(x) - reach) for x in centre)
    window = grasp[r0: math.ceil(centre[0]) + reach + 1, c0: math.ceil(centre[1]) + reach + 1]
    r, c = np.nonzero(window)
    if r.size == 0:
        return None
    nearest = np.argmin((r + r0 - centre[0]) ** 2 + (c + c0 - centre[1]) ** 2)
    if (r[nearest] + r0 - centre[0]) ** 2 + (c[nearest] + c0 - centre[1]) ** 2 > reach**2:
        return None
    return int(r[nearest] + r0), int(c[nearest] + c0)
