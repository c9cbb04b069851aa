"""Tangle CNN building blocks: split, balance, augmentation, metrics, normalisation, target
mask, crops."""

from itertools import product
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import DEFAULT_CROP, CropSpec, candidate_crops, extract_crop
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.tangle_cnn.augment import augment_batch, dihedral
from tangle_drake.tangle_cnn.metrics import binary_metrics, roc_auc
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet, parameter_count
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION, Normalisation
from tangle_drake.tangle_cnn.split import balanced_rows, loss_weights, split_by_pile, undersample
from tangle_drake.tangle_cnn.target_mask import TargetMask


def test_split_keeps_every_pile_on_one_side_and_is_seeded():
    rng = np.random.default_rng(0)
    piles = np.repeat(rng.integers(0, 10**9, 60), rng.integers(1, 12, 60))
    train, validation = split_by_pile(piles, 0.1, seed=3)
    assert not set(piles[train]) & set(piles[validation])
    assert sorted(np.concatenate([train, validation])) == list(range(len(piles)))
    assert 0.1 <= len(validation) / len(piles) < 0.3
    again = split_by_pile(piles, 0.1, seed=3)
    assert np.array_equal(again[0], train) and np.array_equal(again[1], validation)
    assert not np.array_equal(split_by_pile(piles, 0.1, seed=4)[1], validation)


def test_split_gives_each_side_a_pile_and_needs_two():
    train, validation = split_by_pile(np.array([5, 5, 5, 7]), 0.9, seed=0)
    assert len(train) and len(validation)
    with pytest.raises(ValueError):
        split_by_pile(np.array([1, 1, 1]), 0.1, seed=0)


def test_undersample_balances_the_classes_within_the_given_indices():
    labels = np.array([1, 0, 0, 0, 0, 1, 0, 0, 1, 0])
    kept = undersample(np.arange(1, 10), labels, seed=0)
    assert np.bincount(labels[kept]).tolist() == [2, 2]
    assert set(kept) <= set(range(1, 10)) and list(kept) == sorted(kept)


def test_weight_balance_keeps_every_sample_and_weighs_each_class_as_much():
    labels = np.array([2, 0, 0, 0, 0, 1, 0, 0, 1, 0])
    kept = balanced_rows(np.array([9, 0, 1, 2, 3, 4, 5, 6, 7, 8]), labels, 0, 3, "weight")
    assert kept.tolist() == list(range(10))
    weights = loss_weights(labels[kept], 3)  # each class weighs a third of the ten samples
    assert np.allclose([weights[k] * (labels[kept] == k).sum() for k in range(3)], 10 / 3)
    undersampled = balanced_rows(np.arange(10), labels, 0, 3, "undersample")
    assert np.bincount(labels[undersampled]).tolist() == [1, 1, 1]  # as many as the rarest


def test_each_objective_trains_with_its_balance_unless_told():
    from tangle_drake.tangle_cnn.train_settings import TrainSettings

    assert TrainSettings().balance == "undersample"  # the paper's tangle CNN
    assert TrainSettings(objective="outcome").balance == "weight"
    assert TrainSettings(objective="success", balance="undersample").balance == "undersample"
    with pytest.raises(TangleDrakeError, match="unknown balance 'even'"):
        TrainSettings(balance="even")


def test_augmentation_makes_the_eight_symmetries_of_the_square():
    crop = torch.arange(16.0).reshape(4, 4)
    images = [dihedral(crop, t) for t in range(8)]
    expected = [np.rot90(np.fliplr(crop.numpy()) if t >= 4 else crop.numpy(), t % 4)
                for t in range(8)]
    assert all(np.array_equal(a.numpy(), b) for a, b in zip(images, expected, strict=True))
    assert len({tuple(image.flatten().tolist()) for image in images}) == 8
    batch = crop.expand(8, 4, 4)
    transforms = np.array([3, 0, 7, 1, 6, 2, 5, 4])
    out = augment_batch(batch, transforms)
    assert all(torch.equal(out[i], dihedral(crop, int(t))) for i, t in enumerate(transforms))


