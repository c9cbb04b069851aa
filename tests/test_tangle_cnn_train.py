"""Training the tangle CNN: it learns a separable task, the CLI writes what it promises, an
interrupted run resumes to the same weights, and bad datasets are named clearly."""

import json
from dataclasses import asdict
from functools import partial
from pathlib import Path

import numpy as np
import pytest
import torch
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import write_manifest, write_shard
from tangle_drake.perception.crops import CropSpec
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.tangle_cnn import train as train_module
from tangle_drake.tangle_cnn.checkpoint import read_checkpoint
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION, Normalisation
from tangle_drake.tangle_cnn.synthetic import (
    GRASP_DEPTH_M,
    synthetic_crop,
    synthetic_samples,
    write_synthetic_dataset,
)
from tangle_drake.tangle_cnn.target_mask import TargetMask
from tangle_drake.tangle_cnn.train import TrainSettings, log_path, state_path, train
from tangle_drake.tangle_cnn.training_data import load_training_data

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("bars")
    write_synthetic_dataset(directory, 160, size_px=32, size_m=0.05, seed=1)
    return directory


run_train = partial(run_command, "train")


def test_the_network_learns_crossing_bars(dataset, tmp_path):
    out = tmp_path / "bars.pt"
    metrics = train(dataset, out, TrainSettings(epochs=3, seed=2), device="cpu",
                    log=lambda line: None)
    assert metrics["val_accuracy"] > 0.9
    model = load_tangle_model(out)
    rng = np.random.default_rng(99)
    labels = np.arange(100) % 2
    crops = np.stack([synthetic_crop(bool(label), 32, rng) for label in labels])
    p_model = model.predict(crops, np.full(100, GRASP_DEPTH_M))
    assert ((p_model < 0.5) == labels).mean() > 0.9


def test_train_cli_writes_checkpoint_and_log_and_resumes_after_an_interrupt(
        dataset, tmp_path, monkeypatch, capsys):
    out = tmp_path / "models" / "bars.pt"
    args = ["--data", str(dataset), "--out", str(out), "--epochs", "2", "--batch-size", "48",
            "--seed", "5", "--device", "cpu"]
    real_augment = train_module.augment_batch
    calls = {"n": 0}

    def interrupt_in_epoch_two(x, transforms):
        calls["n"] += 1
        if calls["n"] == 30:  # epoch 1 has ceil(144 * 8 / 48) = 24 batches
            raise KeyboardInterrupt
        return real_augment(x, transforms)

    monkeypatch.setattr(train_module, "augment_batch", interrupt_in_epoch_two)
    assert run_train(*args) == 130
    assert "run the same command again" in capsys.readouterr().err
    state = read_checkpoint(state_path(out), "tangle_drake.tangle_cnn.train_state")
    assert state["epoch"] == 1 and len(json.loads(log_path(out).read_text())) == 1

    checkpoint = read_checkpoint(out)
    assert checkpoint["part"] == "synthetic_bars"
    assert checkpoint["crop"] == {"size_m": 0.05, "size_px": 32}
    assert checkpoint["network"]["input_size"] == 32
    assert checkpoint["normalisation"] == {
        "below_m": 0.02, "above_m": 0.06, "scale_m": 0.04,
        "target_mask": TargetMask.for_hand(CropSpec(0.05, 32), DEFAULT_GRIPPER).to_dict()}
    assert checkpoint["network"]["input_channels"] == 2
    assert checkpoint["gripper"]["max_opening"] > 0
    assert checkpoint["training"]["seed"] == 5 and checkpoint["training"]["augment"] == "d4"
    data = checkpoint["data"]
    assert data["samples"] == 160 and data["tangled"] == 80 and data["piles"] == 20
    assert data["train_samples"] + data["validation_samples"] <= 160
    assert data["manifest"]["part"] == "synthetic_bars" and len(data["fingerprint"]) == 64
    assert checkpoint["metrics"]["epoch"] == 1 and checkpoint["metrics"]["stop_reason"] is None

    monkeypatch.setattr(train_module, "augment_batch", real_augment)
    assert run_train(*args) == 0
    assert "resuming" in capsys.readouterr().out
    log = json.loads(log_path(out).read_text())
    assert [record["epoch"] for record in log] == [1, 2]
    for key in ("train_loss", "train_accuracy", "val_loss", "val_accuracy", "val_precision",
                "val_recall", "val_auc"):
        assert all(key in record for record in log)
    resumed = read_checkpoint(out)
    assert resumed["metrics"]["epochs_run"] == 2
    assert resumed["metrics"]["stop_reason"] == "max epochs"

    straight = tmp_path / "straight.pt"
    assert run_train(*args[:2], "--out", str(straight), *args[4:]) == 0
    final_state = read_checkpoint(state_path(out), "tangle_drake.tangle_cnn.train_state")
    straight_state = read_checkpoint(state_path(straight), "tangle_drake.tangle_cnn.train_state")
    for name, tensor in straight_state["weights"].items():
        assert torch.equal(tensor, final_state["weights"][name]), name
    assert [r["val_loss"] for r in log] == \
        [r["val_loss"] for r in json.loads(log_path(straight).read_text())]

    with pytest.raises(TangleDrakeError, match=r"training\.lr.*--restart"):
        run_train(*args, "--lr", "0.01")
    with pytest.raises(TangleDrakeError, match=r"training\.target_mask.*--restart"):
        run_train(*args, "--no-target-mask")


