"""The graspability index, slowly and literally: the reference the fast one is tested against.

This is the paper's procedure as written (Domae et al. 2014; Matsumura et al. 2019, III-A), with
no algebra applied: for every orientation, draw the closing-region and finger-footprint masks;
for every depth level from the top down, binarise the map at the level (contact) and at the
level plus the insertion depth (collision), convolve both with the masks, and keep the first
level where the closing region holds something and the footprints hold nothing, and (the grip
test) where the closing region's cells holding something in the top layer below that level lie
no farther apart along the closing direction than allowed. It shares
with :mod:`.index` only what defines the problem (the work map, its levels, the hand's cells and
the hand-aligned resampling), so the equality test checks the running-minimum reduction, the
shared pass, the footprint shifts and the quarter-turn reuse. Used by the tests; far too slow
for anything else.
"""

from __future__ import annotations

import cv2
import numpy as np

from tangle_drake.graspability.hand import HandCells, HandModel
from tangle_drake.graspability.index import GraspMaps, hand_frames
from tangle_drake.graspability.levels import quantize
from tangle_drake.graspability.params import GraspabilityParams
from tangle_drake.graspability.workmap import WorkMap


def reference_grasp_maps(work: WorkMap, hand: HandModel,
                         params: GraspabilityParams) -> GraspMaps:
    """Same output as :func:`.index.grasp_maps`, by the level-by-level scan."""
    levels = quantize(work, hand, params)
    cells = hand.in_cells(work.cell_m)
    frames = hand_frames(work, cells, params)
    contact_mask, footprint_mask = _masks(cells)
    n_levels = int(levels.index.max())
    grip_span = params.grip_span_cells(work.cell_m)
    encoded = np.empty((params.n_orientations, *work.z.shape), levels.index.dtype)
    for k in range(params.n_orientations):
        canvas = frames.canvas(levels.index, k, border=0).astype(np.int64)
        found = np.zeros(canvas.shape, np.int64)  # 0: no grasp yet, else the grasp level
        for level in range(1, n_levels + 1):
            contact = _count(canvas <= level, contact_mask) > 0
            collision = _count(canvas < level + levels.insertion, footprint_mask) > 0
            new = (found == 0) & contact & ~collision
            if grip_span is not None and new.any():
                squeezed = canvas < level + params.grip_layer_levels
                new &= _grip_span(squeezed, cells) <= grip_span
            found[new] = level
        encoded[k] = frames.to_grid(found.astype(levels.index.dtype), k)
    return GraspMaps(encoded, levels, frames.angles_deg)


def _masks(hand: HandCells) -> tuple[np.ndarray, np.ndarray]:
    """Closing-region and footprint masks, closing along +X, centred on the hand's centre."""
    a = np.abs(np.arange(-hand.finger_outer, hand.finger_outer + 1))
    rows = 2 * hand.half_width + 1
    contact = np.repeat((a <= hand.contact_half)[None, :], rows, axis=0)
    footprint = np.repeat(((a >= hand.finger_inner) & (a <= hand.finger_outer))[None, :],
                          rows, axis=0)
    return contact.astype(np.float32), footprint.astype(np.float32)


def _grip_span(binary: np.ndarray, hand: HandCells) -> np.ndarray:
    """How far apart (cells along the closing direction) the closing region's outermost
    columns holding a true pixel lie, at every position (0 if one or none does)."""
    rows, cols = 2 * hand.half_width + 1, 2 * hand.finger_outer + 1
    offsets = range(-hand.contact_half, hand.contact_half + 1)
    hits = []
    for a in offsets:
        column = np.zeros((rows, cols), np.float32)
        column[:, hand.finger_outer + a] = 1.0
        hits.append(_count(binary, column) > 0)
    stack = np.stack(hits)
    first = np.argmax(stack, axis=0)
    last = len(offsets) - 1 - np.argmax(stack[::-1], axis=0)
    return np.where(stack.any(axis=0), last - first, 0)


def _count(binary: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """How many mask cells hold a true pixel, at every position (outside the canvas: none)."""
    counts = cv2.filter2D(binary.astype(np.float32), -1, mask, borderType=cv2.BORDER_CONSTANT)
    return np.rint(counts)
