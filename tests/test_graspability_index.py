"""Known answers of the graspability index on small synthetic scenes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tangle_drake.graspability import (
    GraspabilityParams,
    HandModel,
    bin_roi,
    compute_candidates,
    compute_candidates_from_height_map,
)
from tangle_drake.graspability.index import grasp_maps
from tangle_drake.graspability.inputs import check_depth
from tangle_drake.graspability.params import FINGER_GRIP_SPAN_M
from tangle_drake.graspability.synthetic import HeightField, pile_field
from tangle_drake.graspability.workmap import View, build_work_map
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec

FLOOR = 0.5
K = CameraIntrinsics.from_fov_y(320, 240, 45.0)
CAMERA = CameraModel(K, top_view_pose(np.zeros(3), FLOOR))
HAND = HandModel.from_gripper(DEFAULT_GRIPPER)
INSERTION = GraspabilityParams().insertion_depth_m


def field() -> HeightField:
    """Heights over the camera's view of the floor, x right and y down in the image."""
    return HeightField((0.3, 0.24))


def in_camera(candidate) -> np.ndarray:
    """X_CT of a candidate (its pose is X_WT)."""
    return np.linalg.inv(CAMERA.X_WC) @ candidate.pose


def hand_points(candidate, region: str, shrink: float = 0.0) -> np.ndarray:
    """Camera-frame (x, y) samples of the candidate's finger footprints or closing region,
    each rectangle shrunk by ``shrink`` metres on every side."""
    X_CT = in_camera(candidate)
    centre, closing = X_CT[:2, 3], X_CT[:2, 1]
    across = np.array([-closing[1], closing[0]])
    half_w = HAND.finger_width_m / 2 - shrink
    if region == "fingers":
        half_len = HAND.finger_thickness_m / 2 - shrink
        middles = [s * (HAND.opening_m / 2 + HAND.finger_thickness_m / 2) for s in (-1, 1)]
    else:
        half_len, middles = HAND.opening_m / 2 - shrink, [0.0]
    steps = [max(2, math.ceil(2 * half / 0.0004) + 1) for half in (half_len, half_w)]
    a, b = np.meshgrid(np.linspace(-half_len, half_len, steps[0]),
                       np.linspace(-half_w, half_w, steps[1]))
    return np.concatenate([centre + (m + a.ravel())[:, None] * closing
                           + b.ravel()[:, None] * across for m in middles])


def heights_at(f: HeightField, points: np.ndarray) -> np.ndarray:
    cols, rows = (np.rint(c).astype(int) for c in f.to_cell(points[:, 0], points[:, 1]))
    return f.heights[rows, cols]


def bar(f: HeightField, y: float = 0.0, length: float = 0.06, diameter: float = 0.008,
        angle_deg: float = 0.0, centre: tuple[float, float] = (0.0, 0.0)) -> None:
    a = math.radians(angle_deg)
    direction = np.array([math.cos(a), math.sin(a)]) * length / 2
    middle = np.array(centre) + np.array([0.0, y])
    f.add_wire(np.array([middle - direction, middle + direction]), diameter)


def test_single_bar_is_grasped_at_its_centre_closing_across_it():
    f = field()
    bar(f, y=0.01)
    candidates = compute_candidates(f.render(K, FLOOR), CAMERA)
    best = candidates[0]
    X_CT = in_camera(best)
    assert X_CT[:2, 3] == pytest.approx([0.0, 0.01], abs=0.0025)
    assert best.angle_deg == 90.0  # the bar runs along +u: close along +v
    assert X_CT[:3, 1] == pytest.approx([0.0, 1.0, 0.0], abs=1e-9)  # y_T: closing direction
    assert X_CT[:3, 2] == pytest.approx([0.0, 0.0, 1.0], abs=1e-9)  # z_T: camera +z
    # Fingertips the insertion depth below the bar's top; T half a pad above them.
    assert FLOOR - best.depth_m == pytest.approx(0.008 - INSERTION, abs=6e-4)
    assert X_CT[2, 3] == pytest.approx(best.depth_m - DEFAULT_GRIPPER.pad_length / 2)
    u, v, _ = CAMERA.world_to_pixel(best.pose[:3, 3])
    assert (best.u, best.v) == pytest.approx((u, v))
    assert best.width_m == DEFAULT_GRIPPER.max_opening
    assert 0 < best.score <= 1 and all(0 < c.score <= 1 for c in candidates)
    assert [c.score for c in candidates] == sorted((c.score for c in candidates), reverse=True)


