"""The model card's tables, one place for their columns: a checkpoint's own validation
figures, and a test on fresh piles (``evaluate``'s figures). The shipped card
(``tools/make_trained_models.py``) and each ``tangle-drake teach`` run's card use them."""

from __future__ import annotations

from pathlib import Path

from tangle_drake.common.stats import wilson
from tangle_drake.tangle_cnn.checkpoint import MODEL_KIND, read_checkpoint
from tangle_drake.tangle_cnn.evaluate import calibration_error
from tangle_drake.tangle_cnn.objectives import TANGLED, objective_named


def validation_header(failure: str = "tangled") -> str:
    """:func:`validation_row`'s header; ``failure`` names the model's class 1 (``failure`` for
    a success/failure model)."""
    return (f"| part | samples | {failure} % | piles | train / validation samples (balanced by "
            f"undersampling, or all of them with the loss weighted by class) "
            f"| epoch chosen | val loss | val accuracy % [95 % interval] | precision % ({failure}) "
            f"| recall % ({failure}) | ROC-AUC | size |\n" + "|---" * 12 + "|")


def test_header(failure: str = "tangled") -> str:
    """:func:`test_row`'s header (``failure`` as in :func:`validation_header`)."""
    return (f"| part | test samples | {failure} % | piles | accuracy % [95 % interval] "
            f"| balanced accuracy % | precision % ({failure}) | recall % ({failure}) | ROC-AUC |\n"
            + "|---" * 9 + "|")


VALIDATION_HEADER = validation_header()
TEST_HEADER = test_header()


def pct(value: float | None) -> str:
    """A share as a percentage with one decimal, or n/a."""
    return "n/a" if value is None else f"{100 * value:.1f}"


def validation_row(path: Path) -> str:
    """One row of :data:`VALIDATION_HEADER` from a checkpoint's own record."""
    checkpoint = read_checkpoint(path, MODEL_KIND)
    data, metrics = checkpoint["data"], checkpoint["metrics"]

    auc = metrics.get("val_auc")
    counts = data.get("class_counts")  # class 0 first; older checkpoints have two classes
    failures = data["samples"] - next(iter(counts.values())) if counts else data["tangled"]
    tangled = 100 * failures / data["samples"]
    n = data["validation_samples"]
    low, high = wilson(round(metrics["val_accuracy"] * n), n)
    weighted = (checkpoint.get("training") or {}).get("balance") == "weight"
    return (f"| {checkpoint['part']} | {data['samples']} | {tangled:.1f} | {data['piles']} "
            f"| {data['train_samples']} / {n} "
            f"({data['validation_piles']} piles{', loss weighted' if weighted else ''}) "
            f"| {metrics['epoch']} of {metrics['epochs_run']} "
            f"| {metrics['val_loss']:.3f} | {pct(metrics.get('val_accuracy'))} [{100 * low:.0f}, "
            f"{100 * high:.0f}] | {pct(metrics.get('val_precision'))} | "
            f"{pct(metrics.get('val_recall'))} | {'n/a' if auc is None else f'{auc:.3f}'} | "
            f"{path.stat().st_size / 1e6:.1f} MB |")


def part_cell(part: str, result: dict) -> str:
    """A test row's part, marked where a pick model was scored by its balanced output: tested
    before the prior correction, its accuracy weighs the classes as if they were equal."""
    objective = objective_named(str(result.get("objective") or TANGLED.name))
    stale = objective.prior_corrected and not result.get("prior_corrected", False)
    return f"{part} (balanced output)" if stale else part


def test_row(part: str, result: dict) -> tuple[str, dict[str, str]]:
    """One row of :data:`TEST_HEADER` from an evaluation (``Evaluation.to_dict()``), and its
    right % (samples) by cause of the label."""
    low, high = result["accuracy_interval"]
    auc = "n/a" if result["auc"] is None else f"{result['auc']:.3f}"
    share = 100 * result["tangled"] / result["samples"]
    row = (f"| {part_cell(part, result)} | {result['samples']} | {share:.1f} | {result['piles']} "
           f"| {pct(result['accuracy'])} [{100 * low:.0f}, {100 * high:.0f}] "
           f"| {pct(result['balanced_accuracy'])} | {pct(result['precision'])} "
           f"| {pct(result['recall'])} | {auc} |")
    causes = {group["name"]: f"{pct(group['correct'] / group['samples'])} ({group['samples']})"
              if group["samples"] else "-" for group in result["groups"]}
    return row, causes


def classes_test_header(classes: tuple[str, ...]) -> str:
    """:func:`classes_test_row`'s header, for a model of three classes or more (``classes``:
    the good one first)."""
    names = " / ".join(classes)
    return (f"| part | test samples | {names} % | piles | most probable class right % "
            f"| recall % ({names}) | ROC-AUC of P({classes[0]}) "
            f"| calibration error of P({classes[0]}), points |\n" + "|---" * 8 + "|")


def classes_test_row(part: str, result: dict) -> str:
    """One row of :func:`classes_test_header` from an evaluation (``Evaluation.to_dict()``)
    of a model of three classes or more."""
    shares = " / ".join(f"{100 * n / result['samples']:.1f}" for n in result["class_samples"])
    recalls = " / ".join(pct(r) for r in result["class_recall"])
    auc = "n/a" if result["auc"] is None else f"{result['auc']:.3f}"
    error = calibration_error(result["calibration"])
    return (f"| {part_cell(part, result)} | {result['samples']} | {shares} | {result['piles']} "
            f"| {pct(result['class_accuracy'])} | {recalls} | {auc} "
            f"| {'n/a' if error is None else f'{100 * error:.1f}'} |")
