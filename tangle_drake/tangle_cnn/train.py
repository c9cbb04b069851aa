"""Training of the tangle CNN: split by pile, balance, augment x8, stop early, resume.

Files, for ``out = models/u_hook.pt``:

- ``models/u_hook.pt``: the model checkpoint (``checkpoint.py``): the weights of the epoch with
  the lowest validation loss so far, with everything that made them. Rewritten after every
  epoch, so it is usable while training runs.
- ``models/u_hook.state.pt``: the training state after the last finished epoch (its weights,
  the optimiser's state, the history). When it exists, ``train`` continues from it (unless
  ``restart``), so an interrupted run loses at most the epoch it was in.
- ``models/u_hook.log.json``: one record per finished epoch (losses, accuracy, precision and
  recall of *tangled*, ROC-AUC), rewritten whole after each epoch.

Determinism: the initial weights come from ``seed``; each epoch's shuffle, augmentation draw
and dropout come from ``(seed, epoch)`` alone, so there is no RNG state to carry: a resumed
run repeats exactly what the uninterrupted run would have done, and on the CPU the same data
and seed give the same weights.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import check_writable
from tangle_drake.tangle_cnn.augment import augment_batch
from tangle_drake.tangle_cnn.checkpoint import (
    FORMAT_VERSION,
    STATE_KIND,
    model_checkpoint,
    read_checkpoint,
    save_atomic,
)
from tangle_drake.tangle_cnn.metrics import class_metrics, few_samples_warning
from tangle_drake.tangle_cnn.model import class_shares, reweighted
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION, Normalisation
from tangle_drake.tangle_cnn.objectives import objective_named
from tangle_drake.tangle_cnn.train_settings import AUGMENTATIONS, TrainSettings
from tangle_drake.tangle_cnn.training_data import TrainingData, load_training_data

EVAL_BATCH = 512
RESUMABLE = ("epochs", "patience")
"""Settings a resumed run may change (to train longer); the others must stay as they were."""


def state_path(out: Path) -> Path:
    return out.with_name(out.stem + ".state.pt")


def log_path(out: Path) -> Path:
    return out.with_name(out.stem + ".log.json")


def resolve_device(name: str) -> torch.device:
    """``auto`` is CUDA when torch sees a GPU, else the CPU."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise TangleDrakeError("--device cuda: torch sees no CUDA GPU (a CPU-only torch build?)")
    if name not in ("cpu", "cuda"):
        raise TangleDrakeError(f"unknown device {name!r}; choose auto, cpu or cuda")
    return torch.device(name)