def _fingers_in_gap(candidates, gap: float) -> bool:
    for c in candidates:
        x, y = hand_points(c, "fingers").T
        if np.any((np.abs(y) < gap / 2) & (np.abs(x) < 0.02)):  # not at the open ends
            return True
    return False


@pytest.mark.parametrize(("gap", "finger_fits"), [(0.005, False), (0.02, True)])
def test_no_finger_between_bars_closer_than_a_finger(gap: float, finger_fits: bool):
    f = field()
    for side in (-1, 1):
        bar(f, y=side * (gap / 2 + 0.004))
    params = GraspabilityParams(top_k=10)
    candidates = compute_candidates(f.render(K, FLOOR), CAMERA, params=params)
    assert candidates
    assert _fingers_in_gap(candidates, gap) == finger_fits


def test_part_whose_fingers_would_land_on_taller_neighbours_is_rejected():
    f = field()
    bar(f)
    alone = compute_candidates(f.render(K, FLOOR), CAMERA)
    assert FLOOR - alone[0].depth_m == pytest.approx(0.008 - INSERTION, abs=6e-4)
    for side in (-1, 1):  # 30 mm tall blocks, 5 mm from the bar: no room for a finger
        inner, outer = side * 0.009, side * 0.039
        f.add_box(-0.04, min(inner, outer), 0.04, max(inner, outer), 0.03)
    crowded = compute_candidates(f.render(K, FLOOR), CAMERA, params=GraspabilityParams(top_k=20))
    assert crowded  # the blocks themselves can be grasped ...
    for c in crowded:  # ... but never the bar between them
        assert FLOOR - c.depth_m > 0.03 - INSERTION - 0.002


@pytest.mark.parametrize("length", [0.02, 0.03])
def test_grip_test_closes_across_a_short_bar_never_along_it(length: float):
    """A bar shorter than the opening fits between the fingers lengthwise: the plain index
    closes along it too (on its rounded ends, which squirt out); with the grip test the hand
    closes along it nowhere, and across it wherever the plain index does."""
    f = field()
    bar(f, length=length)  # along +u: orientation 0 closes along it, n/2 across
    params = GraspabilityParams(max_grip_span_m=FINGER_GRIP_SPAN_M)
    work = build_work_map(check_depth(f.render(K, FLOOR), K), View.of_camera(K),
                          params.cell_size_m)
    plain = grasp_maps(work, HAND, replace(params, max_grip_span_m=None)).encoded
    tested = grasp_maps(work, HAND, params).encoded
    across = params.n_orientations // 2
    assert np.count_nonzero(plain[0]) > 20 and np.count_nonzero(tested[0]) == 0
    assert np.count_nonzero(tested[across]) > 100
    assert np.array_equal(tested[across], plain[across])
    assert np.all((tested == 0) | (tested == plain))  # it only ever removes grasps


def test_fingers_from_the_gripper_spec():
    """An 18 mm gap takes a default 8 mm finger but not a 20 mm one. The region of interest
    keeps only grasps of the upper bar with a finger in the gap (and the gap's middle free)."""
    f = field()
    gap = 0.018
    for side in (-1, 1):
        bar(f, y=side * (gap / 2 + 0.004))
    depth = f.render(K, FLOOR)
    z = FLOOR - 0.01
    u0, u1 = (round(K.cx + K.fx * x / z) for x in (-0.02, 0.02))
    v0, v1 = (round(K.cy + K.fy * y / z) for y in (-0.06, 0.0))
    upper = (u0, v0, u1, v1)
    default = compute_candidates(depth, CAMERA, roi=upper)
    assert default and _fingers_in_gap(default, gap)
    assert all(c.angle_deg == 90.0 for c in default)
    thick = GripperSpec(finger_thickness=0.02)
    assert not _fingers_in_gap(compute_candidates(depth, CAMERA, hand=thick, roi=upper), gap)
    narrow = GripperSpec(max_opening=0.03, palm_size=(0.04, 0.05, 0.03))
    assert {c.width_m for c in compute_candidates(depth, CAMERA, hand=narrow)} == {0.03}


