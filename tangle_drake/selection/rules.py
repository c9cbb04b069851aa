"""Which grasp candidate to pick: the paper's rule and the baselines, the one place for both.

The rules (registered in :mod:`.registry`), over the candidates of one image (graspability's
top-k, best first):

- ``random``: one of the first :data:`RANDOM_TOP_K` candidates, drawn from the seed and the
  candidates' poses (the same draw however often it is asked for; a benchmark baseline that
  knows nothing but where a grasp is possible); its "combined score" is each candidate's
  chance of being drawn;
- ``graspability``: the highest graspability score (the method without the CNN);
- ``cnn``: the highest P(not tangled);
- ``success-cnn`` (the seed's second baseline, Matsumura et al. 2018): the highest P(success)
  from a success/failure CNN trained on physical picks
  (:mod:`tangle_drake.tangle_cnn.objectives`); it arrives where the others' P(not tangled)
  does (a pick-outcome model's P(one part) serves it too);
- ``success-harmonic`` (beyond the paper): the harmonic mean of the normalised graspability
  and P(exactly one part) from a success or pick-outcome model: the paper's rule with the
  physical gripper's outcomes in place of the tangle label;
- ``harmonic`` (the paper): the highest harmonic mean ``2 g p / (g + p)`` of the normalised
  graspability ``g`` and ``p`` = P(not tangled). Graspability is normalised by the best score
  among the image's candidates, ``g = score / max(score)``, so the best candidate has ``g = 1``
  and both terms lie in [0, 1] whatever the index's absolute scale. A zero in either term
  gives 0 (a grasp that cannot close or surely tangles is never preferred); all-zero scores
  give ``g = 0`` for all.
- ``emap`` (Zhang et al. 2021, training-free): the highest ``g (1 - e)``, ``e`` the
  entanglement map at the candidate (:mod:`tangle_drake.entanglement`, 1 at the most
  entangled place in view): graspability's candidates re-ranked by low entanglement;
- ``emap-harmonic``: the highest harmonic mean ``3 / (1/g + 1/p + 1/(1 - e))`` of the three
  (0 when any is 0).

:func:`rank` orders every candidate, best first, which is the order the planner tries them
in: by the rule's score; ties go to the candidate that is better on the other term
(P(not tangled) for ``graspability``, where known, graspability for the CNN rules),
then to the earlier one. After ``random``'s draw come the others in graspability's order.
``cnn``, ``harmonic`` and ``emap-harmonic`` need the tangle CNN (:data:`MODEL_RULES`), the
``emap`` rules the entanglement map (:data:`EMAP_RULES`). Numpy only.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.selection.registry import EMAP_RULES, MODEL_RULES, RULES
from tangle_drake.tangle_cnn.objectives import rule_objective

RANDOM_TOP_K = 5
"""``random`` draws among this many of graspability's best candidates."""


class Ranking(NamedTuple):
    order: np.ndarray
    """Candidate indices, best first (all of them; empty without candidates)."""
    scores: np.ndarray
    """Each candidate's combined score under the rule, (N,) float64, in candidate order."""


class ScoredCandidate(NamedTuple):
    """A candidate with what the selection made of it (the planner reads the three fields)."""

    candidate: Any
    p_model: float | None
    """The model's probability of its good outcome (:attr:`p_model_name`); ``None`` where no
    model ran."""
    score: float
    """The rule's combined score."""
    p_model_name: str | None = None
    """What ``p_model`` is the probability of, for people: ``P(not tangled)`` from a tangle
    CNN, ``P(success)`` or ``P(one part)`` from a pick model."""


def check_rule(rule: str) -> str:
    if rule not in RULES:
        raise TangleDrakeError(f"unknown selection rule {rule!r}; choose one of "
                               f"{', '.join(RULES)}")
    return rule


def needs_model(rule: str) -> bool:
    """Whether ``rule`` needs the tangle CNN's P(not tangled)."""
    return check_rule(rule) in MODEL_RULES


def needs_emap(rule: str) -> bool:
    """Whether ``rule`` needs each candidate's entanglement."""
    return check_rule(rule) in EMAP_RULES


def normalised_graspability(scores: np.ndarray) -> np.ndarray:
    """Scores divided by the best of them (all zeros when the best is not positive)."""
    best = scores.max(initial=0.0)
    return scores / best if best > 0 else np.zeros_like(scores)


def random_draw(poses: np.ndarray, seed: int) -> int | None:
    """The index ``random`` draws: one of the first :data:`RANDOM_TOP_K` rows of ``poses``
    ((N, 3): u, v, angle of each candidate), from ``seed`` and those rows."""
    top = np.ascontiguousarray(np.asarray(poses, dtype=np.float64)[:RANDOM_TOP_K])
    if len(top) == 0:
        return None
    rng = np.random.default_rng((seed, zlib.crc32(top.tobytes())))
    return int(rng.integers(len(top)))


