"""The fast index equals the literal level-by-level reference (tangle_drake.graspability.reference).

What is equal, exactly: for every orientation and every work-map cell, whether the hand can
grasp there and at which depth level (``GraspMaps.encoded``, element for element, no
tolerance), and therefore the candidate lists (same fields, same order). Both run on the same
work map, levels and hand-aligned resampling; the test covers what the fast one does
differently: all levels at once by running minima, shared and doubling passes, finger shifts,
and the reuse of one canvas for two orientations 90 degrees apart.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest

from tangle_drake.graspability import GraspabilityParams, HandModel
from tangle_drake.graspability.candidates import candidates_from_depth
from tangle_drake.graspability.index import grasp_maps
from tangle_drake.graspability.inputs import height_map_to_depth
from tangle_drake.graspability.params import FINGER_GRIP_SPAN_M
from tangle_drake.graspability.ranking import coarse_blur
from tangle_drake.graspability.reference import reference_grasp_maps
from tangle_drake.graspability.roi import roi_mask
from tangle_drake.graspability.synthetic import HeightField, wire_part
from tangle_drake.graspability.workmap import View, build_work_map
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec

PIXEL = 0.002
LEVEL = 1e-4


def random_scene(seed: int, size_m: tuple[float, float] = (0.17, 0.13),
                 n_parts: int = 12, tall_box: bool = False) -> tuple[np.ndarray, View]:
    """A random heap of wires (and maybe a tall box) as a depth map seen from above."""
    rng = np.random.default_rng(seed)
    field = HeightField(size_m, resolution_m=PIXEL)
    for _ in range(n_parts):
        centre = rng.uniform(-0.5, 0.5, 2) * np.array(size_m)
        field.add_wire(wire_part(rng, centre, rng.uniform(0.03, 0.09)), rng.uniform(0.006, 0.01))
    if tall_box:
        field.add_box(-0.02, -0.01, 0.0, 0.02, 0.06)
    height_map = np.rint(field.heights / LEVEL).astype(np.uint16)
    depth = height_map_to_depth(height_map, LEVEL)
    return depth, View.of_height_map(depth.shape, PIXEL)


CASES = [
    pytest.param(0, DEFAULT_GRIPPER, GraspabilityParams(), False, None, id="defaults"),
    pytest.param(1, DEFAULT_GRIPPER, GraspabilityParams(cell_size_m=0.002), False, None,
                 id="finer-cells"),
    pytest.param(2, GripperSpec(max_opening=0.03, finger_width=0.016, finger_thickness=0.006),
                 GraspabilityParams(n_orientations=5, insertion_depth_m=0.006), False, None,
                 id="odd-orientations-other-hand"),
    pytest.param(3, DEFAULT_GRIPPER,
                 GraspabilityParams(n_orientations=4, level_step_m=0.0002), True, None,
                 id="16-bit-levels"),
    pytest.param(4, DEFAULT_GRIPPER, GraspabilityParams(roi_margin_px=3), False, (10, 5, 70, 60),
                 id="region-of-interest"),
    pytest.param(5, DEFAULT_GRIPPER,
                 GraspabilityParams(grip_layer_m=0.002, max_grip_span_m=0.008), False, None,
                 id="tight-grip-test"),
    pytest.param(6, DEFAULT_GRIPPER, GraspabilityParams(max_grip_span_m=FINGER_GRIP_SPAN_M),
                 False, None, id="finger-grip-test"),
]


@pytest.mark.parametrize(("seed", "gripper", "params", "tall", "roi"), CASES)
def test_fast_maps_and_candidates_equal_the_reference(seed, gripper, params, tall, roi):
    depth, view = random_scene(seed, tall_box=tall)
    hand = HandModel.from_gripper(gripper)
    work = build_work_map(depth, view, params.cell_size_m)
    if roi is not None:
        allowed = roi_mask(roi, view.width, view.height, params.roi_margin_px)
        work = replace(work, allowed=work.pixel_mask_to_cells(allowed))
    fast = grasp_maps(work, hand, params)
    slow = reference_grasp_maps(work, hand, params)
    assert fast.encoded.dtype == slow.encoded.dtype == (np.uint16 if tall else np.uint8)
    assert np.count_nonzero(fast.encoded) > 100  # a scene with something to grasp
    assert roi is None or np.count_nonzero(fast.levels.index == 0) > 1000
    assert np.array_equal(fast.encoded, slow.encoded)
    without_grip_test = grasp_maps(work, hand, replace(params, max_grip_span_m=None))
    dropped = np.count_nonzero(without_grip_test.encoded) - np.count_nonzero(fast.encoded)
    assert dropped > 100 if params.max_grip_span_m is not None else dropped == 0

    def candidates(maps_function):
        found = candidates_from_depth(depth, view, hand, params, roi, None, maps_function)
        return [c.to_dict() for c in found]

    fast_candidates = candidates(grasp_maps)
    assert fast_candidates and fast_candidates == candidates(reference_grasp_maps)


def test_coarse_blur_is_close_to_a_full_gaussian():
    """Scores on the coarse grid equal a full-resolution Gaussian blur at those cells within
    0.015, away from the map's edge (where the two treat the border differently and the index
    never grasps: a hand reaching past the edge collides)."""
    rng = np.random.default_rng(0)
    for blob in (3, 6):
        noise = cv2.GaussianBlur(rng.random((120, 161)).astype(np.float32), (0, 0), blob)
        mask = (noise > 0.5).astype(np.uint8) * 255
        for sigma in (2.5, 3.75, 6.0):
            full = cv2.GaussianBlur(mask.astype(np.float32) / 255,
                                    (2 * math.ceil(4 * sigma) + 1,) * 2, sigma)[::2, ::2]
            edge = math.ceil(2 * sigma)
            difference = (coarse_blur(mask, sigma) - full)[edge:-edge, edge:-edge]
            assert np.abs(difference).max() < 0.015
