"""Which grasp candidate to pick: the paper's rule and the baselines it is compared with.

Rules (``RULES``), over the candidates of one image (the graspability top-k):

- ``graspability``: the highest graspability score (the method without the CNN);
- ``cnn``: the highest P(not tangled);
- ``harmonic`` (the paper): the highest harmonic mean ``2 g p / (g + p)`` of the normalised
  graspability ``g`` and ``p`` = P(not tangled). Graspability is normalised by the best score
  among the image's candidates, ``g = score / max(score)``, so the best candidate has ``g = 1``
  and both terms lie in [0, 1] whatever the index's absolute scale. A zero in either term
  gives 0 (a grasp that cannot close or surely tangles is never preferred); all-zero scores
  give ``g = 0`` for all;
- ``random``: uniform among the candidates, from a seeded generator (a benchmark baseline);
  its "combined score" is each candidate's chance of being drawn, ``1 / N``.

Ties go to the candidate that is better on the other term (P(not tangled) for
``graspability``, graspability for ``cnn`` and ``harmonic``), then to the earlier one.
Numpy only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tangle_drake.errors import TangleDrakeError

RULES = ("graspability", "cnn", "harmonic", "random")


class Selection(NamedTuple):
    index: int | None
    """The chosen candidate; ``None`` when there are no candidates."""
    scores: np.ndarray
    """Each candidate's combined score under the rule, (N,) float64."""


def check_rule(rule: str) -> str:
    if rule not in RULES:
        raise TangleDrakeError(f"unknown selection rule {rule!r}; choose one of "
                               f"{', '.join(RULES)}")
    return rule


def normalised_graspability(scores: np.ndarray) -> np.ndarray:
    """Scores divided by the best of them (all zeros when the best is not positive)."""
    best = scores.max(initial=0.0)
    return scores / best if best > 0 else np.zeros_like(scores)


def select(rule: str, graspability: np.ndarray, p_not_tangled: np.ndarray,
           rng: np.random.Generator | None = None) -> Selection:
    """The candidate ``rule`` picks and every candidate's combined score.

    ``graspability`` (N,) are non-negative index scores, ``p_not_tangled`` (N,) the CNN's
    probabilities; ``rng`` is required by ``random`` only.
    """
    check_rule(rule)
    g = np.asarray(graspability, dtype=np.float64)
    p = np.asarray(p_not_tangled, dtype=np.float64)
    if g.ndim != 1 or g.shape != p.shape:
        raise ValueError(f"graspability {g.shape} and P(not tangled) {p.shape} must be two "
                         "equally long vectors")
    if not (np.isfinite(g).all() and np.isfinite(p).all()) or (g < 0).any():
        raise ValueError("graspability must be finite and non-negative, probabilities finite")
    if len(g) == 0:
        return Selection(None, g)
    if rule == "random":
        if rng is None:
            raise ValueError("the random rule needs a seeded rng")
        return Selection(int(rng.integers(len(g))), np.full(len(g), 1 / len(g)))
    if rule == "graspability":
        scores, other = g, p
    elif rule == "cnn":
        scores, other = p, g
    else:
        g_norm = normalised_graspability(g)
        total = g_norm + p
        scores = np.divide(2 * g_norm * p, total, out=np.zeros_like(total), where=total > 0)
        other = g
    # lexsort's last key is the primary one; the largest entry comes last.
    order = np.lexsort((-np.arange(len(g)), other, scores))
    return Selection(int(order[-1]), scores)