def test_empty_bin_gives_no_candidates():
    assert compute_candidates(np.full((K.height, K.width), FLOOR, np.float32), CAMERA) == []
    f = field()
    for x0, y0, x1, y1 in ((-0.13, -0.1, 0.13, -0.09), (-0.13, 0.09, 0.13, 0.1),
                           (-0.13, -0.09, -0.12, 0.09), (0.12, -0.09, 0.13, 0.09)):
        f.add_box(x0, y0, x1, y1, 0.06)
    depth = f.render(K, FLOOR)
    assert compute_candidates(depth, CAMERA)  # the thin walls' tops look graspable ...
    floor_W = [CAMERA.pixel_to_world(u, v, FLOOR) for u, v in
               [(K.cx - 0.12 * K.fx / FLOOR, K.cy - 0.09 * K.fy / FLOOR),
                (K.cx + 0.12 * K.fx / FLOOR, K.cy + 0.09 * K.fy / FLOOR),
                (K.cx - 0.12 * K.fx / FLOOR, K.cy + 0.09 * K.fy / FLOOR),
                (K.cx + 0.12 * K.fx / FLOOR, K.cy - 0.09 * K.fy / FLOOR)]]
    assert compute_candidates(depth, CAMERA, roi=bin_roi(CAMERA, np.array(floor_W))) == []