def test_roc_auc_counts_pairs_with_ties_as_half():
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 2, 200)
    scores = rng.integers(0, 6, 200) / 5  # many ties
    pos, neg = scores[labels == 1], scores[labels == 0]
    pairs = (pos[:, None] > neg[None, :]).sum() + 0.5 * (pos[:, None] == neg[None, :]).sum()
    assert roc_auc(labels, scores) == pytest.approx(pairs / (len(pos) * len(neg)))
    assert roc_auc([0, 0, 1, 1], [0.1, 0.2, 0.3, 0.4]) == 1.0
    assert roc_auc([1, 1, 0, 0], [0.1, 0.2, 0.3, 0.4]) == 0.0
    assert roc_auc([1, 1], [0.2, 0.3]) is None


def test_binary_metrics_of_tangled():
    metrics = binary_metrics(np.array([1, 1, 0, 0, 1]), np.array([0.9, 0.2, 0.6, 0.1, 0.8]))
    assert metrics["accuracy"] == pytest.approx(3 / 5)
    assert metrics["precision"] == pytest.approx(2 / 3)
    assert metrics["recall"] == pytest.approx(2 / 3)
    assert binary_metrics(np.array([0, 0]), np.array([0.1, 0.2]))["precision"] is None


def test_normalisation_is_height_above_the_fingertips_whatever_the_camera_height():
    rng = np.random.default_rng(2)
    crops = rng.uniform(0.70, 0.85, (3, 8, 8)).astype(np.float32)
    depths = np.array([0.78, 0.80, 0.82], dtype=np.float32)
    near = DEFAULT_NORMALISATION.apply(crops, depths)
    far = DEFAULT_NORMALISATION.apply(crops + np.float32(0.5), depths + np.float32(0.5))
    assert np.allclose(near, far, atol=1e-5)
    lo = -DEFAULT_NORMALISATION.below_m / DEFAULT_NORMALISATION.scale_m
    hi = DEFAULT_NORMALISATION.above_m / DEFAULT_NORMALISATION.scale_m
    assert near.min() >= lo and near.max() <= hi
    assert DEFAULT_NORMALISATION.apply(np.full((1, 2, 2), 0.77, np.float32),
                                       np.array([0.79], np.float32)) == pytest.approx(0.5, abs=1e-5)
    assert torch.allclose(DEFAULT_NORMALISATION.apply(torch.from_numpy(crops),
                                                      torch.from_numpy(depths)),
                          torch.from_numpy(near))


def wire(size: int, axis: int, at: int, top: float, radius_px: float = 3.0) -> np.ndarray:
    """Heights (m, 1 mm pixels) of a round wire along ``axis`` at row/column ``at``; -inf off it."""
    d = np.abs(np.arange(size) - at).astype(np.float32)
    profile = np.where(d <= radius_px, top - 0.001 * (radius_px - np.sqrt(
        np.maximum(radius_px**2 - d**2, 0))), -np.inf).astype(np.float32)
    return np.repeat(profile[:, None], size, 1) if axis == 0 else \
        np.repeat(profile[None, :], size, 0)


def test_target_mask_follows_the_part_under_the_fingers_and_stops_at_its_neighbours():
    floor = np.full((48, 48), -0.02, np.float32)
    target = wire(48, 0, 24, 0.0)  # along the closing direction, through the centre
    below = wire(48, 1, 8, -0.014)  # lies on the floor, under the target
    over = wire(48, 1, 44, 0.006)  # lies across the target, outside the closing region
    heights = np.maximum.reduce([floor, target, below, over])
    mask = TargetMask((5, 20)).apply(heights[None])[0]
    assert mask.dtype == np.float32 and set(np.unique(mask)) == {0.0, 1.0}
    assert mask[24, :41].all()  # the target's top, over the part below, up to the one above
    assert not mask[:, 41:].any()  # the part over it
    assert not mask[:19, 8].any() and not mask[30:, 8].any()  # the part below it
    assert not mask[:20].any() and not mask[29:].any()  # the floor
    assert np.flatnonzero(mask.any(axis=1)).tolist() == [22, 23, 24, 25, 26]  # its rounded top
    empty = TargetMask((5, 20)).apply(floor[None])[0]  # a closing region over bare floor
    assert empty.sum() == 1  # the seed alone: the fill never spreads over the floor


