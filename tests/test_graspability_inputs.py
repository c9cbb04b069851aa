"""Bad input gives a clear TangleDrakeError; odd but valid input works."""

from __future__ import annotations

import numpy as np
import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.graspability import (
    GraspabilityParams,
    HandModel,
    bin_roi,
    compute_candidates,
    compute_candidates_from_height_map,
    roi_mask,
)
from tangle_drake.graspability.inputs import millimetre_depth_scale, sizes_disagree
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER

K = CameraIntrinsics.from_fov_y(64, 48, 45.0)
CAMERA = CameraModel(K, top_view_pose(np.zeros(3), 0.5))
FLAT = np.full((48, 64), 0.5, np.float32)


@pytest.mark.parametrize(("depth", "message"), [
    (np.zeros((48, 64), bool), "numeric"),
    (np.full((48, 64), "0.5"), "numeric"),
    (np.array([[None]], dtype=object), "numeric"),
    (np.zeros((48, 64), complex), "numeric"),
    (np.zeros((0, 0), np.float32), "empty"),
    (np.zeros((48, 64, 1), np.float32), "2-D"),
    (np.zeros(64, np.float32), "2-D"),
    (np.full((48, 64), 500, np.uint16), "floating-point metres"),
    (np.full((40, 64), 0.5, np.float32), "intrinsics"),
    (np.full((48, 64), np.nan, np.float32), "no valid pixel"),
    (np.zeros((48, 64), np.float32), "no valid pixel"),
    (np.full((48, 64), np.inf), "no valid pixel"),
    (-FLAT, "no valid pixel"),
])
def test_bad_depth_images(depth, message):
    with pytest.raises(TangleDrakeError, match=message):
        compute_candidates(depth, CAMERA)


def test_the_callers_image_is_left_alone():
    depth = FLAT.copy()
    depth[0, :5] = [np.nan, 0, np.inf, -1, 0.5]
    before = depth.copy()
    assert compute_candidates(depth, CAMERA) == []
    np.testing.assert_array_equal(depth, before)


def test_flat_float64_depth_and_a_few_valid_pixels_give_no_candidates():
    assert compute_candidates(FLAT.astype(np.float64), CAMERA) == []
    sparse = np.full((48, 64), np.nan, np.float32)
    sparse[20:23, 30:33] = 0.5
    assert compute_candidates(sparse, CAMERA) == []


@pytest.mark.parametrize(("image", "scales", "message"), [
    (np.zeros((48, 64), np.float32), (1e-4, 1e-3), "8- or 16-bit"),
    (np.zeros((48, 64), np.int32), (1e-4, 1e-3), "8- or 16-bit"),
    (np.zeros((48, 64), bool), (1e-4, 1e-3), "numeric"),
    (np.zeros((48, 64, 2), np.uint8), (1e-4, 1e-3), "grey"),
    (np.zeros((0, 64), np.uint8), (1e-4, 1e-3), "empty"),
    (np.zeros((48, 64), np.uint8), (0.0, 1e-3), "height per grey level"),
    (np.zeros((48, 64), np.uint8), (1e-4, -1e-3), "pixel size"),
    (np.zeros((48, 64), np.uint8), (1e-4, float("nan")), "pixel size"),
])
def test_bad_height_maps(image, scales, message):
    with pytest.raises(TangleDrakeError, match=message):
        compute_candidates_from_height_map(image, *scales)


def test_height_maps_grey_and_colour_agree():
    grey = np.zeros((101, 121), np.uint8)
    grey[45:55, 20:100] = 80  # an 8 mm tall, 10 mm wide bar at 0.1 mm per level, 1 mm pixels
    found = compute_candidates_from_height_map(grey, 1e-4, 1e-3)
    assert found and found[0].pose is None
    assert found[0].angle_deg == 90.0
    assert found[0].height_m == pytest.approx(0.008 - GraspabilityParams().insertion_depth_m)
    colour = compute_candidates_from_height_map(np.dstack([grey] * 3), 1e-4, 1e-3)
    assert [c.to_dict() for c in colour] == [c.to_dict() for c in found]
    wide = compute_candidates_from_height_map(grey.astype(np.uint16) * 257, 1e-4 / 257, 1e-3)
    assert [(c.u, c.v, c.angle_deg) for c in wide] == [(c.u, c.v, c.angle_deg) for c in found]


def test_bad_regions_of_interest():
    with pytest.raises(TangleDrakeError, match="ROI mask"):
        compute_candidates(FLAT, CAMERA, roi=np.ones((10, 10), bool))
    with pytest.raises(TangleDrakeError, match="four integers"):
        compute_candidates(FLAT, CAMERA, roi=(0, 0, 10))
    with pytest.raises(TangleDrakeError, match="holds no pixel"):
        compute_candidates(FLAT, CAMERA, roi=(10, 10, 10, 20))
    with pytest.raises(TangleDrakeError, match="holds no pixel"):
        compute_candidates(FLAT, CAMERA, params=GraspabilityParams(roi_margin_px=30))
    with pytest.raises(TangleDrakeError, match="bin corners"):
        bin_roi(CAMERA, np.zeros((2, 3)))


def test_roi_margin_and_bin_roi():
    mask = roi_mask((10, 5, 30, 25), 64, 48, margin_px=2)
    assert mask.sum() == (30 - 10 - 4) * (25 - 5 - 4)
    assert mask[7, 12] and not mask[6, 12] and not mask[7, 11]
    edge = roi_mask(None, 64, 48, margin_px=3)
    assert edge.sum() == (64 - 6) * (48 - 6)
    assert roi_mask(None, 64, 48, margin_px=0) is None
    corners_W = CAMERA.pixel_to_world(np.array([10.0, 50, 50, 10]), np.array([5.0, 5, 40, 40]),
                                      0.5)
    inside = bin_roi(CAMERA, corners_W)
    assert inside[20, 30] and not inside[2, 30] and not inside[20, 60]


def test_bad_parameters():
    with pytest.raises(ValueError):
        GraspabilityParams(n_orientations=0)
    with pytest.raises(ValueError):
        GraspabilityParams(peak_tolerance=1.0)
    with pytest.raises(ValueError, match="max_grip_span_m"):
        GraspabilityParams(max_grip_span_m=float("nan"))
    with pytest.raises(ValueError):
        HandModel(0.045, 0.008, 0.012, 0.0, 0.01)
    deep = GraspabilityParams(insertion_depth_m=DEFAULT_GRIPPER.finger_length)
    with pytest.raises(ValueError, match="finger length"):
        compute_candidates(FLAT, CAMERA, params=deep)


def test_millimetre_depth_scale_only_where_the_image_can_be_the_cameras_depth():
    millimetres = np.full((48, 64), 500, np.uint16)
    millimetres[:10] = 0  # missing pixels do not count
    millimetres[20:30, 20:40] = 450  # a part above the floor: the floor is the far end
    depth_m, size = millimetre_depth_scale(millimetres, K)
    assert depth_m == pytest.approx(0.5)
    assert size == pytest.approx(0.5 / K.fx)
    assert sizes_disagree(0.0005, size) and not sizes_disagree(size * 1.1, size)
    assert millimetre_depth_scale(millimetres[:40], K) is None  # not the camera's size
    assert millimetre_depth_scale((millimetres // 2).astype(np.uint8), K) is None  # 8-bit
    assert millimetre_depth_scale(np.zeros_like(millimetres), K) is None  # nothing seen
    assert millimetre_depth_scale(millimetres * 60, K) is None  # 30 m: no bin is that far
    assert millimetre_depth_scale(millimetres, CameraIntrinsics(64, 48, 0, 0, 32, 24)) is None
