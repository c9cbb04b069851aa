"""Every random choice of a task derives from (collection seed, task index) alone.

So task ``i`` makes the same pile and picks the same candidates whichever worker runs it, in
whatever order, on whatever machine, and a resumed run redoes exactly the missing tasks.
"""

from __future__ import annotations

import numpy as np

_PILE, _CHOICE, _PERTURB, _PHYSICS, _DEPTH_NOISE = 0, 1, 2, 3, 4


def _stream(seed: int, task: int, purpose: int, *more: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, task, purpose, *more])


def pile_seed(seed: int, task: int) -> int:
    """The pile seed of task ``task`` (a non-negative int64, stored with every sample)."""
    return int(_stream(seed, task, _PILE).generate_state(1, np.uint64)[0] >> np.uint64(1))


def choice_rng(seed: int, task: int) -> np.random.Generator:
    """Random generator that picks which candidates of the task's pile are labelled."""
    return np.random.default_rng(_stream(seed, task, _CHOICE))


def perturbation_rng(seed: int, task: int, rank: int, repeat: int) -> np.random.Generator:
    """Random generator of the ``repeat``-th perturbed re-run of the lift of candidate ``rank``."""
    return np.random.default_rng(_stream(seed, task, _PERTURB, rank, repeat))


def physics_rng(seed: int, task: int, rank: int) -> np.random.Generator:
    """Random generator of the physics of the physical pick of candidate ``rank``."""
    return np.random.default_rng(_stream(seed, task, _PHYSICS, rank))


def depth_noise_rng(seed: int, task: int, rank: int) -> np.random.Generator:
    """Random generator of the depth noise the crop of candidate ``rank``'s pick sees."""
    return np.random.default_rng(_stream(seed, task, _DEPTH_NOISE, rank))
