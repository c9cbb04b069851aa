"""ONNX export: ONNX Runtime and torch agree on random crops (needs the onnx extra)."""

import json
import logging
from functools import partial

import numpy as np
import pytest
import torch
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.crops import CropSpec
from tangle_drake.tangle_cnn.checkpoint import model_checkpoint, save_atomic
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION, Normalisation
from tangle_drake.tangle_cnn.target_mask import TargetMask

onnx = pytest.importorskip("onnx")
onnxruntime = pytest.importorskip("onnxruntime")
pytest.importorskip("onnxscript")


run_export = partial(run_command, "export-onnx")


def wire_crops(depths: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Crops of a few random 6 mm bars at random heights: target masks of many pixels."""
    crops = np.repeat(depths[:, None, None] + 0.02, 64, 1).repeat(64, 2).astype(np.float32)
    rows, cols = np.mgrid[:64, :64]
    for crop, depth in zip(crops, depths, strict=True):
        for _ in range(4):
            angle, offset = rng.uniform(0, np.pi), rng.uniform(-20, 20)
            distance = np.abs(np.cos(angle) * (rows - 32) - np.sin(angle) * (cols - 32) - offset)
            top = depth - rng.uniform(0.0, 0.015)
            rounded = 0.001 * (3 - np.sqrt(np.maximum(9 - distance**2, 0)))
            bar = np.where(distance < 3, top + rounded, np.inf)
            np.minimum(crop, bar.astype(np.float32), out=crop)
    return crops


class _Heard(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


PICK_DATA = {"class_counts": {"one part": 700, "several parts": 120, "no part": 180}}
"""A pick-outcome model's training data, far from balanced: its probabilities are corrected."""


@pytest.mark.parametrize(("normalisation", "objective"), [
    (DEFAULT_NORMALISATION, "tangled"),
    (Normalisation(target_mask=TargetMask((10, 36))), "tangled"),
    (DEFAULT_NORMALISATION, "outcome")])
def test_onnx_runtime_agrees_with_torch(tmp_path, capsys, normalisation, objective):
    torch.manual_seed(3)
    config = NetworkConfig(input_size=64, input_channels=normalisation.channels,
                           classes=3 if objective == "outcome" else 2)
    model_path = tmp_path / "model.pt"
    save_atomic(model_checkpoint(config, CropSpec(0.08, 64), normalisation,
                                 TangleNet(config).state_dict(), part="u_hook",
                                 objective=objective,
                                 data=PICK_DATA if objective == "outcome" else None), model_path)
    out = tmp_path / "export" / "model.onnx"
    exporter_log, heard = logging.getLogger("torch.onnx"), _Heard()
    exporter_log.addHandler(heard)  # torch's own handler writes to the stderr of its import
    try:
        assert run_export("--model", str(model_path), "--out", str(out)) == 0
    finally:
        exporter_log.removeHandler(heard)
    assert not heard.messages  # "torchvision is not installed ...": not the user's business
    assert "largest difference from torch" in capsys.readouterr().out
    assert [p.name for p in out.parent.iterdir()] == ["model.onnx"]  # weights inside

    model = load_tangle_model(model_path)
    assert (model.class_weights is not None) == (objective == "outcome")
    session = onnxruntime.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    for count in (1, 5, 33):  # the batch dimension is dynamic
        depths = rng.uniform(0.4, 1.6, count).astype(np.float32)
        crops = wire_crops(depths, rng)
        feed = {"crops": crops, "grasp_depths": depths}
        if normalisation.target_mask is not None:
            feed["target_masks"] = normalisation.masks(crops, depths)
            assert feed["target_masks"].sum(axis=(1, 2)).min() > 50  # not the seed alone
        assert [i.name for i in session.get_inputs()] == list(feed)
        output = "p_one_part" if objective == "outcome" else "p_not_tangled"
        assert [o.name for o in session.get_outputs()] == [output]
        (p_onnx,) = session.run([output], feed)
        assert p_onnx.shape == (count,)
        assert np.abs(p_onnx - model.predict(crops, depths)).max() < 1e-5

    metadata = {prop.key: prop.value for prop in onnx.load(str(out)).metadata_props}
    assert json.loads(metadata["tangle_drake.crop"]) == {"size_m": 0.08, "size_px": 64}
    assert json.loads(metadata["tangle_drake.normalisation"]) == normalisation.to_dict()
    assert json.loads(metadata["tangle_drake.part"]) == "u_hook"


def test_export_of_a_bad_checkpoint_is_a_clear_error(tmp_path):
    with pytest.raises(TangleDrakeError, match="not found"):
        run_export("--model", str(tmp_path / "missing.pt"), "--out", str(tmp_path / "x.onnx"))