def test_target_mask_fits_the_hand_and_feeds_a_second_channel():
    assert TargetMask.for_hand(DEFAULT_CROP, DEFAULT_GRIPPER).box_px == (11, 43)
    normalisation = Normalisation(target_mask=TargetMask((5, 20)))
    assert normalisation.channels == 2 and DEFAULT_NORMALISATION.channels == 1
    depths = np.array([0.79, 0.81], np.float32)
    target = np.maximum(wire(48, 0, 24, 0.0), -0.02)
    crops = depths[:, None, None] - np.stack([target, np.roll(target, 2, axis=0)])
    x = normalisation.inputs(crops, depths)
    assert x.shape == (2, 2, 48, 48) and x.dtype == np.float32
    assert np.allclose(x[:, 0], DEFAULT_NORMALISATION.apply(crops, depths))
    assert np.array_equal(x[:, 1], normalisation.masks(crops, depths))
    assert x[0, 1, 24].all() and x[1, 1, 26].all() and not x[0, 1, 28].any()
    assert np.array_equal(DEFAULT_NORMALISATION.inputs(crops, depths)[:, 0], x[:, 0])
    assert Normalisation.from_dict(normalisation.to_dict()) == normalisation
    older = {"below_m": 0.02, "above_m": 0.06, "scale_m": 0.04}  # checkpoints before the mask
    assert Normalisation.from_dict(older) == DEFAULT_NORMALISATION
    with pytest.raises(ValueError, match="positive"):
        TargetMask((0, 20))


def test_network_shapes_and_size():
    network = TangleNet()
    assert network(torch.zeros(5, 1, 96, 96)).shape == (5, 2)
    assert parameter_count(network) * 4 < 2e6  # float32 bytes: well under the few-MB budget
    assert TangleNet(NetworkConfig(input_size=32))(torch.zeros(2, 1, 32, 32)).shape == (2, 2)
    with pytest.raises(ValueError, match="too small"):
        NetworkConfig(input_size=16)
    config = NetworkConfig(input_size=64, channels=(8, 8, 8, 8, 8), hidden=(16, 8))
    assert NetworkConfig.from_dict(config.to_dict()) == config
    two = NetworkConfig(input_size=32, input_channels=2)
    assert TangleNet(two)(torch.zeros(2, 2, 32, 32)).shape == (2, 2)
    older = {key: value for key, value in two.to_dict().items() if key != "input_channels"}
    assert NetworkConfig.from_dict(older).input_channels == 1


def test_candidate_crops_match_extract_crop_on_the_whole_image():
    rng = np.random.default_rng(3)
    intrinsics = CameraIntrinsics.from_fov_y(160, 120, 45)
    depth = (0.8 - 0.05 * rng.random((120, 160))).astype(np.float32)
    for value, fraction in ((np.nan, 0.05), (0.0, 0.02), (np.inf, 0.01)):
        depth[rng.random(depth.shape) < fraction] = value
    candidates = [SimpleNamespace(u=u, v=v, angle_deg=a, depth_m=d) for u, v, a, d in
                  product((-5.0, 3.3, 80.0, 158.9), (1.0, 60.5, 130.0), (0.0, 33.0), (0.6, 0.79))]
    for spec in (DEFAULT_CROP, CropSpec(0.05, 32)):
        crops = candidate_crops(depth, intrinsics, candidates, spec)
        expected = np.stack([extract_crop(depth, intrinsics, c.u, c.v, c.angle_deg, c.depth_m,
                                          spec) for c in candidates])
        assert np.abs(crops - expected).max() < 2e-5  # metres: float rounding only
    empty = np.full((120, 160), np.nan, np.float32)
    assert np.allclose(candidate_crops(empty, intrinsics, candidates[:1], DEFAULT_CROP),
                       extract_crop(empty, intrinsics, -5.0, 1.0, 0.0, 0.6))


def test_candidate_crops_reject_a_mismatched_image_and_bad_candidates():
    intrinsics = CameraIntrinsics.from_fov_y(160, 120, 45)
    good = SimpleNamespace(u=5.0, v=5.0, angle_deg=0.0, depth_m=0.8)
    with pytest.raises(TangleDrakeError, match="intrinsics"):
        candidate_crops(np.zeros((100, 160), np.float32), intrinsics, [good], DEFAULT_CROP)
    bad = SimpleNamespace(u=np.nan, v=5.0, angle_deg=0.0, depth_m=0.8)
    with pytest.raises(TangleDrakeError, match="candidate 1"):
        candidate_crops(np.ones((120, 160), np.float32), intrinsics, [good, bad], DEFAULT_CROP)