def train(data_dir: Path, out: Path, settings: TrainSettings, *,
          network: NetworkConfig | None = None,
          normalisation: Normalisation = DEFAULT_NORMALISATION, device: str = "auto",
          restart: bool = False,
          log: Callable[[str], None] = print) -> dict:
    """Train (or continue training) a model on ``data_dir``; returns the checkpoint's metrics.

    ``KeyboardInterrupt`` propagates after the last finished epoch is on disk.
    """
    out = Path(out)
    check_writable(out, "--out")
    dev = resolve_device(device)
    objective = objective_named(settings.objective)
    data = load_training_data(data_dir, normalisation, settings.validation_fraction,
                              settings.seed, target_mask=settings.target_mask,
                              objective=objective, balance=settings.balance)
    normalisation = data.normalisation
    config = network or NetworkConfig(input_size=data.crop.size_px,
                                      input_channels=normalisation.channels,
                                      classes=len(objective.classes))
    if config.classes != len(objective.classes):
        raise TangleDrakeError(f"a network of {config.classes} classes cannot learn the "
                               f"{objective.name} objective's {len(objective.classes)}")
    if config.input_size != data.crop.size_px:
        raise TangleDrakeError(f"network input {config.input_size} px does not match the "
                               f"data's {data.crop.size_px} px crops")
    if config.input_channels != normalisation.channels:
        raise TangleDrakeError(f"network input of {config.input_channels} channel(s) does not "
                               f"match the {normalisation.channels} the inputs have")
    torch.manual_seed(settings.seed)
    net = TangleNet(config).to(dev)
    optimiser = torch.optim.Adam(net.parameters(), lr=settings.lr)
    fixed = {"training": asdict(settings), "network": config.to_dict(),
             "normalisation": normalisation.to_dict()}
    state = {"kind": STATE_KIND, "version": FORMAT_VERSION, "settings": fixed,
             "fingerprint": data.summary["fingerprint"], "epoch": 0, "weights": None,
             "optimiser": None, "best_epoch": 0, "best_weights": None, "history": [],
             "stop_reason": None}
    if state_path(out).exists() and not restart:
        state = {**_resumed_state(out, fixed, data.summary["fingerprint"]), "stop_reason": None}
        net.load_state_dict(state["weights"])
        optimiser.load_state_dict(state["optimiser"])
        log(f"resuming {out} after epoch {state['epoch']}")
    log(f"data: {data.summary['samples']} samples ({data.summary['tangled']} "
        f"{objective.failure}) in "
        f"{data.summary['piles']} piles; training on {len(data.train)} x "
        f"{AUGMENTATIONS[settings.augment]} (augment {settings.augment}), validating on "
        f"{len(data.validation)}; device {dev}")
    tangled = int((data.labels[data.validation] != 0).sum())
    if warning := few_samples_warning(tangled, len(data.validation) - tangled,
                                      "the validation split", objective.classes):
        log(warning)

    # Validation piles at the data's own class shares (a weighted loss) are scored at them, as
    # ``evaluate`` scores the model there; undersampled ones by the balanced output.
    shares = class_shares(objective, data.summary) if data.loss_weights is not None else None
    while not (reason := _stop_reason(state, settings)):
        epoch = state["epoch"] + 1
        start = time.perf_counter()
        train_loss, train_accuracy = _run_epoch(net, optimiser, data, settings, epoch, dev)
        val_loss, probabilities = evaluate(net, data.inputs, data.labels, data.validation, dev,
                                           data.loss_weights)
        record = {"epoch": epoch, "train_loss": train_loss, "train_accuracy": train_accuracy,
                  "val_loss": val_loss,
                  **{f"val_{k}": v for k, v in validation_figures(
                      data.labels[data.validation], probabilities, shares).items()},
                  "seconds": round(time.perf_counter() - start, 3)}
        state["history"].append(record)
        best = state["history"][state["best_epoch"] - 1] if state["best_epoch"] else None
        if best is None or val_loss < best["val_loss"]:
            state["best_epoch"], state["best_weights"] = epoch, _cpu_copy(net.state_dict())
        state.update(epoch=epoch, weights=_cpu_copy(net.state_dict()),
                     optimiser=optimiser.state_dict())
        _save(out, state, data, settings, normalisation, config, dev)
        log(_describe(record, settings.epochs, epoch == state["best_epoch"]))
    state["stop_reason"] = reason
    checkpoint = _save(out, state, data, settings, normalisation, config, dev)
    log(f"{reason} after epoch {state['epoch']}; {out} holds epoch {state['best_epoch']} "
        f"(lowest validation loss)")
    return checkpoint["metrics"]


def _stop_reason(state: dict, settings: TrainSettings) -> str | None:
    if state["epoch"] >= settings.epochs:
        return "max epochs"
    if state["best_epoch"] and state["epoch"] - state["best_epoch"] >= settings.patience:
        return "early stopping"
    return None


def _resumed_state(out: Path, fixed: dict, fingerprint: str) -> dict:
    """The saved training state, if it was made by the same settings on the same data."""
    path = state_path(out)
    try:
        state = read_checkpoint(path, STATE_KIND)
    except TangleDrakeError as error:
        raise TangleDrakeError(f"{error}; pass --restart to train {out} from the start "
                               "(the data is not touched)") from None
    saved = state["settings"]
    changed = [f"{group}.{key}" for group, values in fixed.items()
               for key, value in values.items()
               if key not in RESUMABLE and saved.get(group, {}).get(key) != value]
    if state["fingerprint"] != fingerprint:
        changed.append("the data")
    if changed:
        raise TangleDrakeError(f"{path} was made with different {', '.join(changed)}; pass "
                               "--restart to start over, or another --out")
    return state


def validation_figures(labels: np.ndarray, probabilities: np.ndarray,
                       shares: torch.Tensor | None) -> dict:
    """The validation's figures (``metrics.class_metrics``) of balanced ``probabilities``,
    moved to the class ``shares`` first where the validation samples are at those shares (a
    weighted loss: every sample kept), as ``evaluate`` scores the model there."""
    return class_metrics(labels, reweighted(torch.from_numpy(probabilities), shares).numpy())