def test_the_target_mask_setting_alone_decides_the_input_channels(dataset):
    masked = Normalisation(target_mask=TargetMask((3, 10)))
    plain = load_training_data(dataset, masked, 0.1, 0, target_mask=False)
    assert plain.normalisation.target_mask is None and plain.inputs.shape[1] == 1
    fitted = load_training_data(dataset, DEFAULT_NORMALISATION, 0.1, 0, target_mask=True)
    assert fitted.normalisation.target_mask == \
        TargetMask.for_hand(CropSpec(0.05, 32), DEFAULT_GRIPPER)
    assert fitted.inputs.shape[1] == 2
    assert torch.equal(fitted.inputs[:, 0], plain.inputs[:, 0])


def test_no_target_mask_trains_on_the_depth_crop_alone(dataset, tmp_path):
    out = tmp_path / "plain.pt"
    assert run_train("--data", str(dataset), "--out", str(out), "--epochs", "1",
                     "--augment", "none", "--device", "cpu", "--no-target-mask") == 0
    model = load_tangle_model(out)
    assert model.normalisation.target_mask is None
    assert model.network.config.input_channels == 1
    assert model.info["training"]["target_mask"] is False


def test_early_stopping_and_nothing_left_to_do(dataset, tmp_path):
    out = tmp_path / "early.pt"
    lines: list[str] = []
    state = {"epoch": 3, "best_epoch": 1}
    assert train_module._stop_reason(state, TrainSettings(epochs=9, patience=2)) == \
        "early stopping"
    assert train_module._stop_reason(state, TrainSettings(epochs=3, patience=9)) == "max epochs"
    assert train_module._stop_reason(state, TrainSettings(epochs=9, patience=3)) is None
    train(dataset, out, TrainSettings(epochs=1, augment="none"), device="cpu", log=lines.append)
    assert any("validation split holds only" in line for line in lines)  # 16 samples
    lines.clear()
    train(dataset, out, TrainSettings(epochs=1, augment="none"), device="cpu", log=lines.append)
    assert lines[-1].startswith("max epochs after epoch 1")

    state_path(out).write_bytes(state_path(out).read_bytes()[:100])  # a truncated state
    with pytest.raises(TangleDrakeError, match=r"not a readable .*training state.*--restart"):
        train(dataset, out, TrainSettings(epochs=1, augment="none"), device="cpu")
    train(dataset, out, TrainSettings(epochs=1, augment="none"), device="cpu", restart=True,
          log=lines.append)
    assert lines[-1].startswith("max epochs after epoch 1")


def test_bad_datasets_are_named(tmp_path):
    settings = TrainSettings(epochs=1)
    with pytest.raises(TangleDrakeError, match="not a tangle dataset"):
        train(tmp_path / "nothing", tmp_path / "m.pt", settings)
    empty = tmp_path / "empty"
    empty.mkdir()
    write_manifest(empty, {"crop": asdict(CropSpec(0.05, 32))})
    with pytest.raises(TangleDrakeError, match="no labelled samples"):
        train(empty, tmp_path / "m.pt", settings)

    def dataset_with(directory: Path, manifest: dict, **changes) -> Path:
        directory.mkdir()
        samples = {**synthetic_samples(32, 32, seed=0), **changes}
        write_shard(directory, 0, samples)
        write_manifest(directory, manifest)
        return directory

    crop = {"crop": asdict(CropSpec(0.05, 32))}
    one_class = dataset_with(tmp_path / "one", crop, label=np.ones(32))
    with pytest.raises(TangleDrakeError, match="holds no not tangled samples"):
        train(one_class, tmp_path / "m.pt", settings)
    one_pile = dataset_with(tmp_path / "pile", crop, pile_seed=np.zeros(32))
    with pytest.raises(TangleDrakeError, match="single pile"):
        train(one_pile, tmp_path / "m.pt", settings)
    no_crop = dataset_with(tmp_path / "nocrop", {"part": "u_hook"})
    with pytest.raises(TangleDrakeError, match="crop spec"):
        train(no_crop, tmp_path / "m.pt", settings)
    wrong_size = dataset_with(tmp_path / "size", {"crop": asdict(CropSpec(0.05, 96))})
    with pytest.raises(TangleDrakeError, match="96 px"):
        train(wrong_size, tmp_path / "m.pt", settings)
    with pytest.raises(TangleDrakeError, match="augmentation"):
        TrainSettings(augment="d8")
    with pytest.raises(TangleDrakeError, match="at least 1"):
        TrainSettings(epochs=0)
