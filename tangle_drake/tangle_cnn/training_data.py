"""A dataset directory -> checked, split, balanced and normalised training data.

Reads what ``tangle-drake collect`` writes (``tangle_drake.dataset``). From the manifest it
takes ``crop`` (``{"size_m", "size_px"}``, required: inference must crop as the data did),
``gripper`` (a ``GripperSpec`` as a dict; the default gripper if absent) and ``part``.
Every problem with the data is a ``TangleDrakeError`` naming the directory.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import load_samples, read_manifest, stored_fields
from tangle_drake.perception.crops import CropSpec
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.tangle_cnn.normalise import Normalisation
from tangle_drake.tangle_cnn.objectives import TANGLED, Objective
from tangle_drake.tangle_cnn.split import balanced_rows, loss_weights, split_by_pile
from tangle_drake.tangle_cnn.target_mask import TargetMask

FIELDS = ("crop", "label", "depth_m", "pile_seed")


@dataclass(frozen=True)
class TrainingData:
    """All samples' network inputs and labels, and which of them train and validate."""

    inputs: torch.Tensor
    """(N, C, S, S) network inputs (``Normalisation.inputs``), float32, on the CPU."""
    labels: np.ndarray
    """(N,) int64, the objective's classes: 1 = tangled (or failure), 0 = the good outcome."""
    train: np.ndarray
    """Indices of the training part (whole piles; classes undersampled, or all of them)."""
    validation: np.ndarray
    """Indices of the validation part (the other piles, chosen the same way)."""
    crop: CropSpec
    normalisation: Normalisation
    """The normalisation the inputs were made with (its target mask fitted to the data's
    crop and gripper)."""
    gripper: dict
    part: str | None
    summary: dict
    """Path, content fingerprint, counts and the manifest: stored in the checkpoint."""
    loss_weights: torch.Tensor | None = None
    """Each class's weight in the loss (``weight`` balance, from the training part's counts);
    ``None``: the classes were undersampled."""