def _run_epoch(net: TangleNet, optimiser: torch.optim.Optimizer, data: TrainingData,
               settings: TrainSettings, epoch: int, dev: torch.device) -> tuple[float, float]:
    """One pass over every (training sample, transform) pair; mean loss and accuracy."""
    rng = np.random.default_rng((settings.seed, epoch))
    torch.manual_seed(int(rng.integers(2**62)))
    transforms = AUGMENTATIONS[settings.augment]
    weights = None if data.loss_weights is None else data.loss_weights.to(dev)
    order = rng.permutation(len(data.train) * transforms)
    net.train()
    total_loss, correct = 0.0, 0
    batches = range(0, len(order), settings.batch_size)
    with tqdm(batches, desc=f"epoch {epoch}/{settings.epochs}", unit="batch", leave=False,
              disable=None) as bar:
        for first in bar:
            pairs = order[first:first + settings.batch_size]
            rows = data.train[pairs // transforms]
            x = augment_batch(data.inputs[torch.from_numpy(rows)], pairs % transforms)
            y = torch.from_numpy(data.labels[rows]).to(dev)
            logits = net(x.to(dev))
            loss = nn.functional.cross_entropy(logits, y, weight=weights)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total_loss += loss.item() * len(rows)
            correct += int((logits.argmax(1) == y).sum())
            bar.set_postfix(loss=f"{loss.item():.3f}")
    return total_loss / len(order), correct / len(order)


def evaluate(net: TangleNet, inputs: torch.Tensor, labels: np.ndarray, indices: np.ndarray,
             dev: torch.device, loss_weights: torch.Tensor | None = None
             ) -> tuple[float, np.ndarray]:
    """Mean cross-entropy (weighted by class as in training, where ``loss_weights`` are
    given) and the class probabilities, (N, classes), of the samples ``indices`` (eval mode,
    no dropout)."""
    net.eval()
    weights = None if loss_weights is None else loss_weights.to(dev)
    total_loss, total_weight, probabilities = 0.0, 0.0, []
    with torch.inference_mode():
        for first in range(0, len(indices), EVAL_BATCH):
            rows = torch.from_numpy(indices[first:first + EVAL_BATCH])
            logits = net(inputs[rows].to(dev))
            y = torch.from_numpy(labels[rows.numpy()]).to(dev)
            total_loss += float(nn.functional.cross_entropy(logits, y, weight=weights,
                                                            reduction="sum"))
            total_weight += len(rows) if weights is None else float(weights[y].sum())
            probabilities.append(torch.softmax(logits, 1).cpu().numpy())
    return total_loss / total_weight, np.concatenate(probabilities)


def _save(out: Path, state: dict, data: TrainingData, settings: TrainSettings,
          normalisation: Normalisation, config: NetworkConfig, dev: torch.device) -> dict:
    """Write the state, then the checkpoint, then the log; returns the checkpoint."""
    save_atomic(state, state_path(out))
    best = state["history"][state["best_epoch"] - 1]
    checkpoint = model_checkpoint(
        config, data.crop, normalisation, state["best_weights"], gripper=data.gripper,
        part=data.part, data=data.summary, objective=settings.objective,
        training={**asdict(settings), "device": str(dev), "torch": str(torch.__version__)},
        metrics={**best, "epochs_run": state["epoch"], "stop_reason": state["stop_reason"]})
    save_atomic(checkpoint, out)
    tmp = log_path(out).with_suffix(".tmp")
    tmp.write_text(json.dumps(state["history"], indent=1))
    os.replace(tmp, log_path(out))
    return checkpoint


def _cpu_copy(weights: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    return {name: tensor.detach().to("cpu", copy=True) for name, tensor in weights.items()}


def _describe(record: dict, epochs: int, is_best: bool) -> str:
    def number(value: float | None) -> str:
        return "n/a" if value is None else f"{value:.3f}"

    return (f"epoch {record['epoch']}/{epochs}: train loss {number(record['train_loss'])} "
            f"acc {number(record['train_accuracy'])} | val loss {number(record['val_loss'])} "
            f"acc {number(record['val_accuracy'])} precision {number(record['val_precision'])} "
            f"recall {number(record['val_recall'])} AUC {number(record['val_auc'])} "
            f"({record['seconds']:.1f} s){' *' if is_best else ''}")
