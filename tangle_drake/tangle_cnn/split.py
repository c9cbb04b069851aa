"""Train/validation split by pile, and the class balance the paper trained with.

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
