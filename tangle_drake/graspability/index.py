"""The graspability index, fast: every depth level at once, by running minima.

For one hand orientation and one cell, scanning levels from the top down (Domae et al. 2014)
asks at each level ``k``: does the closing region hold a surface at or above ``k`` (contact),
and are the finger footprints free of any surface above the fingertips at ``k + m`` (``m``:
insertion depth in levels)? Contact first happens at ``k* = min(level over the closing
region)``, and a footprint surface collides at ``k`` iff its level ``< k + m``, so deeper
levels only add collisions. The scan therefore reduces to one test:

    graspable  <=>  min(level over the footprints) >= k* + m,   grasp level = k*

(with ``k* >= 1``: a closing region that reaches level 0, outside the map or the region of
interest, grasps nothing.)

The grip test (``GraspabilityParams.max_grip_span_m``) then drops a grasp whose top layer,
the closing region's cells of level ``< k* + g`` (``g <= m``: the layer's depth in levels),
stretches more than ``S`` cells along the closing direction: it fails iff some cell ``a1`` of
the layer has another at ``a2 > a1 + S``, i.e. iff ``min over a1 of max(level(a1), min(level
over a2 > a1 + S)) < k* + g``, again running minima (suffix minima along the closing
direction).

Both minima are over axis-aligned rectangles once the map is turned into the hand's frame
(:mod:`.rotation`), so they are separable running minima: one pass across the closing
direction shared by both masks, then one along it for each, each by doubling windows.
:mod:`.reference` runs the literal level-by-level scan and is tested to give identical maps.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from tangle_drake.graspability.hand import HandCells, HandModel
from tangle_drake.graspability.levels import Levels, quantize
from tangle_drake.graspability.params import GraspabilityParams
from tangle_drake.graspability.rotation import HandFrames
from tangle_drake.graspability.workmap import WorkMap


@dataclass(frozen=True)
class GraspMaps:
    """Per orientation and cell: 0 where the hand cannot grasp, else the grasp level (the
    level of the highest surface in the closing region, from 1, see :mod:`.levels`)."""

    encoded: np.ndarray
    """(n_orientations, ny, nx), the dtype of ``levels.index``."""
    levels: Levels
    angles_deg: np.ndarray


def hand_frames(work: WorkMap, hand: HandCells, params: GraspabilityParams) -> HandFrames:
    """The canvases both implementations use; their margin covers the hand's reach."""
    return HandFrames(work.z.shape, params.n_orientations, pad=hand.reach + 1)


def grasp_maps(work: WorkMap, hand: HandModel, params: GraspabilityParams) -> GraspMaps:
    """The graspable maps of all orientations (see the module docstring)."""
    levels = quantize(work, hand, params)
    cells = hand.in_cells(work.cell_m)
    frames = hand_frames(work, cells, params)
    encoded = np.empty((params.n_orientations, *work.z.shape), levels.index.dtype)
    for base in frames.bases:
        # Outside the map is level 0, above everything: a finger there collides.
        canvas = frames.base_canvas(levels.index, base, border=0)
        turned = frames.turned(base)
        for k, closing_axis in ((base, 1), (turned, 0)):
            if k is not None:
                part, offset = _grasp_levels(canvas, cells, levels.insertion, closing_axis,
                                             _grip_test(params, work.cell_m))
                encoded[k] = frames.base_to_grid(part, base, offset)
    return GraspMaps(encoded, levels, frames.angles_deg)


def _grip_test(params: GraspabilityParams, cell_m: float) -> tuple[int, int] | None:
    """The grip test's layer (levels) and longest span (cells); ``None`` when it is off."""
    span = params.grip_span_cells(cell_m)
    return None if span is None else (params.grip_layer_levels, span)


def _grasp_levels(canvas: np.ndarray, hand: HandCells, insertion: int, closing_axis: int,
                  grip: tuple[int, int] | None) -> tuple[np.ndarray, tuple[int, int]]:
    """Encoded grasp map on one canvas, closing along ``closing_axis`` (1: +X, 0: +Y).

    Computed only where the whole hand lies on the canvas (the canvas margin keeps every grid
    cell there): returns that part and its top-left corner (x, y) on the canvas.
    """
    across_axis = 1 - closing_axis
    reach, half = hand.finger_outer, hand.half_width
    across = _window_mins(canvas, [2 * half + 1], across_axis)[2 * half + 1]
    contact_len = 2 * hand.contact_half + 1
    finger_len = hand.finger_outer - hand.finger_inner + 1
    mins = {1: across, **_window_mins(across, [contact_len, finger_len], closing_axis)}
    length = canvas.shape[closing_axis]

    def at(window: int, offset: int) -> np.ndarray:
        """Minimum over the window that starts ``offset`` cells from each hand position."""
        return mins[window][_along(closing_axis, reach + offset, length - reach + offset)]

    contact_top = at(contact_len, -hand.contact_half)
    footprints = cv2.min(at(finger_len, hand.finger_inner), at(finger_len, -hand.finger_outer))
    ok = cv2.compare(footprints, cv2.add(contact_top, insertion), cv2.CMP_GE)
    if grip is not None and 2 * hand.contact_half > grip[1]:  # else no pair is too wide
        layer, span = grip
        column = [at(1, a) for a in range(-hand.contact_half, hand.contact_half + 1)]
        bottom = cv2.add(contact_top, layer)
        ok = cv2.min(ok, cv2.compare(_widest_pair(column, span), bottom, cv2.CMP_GE))
    if canvas.dtype == np.uint8:  # ok is 0 or 255, above every level
        part = cv2.min(contact_top, ok)
    else:
        part = cv2.bitwise_and(contact_top, contact_top, mask=ok)
    return part, ((reach, half) if closing_axis == 1 else (half, reach))


def _widest_pair(column: list[np.ndarray], span: int) -> np.ndarray:
    """``min over i < j, j - i > span`` of ``max(column[i], column[j])``: the highest level at
    which two cells more than ``span`` apart both hold something (needs ``len(column) > span +
    1``). It never exceeds the dtype's top, so comparing it with a saturated sum stays exact."""
    n = len(column)
    suffix = column[n - 1]
    widest = cv2.max(column[n - span - 2], suffix)
    for i in range(n - span - 3, -1, -1):
        suffix = cv2.min(suffix, column[i + span + 1])
        widest = cv2.min(widest, cv2.max(column[i], suffix))
    return widest


def _window_mins(image: np.ndarray, lengths: list[int], axis: int) -> dict[int, np.ndarray]:
    """For each ``L`` in ``lengths``: ``out[i] = min(image[i : i + L])`` along ``axis``.

    Doubling (windows of 1, 2, 4, ... cells, then two overlapping ones per length) costs
    O(log L) passes of ``cv2.min`` instead of the O(L) of a plain running minimum.
    """
    powers = [image]
    while 2 ** len(powers) <= max(lengths):
        span, last = 2 ** (len(powers) - 1), powers[-1]
        n = last.shape[axis]
        powers.append(cv2.min(last[_along(axis, 0, n - span)], last[_along(axis, span, n)]))
    out = {}
    for length in lengths:
        p = length.bit_length() - 1
        rest, n = length - 2**p, powers[p].shape[axis]
        out[length] = powers[p] if rest == 0 else cv2.min(
            powers[p][_along(axis, 0, n - rest)], powers[p][_along(axis, rest, n)])
    return out


def _along(axis: int, start: int, stop: int) -> tuple[slice, slice]:
    """Index ``start:stop`` along ``axis`` of a 2-D array, everything along the other."""
    return (slice(start, stop), slice(None)) if axis == 0 else (slice(None), slice(start, stop))