def rank(rule: str, graspability: np.ndarray, p_model: np.ndarray | None = None,
         poses: np.ndarray | None = None, seed: int = 0,
         entanglement: np.ndarray | None = None) -> Ranking:
    """Every candidate in the order ``rule`` prefers them, and their combined scores.

    ``graspability`` (N,) are non-negative index scores in the candidates' order (best
    first), ``p_model`` (N,) the model's probabilities (``None`` without one: only
    ``random``, ``graspability`` and ``emap`` then), ``poses`` (N, 3) the candidates' u, v and
    angle, ``seed`` the draw of ``random`` and ``entanglement`` (N,) the map's values in
    [0, 1] at the candidates (the ``emap`` rules only).
    """
    check_rule(rule)
    g = np.asarray(graspability, dtype=np.float64)
    if p_model is None:
        if needs_model(rule):
            raise ValueError(f"the {rule} rule needs {rule_objective(rule).probability}")
        p = np.zeros_like(g)
    else:
        p = np.asarray(p_model, dtype=np.float64)
    if g.ndim != 1 or g.shape != p.shape:
        raise ValueError(f"graspability {g.shape} and the model's {p.shape} must be two "
                         "equally long vectors")
    if not (np.isfinite(g).all() and np.isfinite(p).all()) or (g < 0).any():
        raise ValueError("graspability must be finite and non-negative, probabilities finite")
    if rule == "random":
        if poses is None or len(poses) != len(g):
            raise ValueError("the random rule needs the candidates' poses")
        return _random(g, p, np.asarray(poses), seed)
    if rule == "graspability":
        scores, other = g, p
    elif rule in ("cnn", "success-cnn"):
        scores, other = p, g
    elif rule in ("harmonic", "success-harmonic"):
        scores, other = harmonic_mean(normalised_graspability(g), p), g
    else:
        if entanglement is None or np.shape(entanglement) != g.shape:
            raise ValueError(f"the {rule} rule needs each candidate's entanglement")
        calm = 1.0 - np.clip(np.asarray(entanglement, dtype=np.float64), 0.0, 1.0)
        g_norm = normalised_graspability(g)
        scores = g_norm * calm if rule == "emap" else harmonic_mean(g_norm, p, calm)
        other = g
    return Ranking(_order(scores, other), scores)


def harmonic_mean(*terms: np.ndarray) -> np.ndarray:
    """The element-wise harmonic mean of non-negative ``terms``; 0 where any is 0.

    As ``n prod(x) / sum_j prod_{i != j}(x_i)``, which for two terms is the paper's
    ``2 g p / (g + p)`` to the last bit and needs no division by a zero term.
    """
    stacked = np.stack(terms)
    others = sum(np.delete(stacked, j, axis=0).prod(axis=0) for j in range(len(terms)))
    return np.divide(len(terms) * stacked.prod(axis=0), others, out=np.zeros_like(others),
                     where=others > 0)


def _order(scores: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Best first: by score, then the other term, then the earlier index."""
    # lexsort's last key is the primary one; the largest entry comes last.
    return np.lexsort((-np.arange(len(scores)), other, scores))[::-1].copy()


def _random(g: np.ndarray, p: np.ndarray, poses: np.ndarray, seed: int) -> Ranking:
    drawn = random_draw(poses, seed)
    scores = np.zeros_like(g)
    scores[:RANDOM_TOP_K] = 1.0 / max(min(len(g), RANDOM_TOP_K), 1)
    rest = [int(i) for i in _order(g, p) if i != drawn]
    order = np.array(([] if drawn is None else [drawn]) + rest, dtype=np.int64)
    return Ranking(order, scores)


def rank_candidates(rule: str, candidates: Sequence[Any],
                    p_model: np.ndarray | None = None,
                    seed: int = 0, entanglement: np.ndarray | None = None,
                    p_model_name: str | None = None) -> list[ScoredCandidate]:
    """``candidates`` (with ``score``, ``u``, ``v``, ``angle_deg``) as :func:`rank` orders
    them, best first, each with the model's probability (named ``p_model_name``) and the
    combined score."""
    g = np.array([c.score for c in candidates], dtype=np.float64)
    poses = np.array([(c.u, c.v, c.angle_deg) for c in candidates], dtype=np.float64)
    ranking = rank(rule, g, p_model, poses.reshape(len(candidates), 3), seed,
                   entanglement)
    return [ScoredCandidate(candidates[i],
                            None if p_model is None else float(p_model[i]),
                            float(ranking.scores[i]),
                            None if p_model is None else p_model_name) for i in ranking.order]
