"""A trained tangle CNN against a labelled dataset: how often it is right, and on which picks.

The accuracy in a checkpoint is measured on the validation piles that early stopping watched,
which flatters the model a little; a dataset collected with another ``--seed`` holds piles the
model never saw and gives a test figure. On the model's own training data only its validation
piles are scored (the same balanced subset as the checkpoint's figure), never its training piles.

Every collected sample records how its label came about (``tangle_drake.tangle_data.samples``),
so the figures are also broken down by cause: two parts in the closing region, a part hanging
from the target or riding on it, a part that rose and fell back; and, for the picks that lifted
one part, whether another part was disturbed on the way (rose a centimetre or more, but not
past the labelling threshold) — the picks a top view confuses most with tangles.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.stats import wilson
from tangle_drake.dataset import stored_fields
from tangle_drake.perception.crops import CropSpec
from tangle_drake.tangle_cnn.metrics import balanced_accuracy, binary_metrics, class_metrics
from tangle_drake.tangle_cnn.model import TangleModel
from tangle_drake.tangle_cnn.objectives import TANGLED
from tangle_drake.tangle_cnn.split import balanced_rows, split_by_pile
from tangle_drake.tangle_cnn.training_data import fingerprint, load_checked_samples

CAUSE_FIELDS = ("num_in_region", "num_hanging", "num_riding", "max_rise_m")
"""Fields that say how a label came about (older or synthetic datasets may lack some)."""

DISTURBED_RISE_M = 0.01
"""A part that rose at least this far during a one-part pick was disturbed by it."""

BATCH = 256

ALL_SAMPLES = "all samples"
"""The scope of an evaluation on data the model did not train on: its natural class shares,
scored with the model's prior-corrected probabilities (the balanced validation rows of its own
data are scored with the balanced output, as training scored them)."""


@dataclass(frozen=True)
class Group:
    """The samples whose label came about one way, and how the model did on them."""

    name: str
    samples: int
    correct: int
    mean_p_tangled: float | None


@dataclass(frozen=True)
class Bin:
    """Samples whose predicted probability fell in one bin, and what came true."""

    low: float
    high: float
    samples: int
    mean_predicted: float
    observed: float


CALIBRATION_BINS = 10


def calibration(p_good: np.ndarray, good: np.ndarray,
                bins: int = CALIBRATION_BINS) -> tuple[Bin, ...]:
    """The reliability table of ``p_good`` against the truth ``good``: non-empty bins only."""
    edges = np.linspace(0.0, 1.0, bins + 1)
    which = np.clip(np.digitize(p_good, edges[1:-1]), 0, bins - 1)
    return tuple(Bin(float(edges[k]), float(edges[k + 1]), int((which == k).sum()),
                     float(p_good[which == k].mean()), float(good[which == k].mean()))
                 for k in range(bins) if (which == k).any())


def calibration_error(bins: tuple[Bin, ...] | list[dict]) -> float | None:
    """The expected calibration error of a reliability table (:func:`calibration`'s bins, or
    their dicts): the sample-weighted mean gap between predicted and observed, 0-1."""
    rows = [b if isinstance(b, dict) else asdict(b) for b in bins]
    total = sum(b["samples"] for b in rows)
    if not total:
        return None
    return sum(b["samples"] * abs(b["mean_predicted"] - b["observed"]) for b in rows) / total


@dataclass(frozen=True)
class Evaluation:
    """A model's figures on a dataset (``scope`` says which of its samples were scored)."""

    data: str
    data_part: str | None
    model_part: str | None
    scope: str
    samples: int
    tangled: int
    piles: int
    accuracy: float
    accuracy_interval: tuple[float, float]
    """Wilson 95 % interval of the accuracy."""
    balanced_accuracy: float | None
    """Mean of the two classes' recalls: the accuracy a class-balanced set would give
    (``None`` when the scored samples hold one class only)."""
    precision: float | None
    recall: float | None
    auc: float | None
    groups: tuple[Group, ...]
    """By cause of the label; empty when the dataset does not record the causes."""
    objective: str = TANGLED.name
    """What the model predicts (:mod:`.objectives`); ``tangled`` counts the samples not of
    its class 0 (tangled; failure: several parts or none), ``precision`` and ``recall`` are
    theirs, at P(class 0) < 0.5."""
    classes: tuple[str, ...] = TANGLED.classes
    class_accuracy: float | None = None
    """With three classes or more: how often the most probable class is the true one..."""
    class_recall: list | None = None
    """...and each class's recall (``None`` for a class the samples lack)..."""
    class_samples: list | None = None
    """...and how many samples each class holds."""
    calibration: tuple[Bin, ...] = ()
    """How well P(class 0) is calibrated: the samples in ten bins of it, each with its mean
    prediction and how often class 0 was the truth."""
    prior_corrected: bool = False
    """Whether the probabilities were moved to the training data's class shares
    (``Objective.prior_corrected``); ``False`` for a pick model's balanced output, and in
    figures written before the correction existed."""

    def to_dict(self) -> dict:
        return asdict(self)


