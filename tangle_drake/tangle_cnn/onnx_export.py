"""Export a trained tangle CNN to ONNX, for runtimes without torch (C++, other robots' PCs).

The ONNX graph takes what ``TangleModel.predict`` takes and returns what it returns:
inputs ``crops`` (N, S, S) float32 metric crops and ``grasp_depths`` (N,) float32 fingertip
depths, output the probability of the model's good class (N,) (:func:`output_name`:
``p_not_tangled``, ``p_success`` or ``p_one_part``); N is dynamic. The normalisation is
inside the graph, and the crop spec and normalisation are in the model's metadata
(``tangle_drake.*`` keys), so the file alone says how to cut its input. A model with a
target mask (``target_mask.py``) takes a third input, ``target_masks`` (N, S, S) float32:
the flood fill is not an ONNX operator, so the caller computes it (``Normalisation.masks``;
its spec is in the ``tangle_drake.normalisation`` metadata). Needs the ``onnx`` extra (onnx,
onnxscript; onnxruntime to check the result).
"""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.tangle_cnn.model import TangleModel, reweighted
from tangle_drake.tangle_cnn.network import TangleNet
from tangle_drake.tangle_cnn.normalise import Normalisation

OPSET = 18
INPUTS = ("crops", "grasp_depths")
MASK_INPUT = "target_masks"


class _ProbabilityGraph(nn.Module):
    """Normalisation + network + softmax (+ the prior correction of a pick model,
    ``TangleModel.class_weights``): the whole of ``TangleModel.predict`` in torch."""

    def __init__(self, network: TangleNet, normalisation: Normalisation,
                 class_weights: torch.Tensor | None) -> None:
        super().__init__()
        self.network = network
        self.normalisation = normalisation
        self.class_weights = class_weights

    def forward(self, crops: torch.Tensor, grasp_depths: torch.Tensor) -> torch.Tensor:
        return self.probability(self.normalisation.apply(crops, grasp_depths).unsqueeze(1))

    def probability(self, x: torch.Tensor) -> torch.Tensor:
        return reweighted(torch.softmax(self.network(x), dim=1), self.class_weights)[:, 0]


class _MaskedProbabilityGraph(_ProbabilityGraph):
    """The same with the target mask as a second channel, computed outside the graph."""

    def forward(self, crops: torch.Tensor, grasp_depths: torch.Tensor,  # type: ignore[override]
                target_masks: torch.Tensor) -> torch.Tensor:
        height = self.normalisation.apply(crops, grasp_depths)
        return self.probability(torch.stack([height, target_masks], dim=1))


def output_name(model: TangleModel) -> str:
    """The ONNX graph's output, named for what it is the probability of: ``p_not_tangled``
    for a tangle CNN, ``p_success`` or ``p_one_part`` for a pick model."""
    return "p_" + model.objective.classes[0].replace(" ", "_")


def input_names(model: TangleModel) -> tuple[str, ...]:
    """The ONNX graph's inputs for ``model``, in order."""
    return INPUTS if model.normalisation.target_mask is None else (*INPUTS, MASK_INPUT)


def export_onnx(model: TangleModel, out: Path) -> None:
    """Write ``model`` as one self-contained ONNX file (weights inside) at ``out``."""
    try:
        import onnx
    except ImportError:
        raise TangleDrakeError("ONNX export needs the onnx extra: pip install "
                               "'tangle_drake[onnx]'") from None
    size = model.crop.size_px
    names = input_names(model)
    example = tuple(torch.zeros(2, size, size) if name != "grasp_depths" else torch.zeros(2)
                    for name in names)
    batch = torch.export.Dim("batch")
    kind = _ProbabilityGraph if model.normalisation.target_mask is None else \
        _MaskedProbabilityGraph
    graph = kind(model.network, model.normalisation, model.class_weights).eval()
    exporter_log = logging.getLogger("torch.onnx")
    level = exporter_log.level
    exporter_log.setLevel(logging.ERROR)  # "torchvision is not installed. Skipping ..."
    try:
        with warnings.catch_warnings():  # torch-internal notices, nothing a user can act on
            warnings.filterwarnings("ignore", message=".*LeafSpec", category=FutureWarning)
            warnings.filterwarnings("ignore", message=".*axis name: batch will not be used")
            program = torch.onnx.export(
                graph, example, dynamo=True, opset_version=OPSET, input_names=list(names),
                output_names=[output_name(model)],
                dynamic_shapes={name: {0: batch} for name in names},
                external_data=False, verbose=False)
    except ImportError as error:
        raise TangleDrakeError(f"ONNX export needs the onnx extra ({error}): pip install "
                               "'tangle_drake[onnx]'") from None
    finally:
        exporter_log.setLevel(level)
    proto = program.model_proto
    metadata = {"tangle_drake.crop": json.dumps({"size_m": model.crop.size_m, "size_px": size}),
                "tangle_drake.normalisation": json.dumps(model.normalisation.to_dict()),
                "tangle_drake.part": json.dumps(model.info.get("part"))}
    onnx.helper.set_model_props(proto, metadata)
    out.parent.mkdir(parents=True, exist_ok=True)
    onnx.save_model(proto, str(out))


def onnx_disagreement(model: TangleModel, onnx_path: Path, samples: int = 64,
                      seed: int = 0) -> float:
    """Largest |P_onnx - P_torch| over random crops around the fingertip level (onnxruntime)."""
    try:
        import onnxruntime
    except ImportError:
        raise TangleDrakeError("checking the ONNX file needs onnxruntime: pip install "
                               "'tangle_drake[onnx]'") from None
    rng = np.random.default_rng(seed)
    size = model.crop.size_px
    depths = rng.uniform(0.5, 1.5, samples).astype(np.float32)
    crops = (depths[:, None, None] + rng.uniform(-0.08, 0.04, (samples, size, size))) \
        .astype(np.float32)
    session = onnxruntime.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    feed = {"crops": crops, "grasp_depths": depths}
    if model.normalisation.target_mask is not None:
        feed[MASK_INPUT] = model.normalisation.masks(crops, depths)
    (p_onnx,) = session.run([output_name(model)], feed)
    return float(np.abs(p_onnx - model.predict(crops, depths)).max())
