"""The ceiling a selection rule can reach on the top candidates, from physical-pick data.

Physical-pick data (:mod:`.physical`) holds, for each pile, what each of graspability's first
candidates would have brought up. Graspability alone picks the best one it can reach (the
lowest rank with an outcome, as the planner goes down its order); an oracle that knew every
outcome picks one that brings up exactly one part whenever there is one. Any rule that
re-ranks the same candidates (the tangle CNN's, the success CNN's, the entanglement map's)
lies between the two, so their gap is what learning can close.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tangle_drake.bench.stats import wilson
from tangle_drake.pick.outcome import Outcome
from tangle_drake.tangle_data.physical import OUTCOME_CODES

ONE = OUTCOME_CODES[Outcome.ONE]


@dataclass(frozen=True)
class Ceiling:
    """First-pick success rates over the piles of a physical-pick dataset."""

    piles: int
    graspability: float
    """Exactly one part from graspability's pick (its best candidate with an outcome)."""
    oracle: float
    """Exactly one part from the best of the pile's candidates."""
    by_rank: dict[int, tuple[float, int]]
    """Each rank's success rate and number of picks."""
    graspability_interval: tuple[float, float]
    oracle_interval: tuple[float, float]
    """Wilson 95 % intervals."""

    @property
    def gap(self) -> float:
        return self.oracle - self.graspability


def pick_ceiling(samples: dict[str, np.ndarray]) -> Ceiling:
    """The ceiling of the samples' piles (fields ``task``, ``rank``, ``outcome``; tasks are
    piles)."""
    tasks, ranks, outcomes = (np.asarray(samples[name]) for name in ("task", "rank", "outcome"))
    if len(tasks) == 0:
        raise ValueError("no physical picks to measure the ceiling on")
    first, best = [], []
    for task in np.unique(tasks):
        mine = tasks == task
        order = np.argsort(ranks[mine], kind="stable")
        pile = outcomes[mine][order]
        first.append(pile[0] == ONE)
        best.append((pile == ONE).any())
    n = len(first)
    by_rank = {int(r): (float((outcomes[ranks == r] == ONE).mean()), int((ranks == r).sum()))
               for r in np.unique(ranks)}
    return Ceiling(n, float(np.mean(first)), float(np.mean(best)), by_rank,
                   wilson(int(np.sum(first)), n), wilson(int(np.sum(best)), n))
