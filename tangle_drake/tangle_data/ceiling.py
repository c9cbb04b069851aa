"""The ceiling a selection rule can reach on the top candidates, from physical-pick data.

Physical-pick data (:mod:`.physical`) holds, for each pile, what each of graspability's first
candidates would have brought up. Graspability alone picks the best one it can reach (the
lowest rank with an outcome, as the planner goes down its order); an oracle that knew every
outcome picks one that brings up exactly one part whenever there is one. Any rule that
re-ranks the same candidates (the tangle CNN's, the success CNN's, the entanglement map's)
lies between the two, so their gap is what learning can close; :func:`rule_choice` measures how
much of it a rule with a model closes on the same piles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tangle_drake.common.stats import PairedDifference, paired_difference, wilson
from tangle_drake.pick.outcome import Outcome
from tangle_drake.selection.rules import rank
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
    ranks, outcomes = np.asarray(samples["rank"]), np.asarray(samples["outcome"])
    first, best = [], []
    for rows in _piles(samples, "the ceiling"):
        pile = outcomes[rows] == ONE
        first.append(bool(pile[0]))
        best.append(bool(pile.any()))
    n = len(first)
    by_rank = {int(r): (float((outcomes[ranks == r] == ONE).mean()), int((ranks == r).sum()))
               for r in np.unique(ranks)}
    return Ceiling(n, float(np.mean(first)), float(np.mean(best)), by_rank,
                   wilson(int(np.sum(first)), n), wilson(int(np.sum(best)), n))


@dataclass(frozen=True)
class RuleChoice:
    """A rule's first picks on the same piles, against graspability's and the oracle's."""

    rule: str
    success: float
    """Exactly one part from the rule's pick (its best candidate with an outcome)."""
    interval: tuple[float, float]
    """Wilson 95 %."""
    against_graspability: PairedDifference
    """The rule's picks minus graspability's, pile by pile (Newcombe's interval, McNemar)."""
    closed: float | None
    """The share of graspability's gap to the oracle the rule closes (``None``: no gap)."""


def rule_choice(samples: dict[str, np.ndarray], rule: str,
                p_model: np.ndarray | None = None) -> RuleChoice:
    """What ``rule`` would have picked first on each pile of the samples (fields ``task``,
    ``rank``, ``outcome``, ``score``; ``p_model`` (N,) the model's probability per sample),
    scored by the outcome the data recorded for that candidate.

    The rule sees a pile's candidates that have an outcome (a pick that could not be attempted
    is absent, as the planner passes over an unreachable candidate), graspability normalised by
    their best.
    """
    outcomes, scores = np.asarray(samples["outcome"]), np.asarray(samples["score"])
    p = None if p_model is None else np.asarray(p_model, dtype=np.float64)
    first, chosen, best = [], [], []
    for rows in _piles(samples, "the rule"):
        pile = outcomes[rows] == ONE
        order = rank(rule, scores[rows], None if p is None else p[rows]).order
        first.append(bool(pile[0]))
        chosen.append(bool(pile[order[0]]))
        best.append(bool(pile.any()))
    n, gap = len(first), np.mean(best) - np.mean(first)
    gained = np.mean(chosen) - np.mean(first)
    return RuleChoice(rule, float(np.mean(chosen)), wilson(int(np.sum(chosen)), n),
                      paired_difference(chosen, first),
                      float(gained / gap) if gap > 0 else None)


def _piles(samples: dict[str, np.ndarray], what: str) -> list[np.ndarray]:
    """Each pile's sample rows (tasks are piles), in graspability's rank order."""
    tasks, ranks = np.asarray(samples["task"]), np.asarray(samples["rank"])
    if len(tasks) == 0:
        raise ValueError(f"no physical picks to measure {what} on")
    piles = [np.flatnonzero(tasks == task) for task in np.unique(tasks)]
    return [rows[np.argsort(ranks[rows], kind="stable")] for rows in piles]