def load_checked_samples(directory: Path, extra_fields: tuple[str, ...] = (),
                         objective: Objective = TANGLED
                         ) -> tuple[dict[str, np.ndarray], CropSpec, dict]:
    """The ``FIELDS`` (and ``extra_fields``) of every sample labelled for ``objective``, with
    ``label`` its class (0 the good outcome; ``fingerprint`` hashes them so), the crop spec
    and the manifest; ``TangleDrakeError`` naming ``directory`` if there are no such samples
    or they are unusable. Samples without a label for the objective (a tangle ``label`` of -1:
    a pick's empty grasp; an ``outcome`` of -1: not sure) are left out."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    stored = stored_fields(directory)
    if stored and objective.field not in stored:
        raise TangleDrakeError(f"dataset {directory} has no {objective.field!r} field: a "
                               f"{objective.name} model learns from {objective.data}")
    samples = load_samples(directory, tuple(dict.fromkeys((*FIELDS, objective.field,
                                                           *extra_fields))))
    raw = samples[objective.field]
    if not np.isin(raw, [*objective.codes, -1]).all():
        raise TangleDrakeError(f"dataset {directory}: {objective.field} values must be one of "
                               f"{sorted(objective.codes)} (-1: none)")
    classes, labelled = objective.labels(raw)
    samples = {name: array[labelled] for name, array in samples.items()}
    samples["label"] = classes.astype(samples["label"].dtype)
    crops, labels = samples["crop"], samples["label"].astype(np.int64)
    depths = samples["depth_m"]
    if len(labels) == 0:
        raise TangleDrakeError(f"dataset {directory} has no labelled samples yet; collect "
                               "some first")
    if crops.ndim != 3 or crops.shape[1] != crops.shape[2]:
        raise TangleDrakeError(f"dataset {directory}: crops have shape {crops.shape[1:]}, "
                               "not square")
    crop = crop_spec(manifest, crops.shape[1], directory)
    if not (np.isfinite(crops).all() and np.isfinite(depths).all() and (depths > 0).all()):
        raise TangleDrakeError(f"dataset {directory}: crops and depths must be finite, "
                               "depths positive")
    return samples, crop, manifest


def load_training_data(directory: Path, normalisation: Normalisation,
                       validation_fraction: float, seed: int,
                       target_mask: bool = False, objective: Objective = TANGLED,
                       balance: str = "undersample") -> TrainingData:
    """Load ``directory``'s labels for ``objective``, split it by pile with ``seed`` and even
    out each part's classes as ``balance`` says (``split.BALANCES``); ``target_mask`` alone
    decides whether the inputs get the target-mask channel (fitted to the data's hand and
    crop), whatever mask ``normalisation`` held."""
    from tangle_drake.common.paths import shown_path  # imports pydrake

    directory = Path(directory)
    samples, crop, manifest = load_checked_samples(directory, objective=objective)
    crops, labels = samples["crop"], samples["label"].astype(np.int64)
    depths, piles = samples["depth_m"], samples["pile_seed"]
    classes = len(objective.classes)
    counts = np.bincount(labels, minlength=classes)
    if counts.min() == 0:
        lacking = [name for name, n in zip(objective.classes, counts, strict=True) if n == 0]
        raise TangleDrakeError(f"dataset {directory} holds no {' and no '.join(lacking)} "
                               f"samples; the {objective.name} model needs every class "
                               f"({', '.join(objective.classes)})")
    try:
        train_all, validation_all = split_by_pile(piles, validation_fraction, seed)
    except ValueError:
        raise TangleDrakeError(f"dataset {directory} holds a single pile; a split by pile "
                               "needs two or more") from None
    train = balanced_rows(train_all, labels, seed, classes, balance)
    validation = balanced_rows(validation_all, labels, seed, classes, balance)
    for name, part in (("training", train), ("validation", validation)):
        if len(np.unique(labels[part])) < classes:
            raise TangleDrakeError(f"dataset {directory}: the {name} piles lack a class; "
                                   "collect more piles")
    gripper = manifest.get("gripper", asdict(DEFAULT_GRIPPER))
    normalisation = replace(normalisation, target_mask=_target_mask(gripper, crop, directory)
                            if target_mask else None)
    summary = {
        "path": shown_path(directory),
        "fingerprint": fingerprint(samples),
        "samples": len(labels),
        "tangled": int(len(labels) - counts[0]),  # not the good class, as ``Evaluation``'s
        "objective": objective.name,
        "class_counts": {name: int(n) for name, n in zip(objective.classes, counts, strict=True)},
        "piles": len(np.unique(piles)),
        "pile_seeds": [int(seed) for seed in np.unique(piles)],
        "train_samples": len(train),
        "train_piles": len(np.unique(piles[train])),
        "validation_samples": len(validation),
        "validation_piles": len(np.unique(piles[validation])),
        "manifest": manifest,
    }
    return TrainingData(
        inputs=torch.from_numpy(normalisation.inputs(crops, depths)),
        labels=labels, train=train, validation=validation, crop=crop,
        normalisation=normalisation, gripper=gripper, part=manifest.get("part"),
        loss_weights=(None if balance == "undersample" else
                      torch.as_tensor(loss_weights(labels[train], classes), dtype=torch.float32)),
        summary=summary)


def _target_mask(gripper: dict, crop: CropSpec, directory: Path) -> TargetMask:
    """The target mask for the data's hand and crop."""
    try:
        hand = GripperSpec.from_dict(gripper)
    except (TypeError, ValueError, AttributeError) as error:
        raise TangleDrakeError(f"dataset {directory}: invalid gripper in the manifest: "
                               f"{error}") from None
    return TargetMask.for_hand(crop, hand)


def crop_spec(manifest: dict, size_px: int, directory: Path) -> CropSpec:
    """The manifest's crop spec, checked against the crops' size."""
    info = manifest.get("crop")
    try:
        crop = CropSpec(float(info["size_m"]), int(info.get("size_px", size_px)))
        if not crop.size_m > 0:
            raise ValueError
    except (TypeError, KeyError, ValueError, AttributeError):
        raise TangleDrakeError(f"dataset {directory}: the manifest lacks a valid crop spec "
                               "(crop: {size_m > 0, size_px}); inference must crop as the "
                               "data did") from None
    if crop.size_px != size_px:
        raise TangleDrakeError(f"dataset {directory}: the manifest's crop is {crop.size_px} px "
                               f"but the stored crops are {size_px} px")
    return crop


def fingerprint(samples: dict[str, np.ndarray]) -> str:
    """SHA-256 of the arrays training reads: a resumed run must see the same data."""
    digest = hashlib.sha256()
    for name in FIELDS:
        array = np.ascontiguousarray(samples[name])
        digest.update(f"{name}{array.dtype}{array.shape}".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()