def class_probabilities(model: TangleModel, samples: dict[str, np.ndarray],
                        rows: np.ndarray | None = None,
                        progress: Callable[[int], None] | None = None,
                        balanced: bool = False) -> np.ndarray:
    """The model's class probabilities of the samples' ``rows`` (default all), (N, classes),
    scored in batches (``balanced``: as ``TangleModel.probabilities``); ``progress(n)`` is
    told of each batch of n samples."""
    rows = np.arange(len(samples["label"])) if rows is None else rows
    probabilities = np.empty((len(rows), len(model.objective.classes)), dtype=np.float64)
    for first in range(0, len(rows), BATCH):
        batch = rows[first:first + BATCH]
        probabilities[first:first + len(batch)] = model.probabilities(
            samples["crop"][batch], samples["depth_m"][batch], balanced)
        if progress is not None:
            progress(len(batch))
    return probabilities


def evaluate_model(model: TangleModel, directory: Path,
                   progress: Callable[[int], None] | None = None) -> Evaluation:
    """Score every sample of ``directory`` (or, for the model's own training data, its
    validation piles) with ``model``; ``progress(n)`` is told of each batch of n samples."""
    from tangle_drake.common.paths import shown_path  # imports pydrake

    directory = Path(directory)
    causes = CAUSE_FIELDS if set(CAUSE_FIELDS) <= stored_fields(directory) else ()
    objective = model.objective
    samples, crop, manifest = load_checked_samples(directory, causes, objective)
    labels = samples["label"].astype(np.int64)
    check_crop(model.crop, crop, directory)
    rows, scope, balanced = _scored_rows(model, samples, labels, len(objective.classes))
    corrected = model.class_weights is not None and not balanced
    probabilities = class_probabilities(model, samples, rows, progress, balanced=not corrected)
    # P(not the good class), as float32 arithmetic then float64, as it always was.
    p_tangled = (1.0 - probabilities[:, 0].astype(np.float32)).astype(np.float64)
    classes = labels[rows]
    truth = (classes != 0).astype(np.int64)
    metrics = binary_metrics(truth, p_tangled)
    correct = int(((p_tangled > 0.5) == truth.astype(bool)).sum())
    several = class_metrics(classes, probabilities) if len(objective.classes) > 2 else {}
    return Evaluation(
        data=shown_path(directory), data_part=manifest.get("part"),
        model_part=model.info.get("part"),
        scope=scope, samples=len(rows), tangled=int(truth.sum()),
        piles=len(np.unique(samples["pile_seed"][rows])),
        accuracy=float(metrics["accuracy"]), accuracy_interval=wilson(correct, len(rows)),
        balanced_accuracy=balanced_accuracy(truth, p_tangled), precision=metrics["precision"],
        recall=metrics["recall"], auc=metrics["auc"],
        groups=(_outcome_groups(samples, rows, truth, p_tangled)
                if objective.field == "outcome" else
                _groups(samples, manifest, rows, truth, p_tangled)),
        objective=objective.name, classes=objective.classes,
        class_accuracy=several.get("class_accuracy"), class_recall=several.get("class_recall"),
        class_samples=([int((classes == k).sum()) for k in range(len(objective.classes))]
                       if several else None),
        calibration=calibration(1.0 - p_tangled, truth == 0), prior_corrected=corrected)