def test_roi_and_margin_keep_the_hand_inside():
    f = field()
    bar(f, centre=(-0.1, 0.0))
    bar(f, centre=(0.1, 0.0), angle_deg=90)
    depth = f.render(K, FLOOR)
    params = GraspabilityParams(top_k=10)
    both = compute_candidates(depth, CAMERA, params=params)
    assert {c.angle_deg for c in both} >= {0.0, 90.0}
    right = compute_candidates(depth, CAMERA, params=params,
                               roi=(K.width // 2, 0, K.width, K.height))
    assert right and all(c.u >= K.width / 2 and c.angle_deg == 0.0 for c in right)
    margin = 90

    def within_margin(c) -> bool:  # the whole hand, not only its centre (give or take a cell)
        x, y = np.concatenate([hand_points(c, "fingers"), hand_points(c, "closing")]).T
        z = c.depth_m - HAND.tcp_above_tips_m
        u, v = K.cx + K.fx * x / z, K.cy + K.fy * y / z
        return (u.min() > margin - 2 and u.max() < K.width - margin + 2
                and v.min() > margin - 2 and v.max() < K.height - margin + 2)

    assert not all(within_margin(c) for c in both)
    inner = compute_candidates(depth, CAMERA, params=roi_margin(margin, params))
    assert inner and all(within_margin(c) for c in inner)


def roi_margin(pixels: int, params: GraspabilityParams) -> GraspabilityParams:
    return GraspabilityParams(top_k=params.top_k, roi_margin_px=pixels)


def test_candidates_are_valid_grasps_of_the_true_scene():
    """Every candidate, checked against the scene it was rendered from (not the index's map):
    the finger footprints hold nothing above the fingertips, the closing region holds
    something the fingers reach into. Tolerances: one 2 mm cell inwards, 1 mm in height."""
    rng = np.random.default_rng(7)
    bin_floor_W = np.array([[x, y, 0.0] for x in (-0.13, 0.13) for y in (-0.18, 0.18)])
    params = GraspabilityParams(top_k=8)
    checked = 0
    for _ in range(3):
        f = pile_field(rng, K, n_parts=15, floor_depth_m=FLOOR)
        candidates = compute_candidates(f.render(K, FLOOR), CAMERA, params=params,
                                        roi=bin_roi(CAMERA, bin_floor_W))
        for c in candidates:
            tips = FLOOR - c.depth_m
            assert heights_at(f, hand_points(c, "fingers", shrink=0.002)).max() <= tips + 0.001
            assert heights_at(f, hand_points(c, "closing")).max() >= tips + INSERTION - 0.001
            checked += 1
    assert checked >= 15


def _three_bars_height_map() -> np.ndarray:
    """A 16-bit height map (0.1 mm per level, 2 mm pixels, odd size) with three short bars
    of different lengths, so the three best grasps have clearly different scores."""
    f = HeightField((0.302, 0.242), resolution_m=0.002)
    bar(f, centre=(-0.08, -0.05), length=0.014, angle_deg=30)
    bar(f, centre=(0.07, -0.04), length=0.02, angle_deg=100)
    bar(f, centre=(0.0, 0.06), length=0.026, angle_deg=160)
    return np.rint(f.heights / 1e-4).astype(np.uint16)


@pytest.mark.parametrize("transform", ["rot90", "fliplr", "flipud"])
def test_turned_or_flipped_image_gives_turned_or_flipped_candidates(transform: str):
    image = _three_bars_height_map()
    h, w = image.shape
    assert h % 2 == 1 and w % 2 == 1
    params = GraspabilityParams(top_k=3, cell_size_m=0.002)  # one cell per pixel
    original = compute_candidates_from_height_map(image, 1e-4, 0.002, params=params)
    moved = compute_candidates_from_height_map(
        np.ascontiguousarray(getattr(np, transform)(image)), 1e-4, 0.002, params=params)
    expected = {
        "rot90": lambda c: (c.v, w - 1 - c.u, c.angle_deg - 90),
        "fliplr": lambda c: (w - 1 - c.u, c.v, 180 - c.angle_deg),
        "flipud": lambda c: (c.u, h - 1 - c.v, 180 - c.angle_deg),
    }[transform]
    assert len(original) == len(moved) == 3
    assert len({round(c.score, 3) for c in original}) == 3
    for before, after in zip(original, moved, strict=True):
        u, v, angle = expected(before)
        assert (after.u, after.v) == pytest.approx((u, v), abs=1.01)
        assert after.angle_deg == pytest.approx(angle % 180)
        assert after.score == pytest.approx(before.score, abs=1e-4)
        assert after.depth_m == pytest.approx(before.depth_m)


def test_turned_depth_image_with_turned_camera():
    f = field()
    bar(f, centre=(0.04, 0.02), angle_deg=20)
    bar(f, centre=(-0.05, -0.03), length=0.03, angle_deg=75)
    depth = f.render(K, FLOOR)
    turned_k = CameraIntrinsics(K.height, K.width, K.fy, K.fx, K.cy, K.cx)
    best = compute_candidates(depth, K)[0]
    turned = compute_candidates(np.ascontiguousarray(np.rot90(depth)), turned_k)[0]
    assert best.pose is None and turned.pose is None  # bare intrinsics: no pose
    assert (turned.u, turned.v) == pytest.approx((best.v, K.width - 1 - best.u), abs=1.5)
    assert turned.angle_deg == pytest.approx((best.angle_deg - 90) % 180)
    assert turned.score == pytest.approx(best.score, abs=0.02)


def test_holes_and_speckle_are_ignored():
    f = field()
    bar(f, y=0.01)
    clean = compute_candidates(f.render(K, FLOOR), CAMERA)[0]
    rng = np.random.default_rng(3)
    noisy = f.render(K, FLOOR)
    flat = noisy.reshape(-1)
    holes = rng.choice(flat.size, flat.size // 20, replace=False)
    flat[holes[: len(holes) // 3]] = np.nan
    flat[holes[len(holes) // 3: 2 * len(holes) // 3]] = 0.0
    flat[holes[2 * len(holes) // 3:]] = np.inf
    speckle = rng.choice(flat.size // 9, 40, replace=False) * 9  # isolated pixels
    flat[speckle[:30]] = rng.uniform(0.3, 0.49, 30)
    flat[speckle[30:]] = 5.0  # stray far readings must not coarsen the map
    best = compute_candidates(noisy, CAMERA)[0]
    assert (best.u, best.v) == pytest.approx((clean.u, clean.v), abs=2.0)
    assert best.angle_deg == clean.angle_deg
    assert best.depth_m == pytest.approx(clean.depth_m, abs=1.1e-3)


def test_work_map_is_metric_despite_perspective():
    """A tall post off the optical axis lands at its true x, y on the work map: its edges
    facing the axis at 90 and 50 mm, where the floor's pixel scale would put them at 100 and
    56 mm (parallax). Beyond its far edges lies its occlusion shadow (up to 11/0.9 = 122 and
    7/0.9 = 78 mm), which the map fills from the nearest seen cell."""
    f = field()
    f.add_box(0.09, 0.05, 0.11, 0.07, 0.05)  # a 20 mm square post, 50 mm tall
    work = build_work_map(check_depth(f.render(K, FLOOR), K), View.of_camera(K), 0.0025)
    x, y = work.cell_xy(*np.mgrid[0: work.z.shape[0], 0: work.z.shape[1]])
    top = work.z < FLOOR - 0.045
    assert x[top].min() == pytest.approx(0.09, abs=0.0025)
    assert y[top].min() == pytest.approx(0.05, abs=0.0025)
    assert x[top].max() <= 0.11 / 0.9 + 0.0025 and y[top].max() <= 0.07 / 0.9 + 0.0025
    centre = (np.abs(x - 0.1) < 0.008) & (np.abs(y - 0.06) < 0.008)
    assert work.z[centre] == pytest.approx(FLOOR - 0.05, abs=2e-4)
