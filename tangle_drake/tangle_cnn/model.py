"""A trained tangle CNN ready to score grasp candidates: ``load_tangle_model(path)``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import CropSpec, candidate_crops
from tangle_drake.tangle_cnn.checkpoint import network_from, read_checkpoint
from tangle_drake.tangle_cnn.network import TangleNet
from tangle_drake.tangle_cnn.normalise import Normalisation
from tangle_drake.tangle_cnn.objectives import Objective, checkpoint_objective, prior_weights

INFERENCE_THREADS = 1
"""Threads of one prediction. A handful of 96 px crops is too little work to share: two
threads are slower than one, and far slower whenever another process (the physics, a
benchmark worker) holds the other core, as torch's threads wait on each other (figures:
``docs/performance.md``)."""


def reweighted(probabilities: torch.Tensor, weights: torch.Tensor | None) -> torch.Tensor:
    """Class probabilities (N, classes) under equal shares, moved by Bayes' rule to the class
    shares ``weights`` and renormalised (as they are for ``None``): a pick model's prior
    correction, the one place for it (:class:`TangleModel`, its ONNX graph, training's
    validation figures)."""
    if weights is None:
        return probabilities
    weighted = probabilities * weights
    return weighted / weighted.sum(dim=1, keepdim=True)


def class_shares(objective: Objective, data: dict) -> torch.Tensor | None:
    """:func:`~tangle_drake.tangle_cnn.objectives.prior_weights` of a checkpoint's (or a
    training run's) ``data`` summary, as the tensor :func:`reweighted` takes."""
    shares = prior_weights(objective, data)
    return None if shares is None else torch.as_tensor(shares, dtype=torch.float32)


class TangleModel:
    """The network in eval mode on the CPU, with the crop spec and normalisation it was trained
    with, so callers hand over metric crops or whole depth images and never normalise.
    Predictions run on ``INFERENCE_THREADS`` threads, whatever torch's global setting (which
    they leave as it was)."""

    def __init__(self, network: TangleNet, crop: CropSpec, normalisation: Normalisation,
                 info: dict | None = None, source: str = "the model") -> None:
        if crop.size_px != network.config.input_size:
            raise TangleDrakeError(f"crop of {crop.size_px} px does not fit the network's "
                                   f"{network.config.input_size} px input")
        if normalisation.channels != network.config.input_channels:
            raise TangleDrakeError(f"the normalisation makes {normalisation.channels} input "
                                   f"channel(s), the network takes "
                                   f"{network.config.input_channels}")
        self.network = network.eval()
        self.crop = crop
        self.normalisation = normalisation
        self.info = info or {}
        """The checkpoint's metadata (everything but the weights)."""
        self.objective: Objective = checkpoint_objective(self.info)
        """What :meth:`predict` gives the probability of (P(not tangled) for a tangle CNN)."""
        if len(self.objective.classes) != network.config.classes:
            raise TangleDrakeError(f"a {self.objective.name} model needs "
                                   f"{len(self.objective.classes)} outputs, the network has "
                                   f"{network.config.classes}")
        self.class_weights = class_shares(self.objective, self.info.get("data") or {})
        """The training data's class shares that the balanced network's probabilities are
        weighted by (``None``: its output is used as it is); see ``Objective.prior_corrected``."""
        self.source = source
        """Where the model came from (its file), for messages."""

    def predict(self, crops: np.ndarray, grasp_depths: np.ndarray) -> np.ndarray:
        """P(not tangled) (the objective's good class: P(exactly one part) for a success or
        outcome model), (N,) float32, of (N, S, S) metric crops at (N,) fingertip depths."""
        return self.probabilities(crops, grasp_depths)[:, 0]

    def probabilities(self, crops: np.ndarray, grasp_depths: np.ndarray,
                      balanced: bool = False) -> np.ndarray:
        """Every class's probability, (N, classes) float32 (:attr:`objective`'s classes);
        ``balanced``: the network's own output, under the equal class shares it trained on
        (to score a class-balanced set), without the prior correction."""
        crops = np.asarray(crops, dtype=np.float32)
        grasp_depths = np.asarray(grasp_depths, dtype=np.float32)
        size = self.crop.size_px
        if crops.ndim != 3 or crops.shape[1:] != (size, size):
            raise TangleDrakeError(f"crops must be (N, {size}, {size}), got {crops.shape}")
        if grasp_depths.shape != (len(crops),):
            raise TangleDrakeError(f"grasp depths must be ({len(crops)},), got "
                                   f"{grasp_depths.shape}")
        if not (np.isfinite(crops).all() and np.isfinite(grasp_depths).all()):
            raise TangleDrakeError("crops and grasp depths must be finite (extract_crop fills "
                                   "missing pixels)")
        if len(crops) == 0:
            return np.zeros((0, self.network.config.classes), dtype=np.float32)
        x = torch.from_numpy(self.normalisation.inputs(crops, grasp_depths))
        threads = torch.get_num_threads()
        torch.set_num_threads(INFERENCE_THREADS)
        try:
            with torch.inference_mode():
                probabilities = reweighted(torch.softmax(self.network(x), dim=1),
                                           None if balanced else self.class_weights).numpy()
        finally:
            torch.set_num_threads(threads)
        return probabilities

    def warm_up(self, batch: int) -> None:
        """Predict once on ``batch`` blank crops: torch sizes its buffers on the first call
        of a batch size (10 candidates: 14 ms the first time, 3 ms after), so the first pick
        is as fast as the others."""
        size = self.crop.size_px
        self.predict(np.full((batch, size, size), 0.5, dtype=np.float32),
                     np.full(batch, 0.5, dtype=np.float32))

    def predict_candidates(self, depth_image: np.ndarray, intrinsics: CameraIntrinsics,
                           candidates: Sequence[Any]) -> np.ndarray:
        """P(not tangled) per candidate (anything with ``u, v, angle_deg, depth_m``)."""
        crops = candidate_crops(depth_image, intrinsics, candidates, self.crop)
        return self.predict(crops, np.array([c.depth_m for c in candidates], dtype=np.float32))


def load_tangle_model(path: Path | str) -> TangleModel:
    """The model in a checkpoint written by ``tangle-drake train``; ``TangleDrakeError`` if the
    file is missing, corrupt, of another kind or version, or its weights do not fit."""
    path = Path(path)
    data = read_checkpoint(path)
    network = network_from(data["network"], data["state_dict"], path)
    try:
        crop = CropSpec(float(data["crop"]["size_m"]), int(data["crop"]["size_px"]))
        normalisation = Normalisation.from_dict(data["normalisation"])
    except (TypeError, KeyError, ValueError, AttributeError) as error:
        raise TangleDrakeError(f"{path}: invalid crop spec or normalisation: {error}") from None
    try:
        return TangleModel(network, crop, normalisation,
                           {key: value for key, value in data.items() if key != "state_dict"},
                           source=str(path))
    except TangleDrakeError as error:
        raise TangleDrakeError(f"{path}: {error}") from None