def check_crop(model_crop: CropSpec, data_crop: CropSpec, directory: Path) -> None:
    """Refuse data cropped otherwise than the model's training data: its probabilities would
    mean nothing there."""
    if (model_crop.size_px != data_crop.size_px
            or not np.isclose(model_crop.size_m, data_crop.size_m, rtol=1e-6)):
        raise TangleDrakeError(
            f"dataset {directory} holds {data_crop.size_m:g} m crops at {data_crop.size_px} px, "
            f"the model was trained on {model_crop.size_m:g} m at {model_crop.size_px} px: "
            "collect the data with the model's crop (tangle-drake collect --crop-size)")


def _scored_rows(model: TangleModel, samples: dict[str, np.ndarray],
                 labels: np.ndarray, classes: int) -> tuple[np.ndarray, str, bool]:
    """All rows, or the validation rows as training chose them when this is the model's
    training data; and whether their classes were undersampled to equal shares."""
    data = model.info.get("data") or {}
    training = model.info.get("training") or {}
    if data.get("fingerprint") != fingerprint(samples):
        return np.arange(len(labels)), ALL_SAMPLES, False
    seed = int(training.get("seed", 0))
    balance = training.get("balance") or "undersample"  # checkpoints made before ``weight``
    _, validation = split_by_pile(samples["pile_seed"],
                                  float(training.get("validation_fraction", 0.1)), seed)
    undersampled = balance == "undersample"
    return (balanced_rows(validation, labels, seed, classes, balance),
            "the model's validation piles (this is its training data)" +
            (", classes balanced as in training" if undersampled else ""), undersampled)


def _outcome_groups(samples: dict[str, np.ndarray], rows: np.ndarray, truth: np.ndarray,
                    p_failure: np.ndarray) -> tuple[Group, ...]:
    """A success/failure model's figures by what the physical pick brought up."""
    outcome = samples["outcome"][rows]
    right = (p_failure > 0.5) == (truth == 1)
    names = {2: "failure: several parts came up", 0: "failure: no part came up",
             1: "success: exactly one part came up"}
    return tuple(Group(name, int(chosen.sum()), int(right[chosen].sum()),
                       float(p_failure[chosen].mean()) if chosen.any() else None)
                 for code, name in names.items() for chosen in [outcome == code])


def _groups(samples: dict[str, np.ndarray], manifest: dict, rows: np.ndarray,
            truth: np.ndarray, p_tangled: np.ndarray) -> tuple[Group, ...]:
    """The figures by cause of the label, if the dataset records the causes."""
    if not set(CAUSE_FIELDS) <= set(samples):
        return ()
    causes = {name: samples[name][rows] for name in CAUSE_FIELDS}
    threshold = float((manifest.get("labels") or {}).get("rise_threshold_m", np.nan))
    region = causes["num_in_region"] >= 2
    hangs, rides = causes["num_hanging"] > 0, causes["num_riding"] > 0
    disturbed = causes["max_rise_m"] >= DISTURBED_RISE_M
    tangled, clean = truth == 1, truth == 0
    below = f"under {threshold * 100:g} cm" if np.isfinite(threshold) else "under the threshold"
    selections = {
        "tangled: two parts in the closing region": tangled & region,
        "tangled: a part hangs from the target": tangled & ~region & hangs,
        "tangled: a part rides on the target": tangled & ~region & ~hangs & rides,
        "tangled: a part rose and fell back": tangled & ~region & ~hangs & ~rides,
        f"not tangled: no other part rose {DISTURBED_RISE_M * 100:g} cm": clean & ~disturbed,
        f"not tangled: another part rose {DISTURBED_RISE_M * 100:g} cm or more, {below}":
            clean & disturbed,
    }
    right = (p_tangled > 0.5) == tangled
    return tuple(Group(name, int(chosen.sum()), int(right[chosen].sum()),
                       float(p_tangled[chosen].mean()) if chosen.any() else None)
                 for name, chosen in selections.items())
