"""Tangle CNN checkpoints: exact round trip, prediction API, and every kind of bad file."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import CropSpec, extract_crop
from tangle_drake.tangle_cnn.checkpoint import model_checkpoint, read_checkpoint, save_atomic
from tangle_drake.tangle_cnn.model import TangleModel, load_tangle_model
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION, Normalisation
from tangle_drake.tangle_cnn.target_mask import TargetMask

CONFIG = NetworkConfig(input_size=48)
CROP = CropSpec(0.06, 48)
MASKED = Normalisation(target_mask=TargetMask((9, 36)))
MASKED_CONFIG = NetworkConfig(input_size=48, input_channels=2)


def make_checkpoint(seed: int = 0, config: NetworkConfig = CONFIG,
                    normalisation: Normalisation = DEFAULT_NORMALISATION) -> dict:
    torch.manual_seed(seed)
    return model_checkpoint(config, CROP, normalisation, TangleNet(config).state_dict(),
                            part="u_hook", metrics={"val_loss": 0.1})


@pytest.fixture
def checkpoint_path(tmp_path: Path) -> Path:
    path = tmp_path / "model.pt"
    save_atomic(make_checkpoint(), path)
    return path


def random_crops(count: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    depths = rng.uniform(0.6, 1.0, count).astype(np.float32)
    crops = depths[:, None, None] + rng.uniform(-0.06, 0.03, (count, 48, 48))
    return crops.astype(np.float32), depths


@pytest.mark.parametrize(("config", "normalisation"), [(CONFIG, DEFAULT_NORMALISATION),
                                                       (MASKED_CONFIG, MASKED)])
def test_round_trip_reproduces_the_outputs_exactly(tmp_path, config, normalisation):
    data = make_checkpoint(config=config, normalisation=normalisation)
    checkpoint_path = tmp_path / "model.pt"
    save_atomic(data, checkpoint_path)
    network = TangleNet(config)
    network.load_state_dict(data["state_dict"])
    in_memory = TangleModel(network, CROP, normalisation)
    loaded = load_tangle_model(checkpoint_path)
    crops, depths = random_crops(7)
    p = loaded.predict(crops, depths)
    assert p.shape == (7,) and p.dtype == np.float32
    assert np.array_equal(p, in_memory.predict(crops, depths))
    assert np.array_equal(p, load_tangle_model(checkpoint_path).predict(crops, depths))
    assert ((p > 0) & (p < 1)).all()
    assert loaded.crop == CROP and loaded.normalisation == normalisation
    assert loaded.info["part"] == "u_hook" and "state_dict" not in loaded.info


def test_predict_candidates_crops_each_candidate_as_extract_crop_does(checkpoint_path):
    model = load_tangle_model(checkpoint_path)
    intrinsics = CameraIntrinsics.from_fov_y(120, 90, 45)
    rng = np.random.default_rng(1)
    depth = (0.8 - 0.04 * rng.random((90, 120))).astype(np.float32)
    candidates = [SimpleNamespace(u=30, v=40, angle_deg=10, depth_m=0.78),
                  SimpleNamespace(u=100, v=5, angle_deg=-60, depth_m=0.79)]
    crops = np.stack([extract_crop(depth, intrinsics, c.u, c.v, c.angle_deg, c.depth_m, CROP)
                      for c in candidates])
    expected = model.predict(crops, np.array([c.depth_m for c in candidates]))
    p = model.predict_candidates(depth, intrinsics, candidates)
    assert np.allclose(p, expected, atol=1e-4)
    assert model.predict_candidates(depth, intrinsics, []).shape == (0,)


def test_predict_rejects_wrong_shapes_and_missing_pixels(checkpoint_path):
    model = load_tangle_model(checkpoint_path)
    crops, depths = random_crops(3)
    with pytest.raises(TangleDrakeError, match=r"\(N, 48, 48\)"):
        model.predict(crops[:, :32, :32], depths)
    with pytest.raises(TangleDrakeError, match="grasp depths"):
        model.predict(crops, depths[:2])
    crops[0, 0, 0] = np.nan
    with pytest.raises(TangleDrakeError, match="finite"):
        model.predict(crops, depths)


def write_bytes(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


@pytest.mark.parametrize(("make_file", "message"), [
    (lambda d, good: d / "absent.pt", "not found"),
    (lambda d, good: write_bytes(d / "random.pt", np.random.default_rng(0).bytes(5000)),
     "not a readable"),
    (lambda d, good: write_bytes(d / "cut.pt", good.read_bytes()[:20000]), "not a readable"),
    (lambda d, good: write_bytes(d / "empty.pt", b""), "not a readable"),
    (lambda d, good: d, "not a file"),
])
def test_unreadable_checkpoints(tmp_path, checkpoint_path, make_file, message):
    with pytest.raises(TangleDrakeError, match=message):
        load_tangle_model(make_file(tmp_path, checkpoint_path))


def test_a_pickle_with_code_is_refused_without_running_it(tmp_path):
    path = tmp_path / "evil.pt"
    torch.save({"kind": Path("x")}, path)  # not allowed under weights_only
    with pytest.raises(TangleDrakeError, match="not a readable"):
        load_tangle_model(path)


def save(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "other.pt"
    torch.save(data, path)
    return path


def edited(**changes) -> dict:
    data = make_checkpoint()
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    return data


@pytest.mark.parametrize(("data", "message"), [
    (torch.zeros(3), "not a tangle CNN checkpoint"),
    (TangleNet(CONFIG).state_dict(), "not a tangle CNN checkpoint"),
    (edited(kind="something else"), "not a tangle CNN checkpoint"),
    (edited(version=99), "format version 99"),
    (edited(normalisation=None), "lacks normalisation"),
    (edited(state_dict=None, crop=None), "lacks crop, state_dict"),
    (edited(network={**CONFIG.to_dict(), "input_size": 96}), "do not fit"),
    (edited(network={**CONFIG.to_dict(), "channels": [8, 8, 8, 8, 8]}), "do not fit"),
    (edited(network={"input_size": 48, "layers": 3}), "invalid network configuration"),
    (edited(network={**CONFIG.to_dict(), "input_size": 8}), "invalid network configuration"),
    (edited(crop={"size_m": 0.06, "size_px": 96}), "does not fit the network"),
    (edited(crop={"size_m": 0.06}), "invalid crop spec"),
    (edited(normalisation={"below_m": -1.0}), "invalid crop spec or normalisation"),
    (edited(normalisation=MASKED.to_dict()), "makes 2 input channel"),
    (edited(normalisation={**MASKED.to_dict(), "target_mask": {"box_px": 5}}),
     "invalid crop spec or normalisation"),
])
def test_mismatched_checkpoints(tmp_path, data, message):
    with pytest.raises(TangleDrakeError, match=message):
        load_tangle_model(save(tmp_path, data))


def test_training_state_is_not_a_model(tmp_path):
    path = save(tmp_path, {"kind": "tangle_drake.tangle_cnn.train_state", "version": 1})
    with pytest.raises(TangleDrakeError, match="not a tangle CNN checkpoint"):
        load_tangle_model(path)
    with pytest.raises(TangleDrakeError, match="training state lacks"):
        read_checkpoint(path, "tangle_drake.tangle_cnn.train_state")
