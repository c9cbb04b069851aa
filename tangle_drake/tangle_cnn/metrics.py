"""Classification metrics of *tangled* (the positive class), numpy only.

Undefined values (precision with no positive prediction, recall or ROC-AUC without both
classes) are ``None``, which JSON logs can hold and NaN cannot.
"""

from __future__ import annotations

import numpy as np


def roc_auc(labels: np.ndarray, scores: np.ndarray) -> float | None:
    """Area under the ROC curve of ``scores`` for the positive ``labels`` (1 / True).

    The probability that a random positive scores above a random negative, ties counting
    half (Mann-Whitney U with mid-ranks): exact, no threshold sweep.
    """
    positive = np.asarray(labels).astype(bool)
    n_positive = int(positive.sum())
    n_negative = positive.size - n_positive
    if n_positive == 0 or n_negative == 0:
        return None
    _, inverse, counts = np.unique(np.asarray(scores), return_inverse=True, return_counts=True)
    last_rank = np.cumsum(counts)
    mid_rank = last_rank - (counts - 1) / 2
    rank_sum = float(mid_rank[inverse.ravel()][positive].sum())
    return (rank_sum - n_positive * (n_positive + 1) / 2) / (n_positive * n_negative)


def balanced_accuracy(labels: np.ndarray, p_tangled: np.ndarray) -> float | None:
    """Mean of the two classes' recalls at threshold 0.5: the accuracy on a class-balanced
    set, without discarding samples of the common class. ``None`` without both classes."""
    truth = np.asarray(labels).astype(bool)
    predicted = np.asarray(p_tangled) > 0.5
    if truth.all() or not truth.any():
        return None
    return float((predicted[truth].mean() + (~predicted[~truth]).mean()) / 2)


def binary_metrics(labels: np.ndarray, p_tangled: np.ndarray) -> dict[str, float | None]:
    """Accuracy, precision, recall (threshold 0.5, i.e. the softmax's argmax) and ROC-AUC."""
    truth = np.asarray(labels).astype(bool)
    predicted = np.asarray(p_tangled) > 0.5
    true_positive = int((truth & predicted).sum())
    return {
        "accuracy": float((truth == predicted).mean()) if truth.size else None,
        "precision": true_positive / int(predicted.sum()) if predicted.any() else None,
        "recall": true_positive / int(truth.sum()) if truth.any() else None,
        "auc": roc_auc(truth, p_tangled),
    }


def class_metrics(labels: np.ndarray, probabilities: np.ndarray) -> dict:
    """A model's figures from its class probabilities ``(N, classes)``: :func:`binary_metrics`
    of class 0 (the good outcome) against the others, as P(not class 0) (for the tangle CNN:
    of *tangled*, exactly as before), and with three classes or more the accuracy of the most
    probable class and each class's recall too."""
    labels = np.asarray(labels)
    probabilities = np.asarray(probabilities)
    metrics: dict = binary_metrics(labels != 0, probabilities[:, 1:].sum(axis=1))
    if probabilities.shape[1] > 2:
        predicted = probabilities.argmax(axis=1)
        metrics["class_accuracy"] = float((predicted == labels).mean()) if len(labels) else None
        metrics["class_recall"] = [float((predicted[labels == k] == k).mean())
                                   if (labels == k).any() else None
                                   for k in range(probabilities.shape[1])]
    return metrics


FEW_PER_CLASS = 30
"""Below this many samples of a class, accuracy and ROC-AUC swing by tens of points from one
split to the next (a handful of samples gives an AUC of 1.000 by luck)."""


def few_samples_warning(bad: int, good: int, what: str,
                        classes: tuple[str, ...] = ("not tangled", "tangled")) -> str | None:
    """A warning when ``what`` holds fewer than ``FEW_PER_CLASS`` samples of the model's good
    class (class 0 of ``classes``) or of the others."""
    if min(bad, good) >= FEW_PER_CLASS:
        return None
    others = classes[1] if len(classes) == 2 else f"other than {classes[0]}"
    return (f"warning: {what} holds only {bad} {others} and {good} {classes[0]} samples; "
            f"with fewer than {FEW_PER_CLASS} of a class its accuracy and ROC-AUC are "
            "unreliable (even 1.000 says little): collect more piles")
