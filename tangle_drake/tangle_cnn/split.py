"""Train/validation split by pile, and how training evens out its classes.

Samples of one pile share its parts and their poses, so a pile split between training and
validation would leak: the split is by ``pile_seed``, never by sample. Both steps are
deterministic functions of their seed.
"""

from __future__ import annotations

import numpy as np


def split_by_pile(pile_seeds: np.ndarray, validation_fraction: float,
                  seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (train, validation): whole piles, about ``validation_fraction`` of the samples.

    Piles are shuffled with ``seed`` and taken into validation until they hold at least the
    fraction of the samples; at least one pile goes to each side. Needs two or more piles.
    """
    piles, counts = np.unique(pile_seeds, return_counts=True)
    if len(piles) < 2:
        raise ValueError("a split by pile needs at least two piles")
    order = np.random.default_rng(seed).permutation(len(piles))
    reached = np.searchsorted(np.cumsum(counts[order]), validation_fraction * len(pile_seeds))
    n_validation = int(np.clip(reached + 1, 1, len(piles) - 1))
    is_validation = np.isin(pile_seeds, piles[order[:n_validation]])
    return np.flatnonzero(~is_validation), np.flatnonzero(is_validation)


def undersample(indices: np.ndarray, labels: np.ndarray, seed: int,
                classes: int = 2) -> np.ndarray:
    """The subset of ``indices`` with as many of each class as the rarer one has (sorted).

    This is how the paper balanced its data (equal numbers of single and multiple picks);
    the dropped samples of the common class are chosen at random with ``seed``.
    """
    rng = np.random.default_rng(seed)
    by_class = [indices[labels[indices] == label] for label in range(classes)]
    keep = min(len(members) for members in by_class)
    return np.sort(np.concatenate([rng.choice(members, keep, replace=False)
                                   for members in by_class]))


BALANCES = ("undersample", "weight")
"""How training evens out its classes: ``undersample``, the paper's (as many samples of each
class as the rarest has, :func:`undersample`), or ``weight`` (every sample, each class's loss
weighted by the inverse of its share, :func:`loss_weights`: nothing is thrown away, which
matters where the rarest class is a few dozen picks)."""


def balanced_rows(indices: np.ndarray, labels: np.ndarray, seed: int, classes: int,
                  balance: str) -> np.ndarray:
    """The rows of ``indices`` that ``balance`` trains or validates on (sorted)."""
    if balance == "undersample":
        return undersample(indices, labels, seed, classes)
    return np.sort(indices)


def loss_weights(labels: np.ndarray, classes: int) -> np.ndarray:
    """Each class's weight in a ``weight``-balanced loss, ``n / (classes * n_class)``: every
    class then weighs as much in the loss as under undersampling, so the network's output is
    the same balanced estimate (and the prior correction the same)."""
    counts = np.bincount(labels, minlength=classes).astype(np.float64)
    return len(labels) / (classes * counts)
