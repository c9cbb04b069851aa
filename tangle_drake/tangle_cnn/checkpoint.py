"""The files ``tangle-drake train`` writes: the model checkpoint and the training state.

Both are ``torch.save`` dicts of plain values (str, numbers, lists, dicts) and tensors, so they
load with ``torch.load(weights_only=True)``, which runs no code from the file. Each carries a
``kind`` and a format ``version``; anything else in the file's place (missing, truncated,
random bytes, some other torch file, an older format, weights that do not fit the stored
network configuration) is a ``TangleDrakeError`` that says so, not an error from inside torch.

The model checkpoint (``--out``, e.g. ``models/u_hook.pt``) holds the best weights and
everything needed to use and trace them:

============== ==========================================================================
key            meaning
============== ==========================================================================
kind, version  ``MODEL_KIND``, ``FORMAT_VERSION``
network        ``NetworkConfig.to_dict()``
crop           the crop spec the data was made with: ``{"size_m", "size_px"}``
normalisation  ``Normalisation.to_dict()`` (with the target mask's spec, or ``None``)
gripper        the gripper spec of the data (the manifest's, else the default), dict
part           the part name from the data manifest (``None`` if it had none)
data           data summary: path, fingerprint, counts, split sizes, manifest
training       the training settings (``TrainSettings``)
metrics        the chosen (lowest validation loss) epoch's metrics, epochs run, stop reason
state_dict     the network's weights
objective      what the model predicts (:mod:`.objectives`); absent before objectives
               existed, which means ``tangled``
============== ==========================================================================

The training state (next to it, ``<out stem>.state.pt``) adds the last epoch's weights and the
optimiser's state, so an interrupted run continues where it stopped (see ``train.py``).
"""

from __future__ import annotations

import os
from dataclasses import asdict
from pathlib import Path

import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.crops import CropSpec
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import Normalisation
from tangle_drake.tangle_cnn.objectives import DEFAULT_OBJECTIVE

FORMAT_VERSION = 1
MODEL_KIND = "tangle_drake.tangle_cnn.model"
STATE_KIND = "tangle_drake.tangle_cnn.train_state"
MODEL_KEYS = ("kind", "version", "network", "crop", "normalisation", "gripper", "part", "data",
              "training", "metrics", "state_dict")
STATE_KEYS = ("kind", "version", "settings", "fingerprint", "epoch", "weights", "optimiser",
              "best_epoch", "best_weights", "history", "stop_reason")


def model_checkpoint(config: NetworkConfig, crop: CropSpec, normalisation: Normalisation,
                     weights: dict[str, torch.Tensor], *, gripper: dict | None = None,
                     part: str | None = None, data: dict | None = None,
                     training: dict | None = None, metrics: dict | None = None,
                     objective: str = DEFAULT_OBJECTIVE) -> dict:
    """The model checkpoint's dict (see the table above), ready for :func:`save_atomic`."""
    return {"kind": MODEL_KIND, "version": FORMAT_VERSION, "network": config.to_dict(),
            "crop": asdict(crop), "normalisation": normalisation.to_dict(), "gripper": gripper,
            "part": part, "data": data, "training": training, "metrics": metrics,
            "state_dict": weights, "objective": objective}


def save_atomic(data: dict, path: Path) -> None:
    """``torch.save`` to a temporary file, then rename: an interrupt never leaves half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        torch.save(data, tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def read_checkpoint(path: Path, kind: str = MODEL_KIND) -> dict:
    """The validated dict stored at ``path``: right kind, right version, every key present."""
    path = Path(path)
    what = "tangle CNN checkpoint" if kind == MODEL_KIND else "tangle CNN training state"
    if not path.is_file():
        raise TangleDrakeError(f"{what} not found: {path}" if not path.exists() else
                               f"{what} {path} is not a file")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many types for a bad file; all mean "corrupt"
        # torch's own message may advise weights_only=False, which would run the file's code.
        raise TangleDrakeError(f"{path} is not a readable {what}: truncated, corrupt, or "
                               "holding more than tensors and plain values "
                               f"({type(error).__name__})") from None
    if not isinstance(data, dict) or data.get("kind") != kind:
        raise TangleDrakeError(f"{path} is a torch file but not a {what}; make one with "
                               "`tangle-drake train`")
    if data.get("version") != FORMAT_VERSION:
        raise TangleDrakeError(f"{path}: {what} format version {data.get('version')!r} is not "
                               f"{FORMAT_VERSION}; retrain it with this version")
    keys = MODEL_KEYS if kind == MODEL_KIND else STATE_KEYS
    missing = [key for key in keys if key not in data]
    if missing:
        raise TangleDrakeError(f"{path}: {what} lacks {', '.join(missing)}")
    return data


def network_from(config: dict, weights: dict, path: Path) -> TangleNet:
    """The network ``config`` describes, with ``weights`` loaded; mismatches name ``path``."""
    try:
        network = TangleNet(NetworkConfig.from_dict(config))
    except (TypeError, ValueError, AttributeError) as error:
        raise TangleDrakeError(f"{path}: invalid network configuration {config!r}: "
                               f"{error}") from None
    try:
        network.load_state_dict(weights)
    except (RuntimeError, TypeError, AttributeError) as error:
        detail = " ".join(str(error).split())
        raise TangleDrakeError(f"{path}: the weights do not fit the network configuration "
                               f"{config!r}: {detail[:400]}") from None
    return network
