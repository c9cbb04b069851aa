"""ONNX export: ONNX Runtime and torch agree on random crops (needs the onnx extra)."""

import argparse
import json

import numpy as np
import pytest
import torch

from tangle_drake.commands import export_onnx as export_command
from tangle_drake.crops import CropSpec
from tangle_drake.errors import TangleDrakeError
from tangle_drake.tangle_cnn.checkpoint import model_checkpoint, save_atomic
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION

onnx = pytest.importorskip("onnx")
onnxruntime = pytest.importorskip("onnxruntime")
pytest.importorskip("onnxscript")


def run_export(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    export_command.register(parser.add_subparsers())
    args = parser.parse_args(["export-onnx", *argv])
    return args.func(args)


def test_onnx_runtime_agrees_with_torch(tmp_path, capsys):
    torch.manual_seed(3)
    config = NetworkConfig(input_size=64)
    model_path = tmp_path / "model.pt"
    save_atomic(model_checkpoint(config, CropSpec(0.08, 64), DEFAULT_NORMALISATION,
                                 TangleNet(config).state_dict(), part="u_hook"), model_path)
    out = tmp_path / "export" / "model.onnx"
    assert run_export("--model", str(model_path), "--out", str(out)) == 0
    assert "largest difference from torch" in capsys.readouterr().out
    assert [p.name for p in out.parent.iterdir()] == ["model.onnx"]  # weights inside

    model = load_tangle_model(model_path)
    session = onnxruntime.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    for count in (1, 5, 33):  # the batch dimension is dynamic
        depths = rng.uniform(0.4, 1.6, count).astype(np.float32)
        crops = (depths[:, None, None] + rng.uniform(-0.1, 0.05, (count, 64, 64))) \
            .astype(np.float32)
        (p_onnx,) = session.run(["p_not_tangled"], {"crops": crops, "grasp_depths": depths})
        assert p_onnx.shape == (count,)
        assert np.abs(p_onnx - model.predict(crops, depths)).max() < 1e-5

    metadata = {prop.key: prop.value for prop in onnx.load(str(out)).metadata_props}
    assert json.loads(metadata["tangle_drake.crop"]) == {"size_m": 0.08, "size_px": 64}
    assert json.loads(metadata["tangle_drake.normalisation"])["scale_m"] == 0.04
    assert json.loads(metadata["tangle_drake.part"]) == "u_hook"


def test_export_of_a_bad_checkpoint_is_a_clear_error(tmp_path):
    with pytest.raises(TangleDrakeError, match="not found"):
        run_export("--model", str(tmp_path / "missing.pt"), "--out", str(tmp_path / "x.onnx"))
