"""Selection rules on hand-made scores: graspability, cnn, harmonic, random; the order the
planner tries candidates in, ties and zeros; the same rules wherever they run."""

from types import SimpleNamespace

import numpy as np
import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.selection.rules import (
    MODEL_RULES,
    RANDOM_TOP_K,
    RULES,
    needs_model,
    normalised_graspability,
    random_draw,
    rank,
    rank_candidates,
)

GRASPABILITY = np.array([0.8, 0.4, 0.2, 0.6])
P_NOT_TANGLED = np.array([0.1, 0.9, 0.95, 0.5])


def poses(n: int) -> np.ndarray:
    return np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.zeros(n)])


def test_graspability_and_cnn_order_by_their_own_term():
    assert list(rank("graspability", GRASPABILITY, P_NOT_TANGLED).order) == [0, 3, 1, 2]
    cnn = rank("cnn", GRASPABILITY, P_NOT_TANGLED)
    assert list(cnn.order) == [2, 1, 3, 0]
    assert np.array_equal(cnn.scores, P_NOT_TANGLED)


def test_harmonic_mean_of_normalised_graspability_and_p_not_tangled():
    ranking = rank("harmonic", GRASPABILITY, P_NOT_TANGLED)
    g = GRASPABILITY / 0.8
    assert np.allclose(ranking.scores, 2 * g * P_NOT_TANGLED / (g + P_NOT_TANGLED))
    assert np.allclose(ranking.scores, [0.1818, 0.6429, 0.3958, 0.6], atol=1e-4)
    assert ranking.order[0] == 1  # neither the most graspable (0) nor the surest (2)
    assert list(ranking.order) == [1, 3, 2, 0]


def test_harmonic_is_zero_where_either_term_is_zero():
    ranking = rank("harmonic", np.array([0.0, 0.5, 0.3]), np.array([1.0, 0.0, 0.2]))
    assert ranking.scores[0] == 0 and ranking.scores[1] == 0
    assert list(ranking.order) == [2, 1, 0]  # the zero tie goes to the more graspable
    all_zero = rank("harmonic", np.zeros(3), np.array([0.2, 0.9, 0.4]))
    assert np.array_equal(all_zero.scores, np.zeros(3))
    assert list(all_zero.order) == [0, 1, 2]  # a full tie, graspability tied too: as given
    assert np.array_equal(normalised_graspability(np.zeros(2)), np.zeros(2))


def test_ties_go_to_the_better_other_term_then_the_earlier_candidate():
    g = np.array([0.5, 0.9, 0.9, 0.7])
    p = np.array([0.8, 0.3, 0.6, 0.8])
    assert list(rank("graspability", g, p).order) == [2, 1, 3, 0]  # g tie 1/2: higher p
    assert list(rank("graspability", g).order) == [1, 2, 3, 0]  # no CNN: the earlier
    assert list(rank("cnn", g, p).order) == [3, 0, 2, 1]  # p tie 0/3: higher g
    assert list(rank("cnn", np.array([0.5, 0.5]), np.array([0.7, 0.7])).order) == [0, 1]


def test_random_draws_among_the_top_five_from_the_seed_and_the_candidates():
    n = 10
    g = np.linspace(1.0, 0.1, n)
    draws = [rank("random", g, None, poses(n), seed).order[0] for seed in range(300)]
    counts = np.bincount(draws, minlength=n)
    assert set(np.flatnonzero(counts)) == set(range(RANDOM_TOP_K))
    assert counts[:RANDOM_TOP_K].min() > 40  # about 60 each: uniform
    # A pure function: another seed or other candidates draw anew; the same, the same.
    assert [random_draw(poses(n), s) for s in range(20)] == draws[:20]
    shifted = poses(n) + np.array([0.5, 0.0, 0.0])
    assert [random_draw(shifted, s) for s in range(20)] != draws[:20]
    # After the draw, graspability's order; each of the top five had a 1/5 chance.
    ranking = rank("random", g, None, poses(n), 0)
    assert list(ranking.order[1:]) == [i for i in range(n) if i != ranking.order[0]]
    assert np.allclose(ranking.scores, [0.2] * 5 + [0.0] * 5)
    assert random_draw(np.zeros((0, 3)), 0) is None


def test_only_the_cnn_rules_need_the_model():
    assert [rule for rule in RULES if needs_model(rule)] == list(MODEL_RULES) == [
        "cnn", "harmonic", "emap-harmonic", "success-cnn", "success-harmonic"]
    for rule in MODEL_RULES:
        with pytest.raises(ValueError, match="needs P"):
            rank(rule, GRASPABILITY)


def test_rank_candidates_orders_the_candidates_themselves():
    candidates = [SimpleNamespace(u=float(i), v=0.0, angle_deg=0.0, score=s)
                  for i, s in enumerate(GRASPABILITY)]
    scored = rank_candidates("harmonic", candidates, P_NOT_TANGLED)
    assert [s.candidate.u for s in scored] == [1.0, 3.0, 2.0, 0.0]
    assert scored[0].p_model == pytest.approx(0.9)
    assert [s.p_model for s in rank_candidates("graspability", candidates)] == [None] * 4


@pytest.mark.parametrize("rule", RULES)
def test_no_candidates_rank_nothing(rule):
    ranking = rank(rule, np.zeros(0), np.zeros(0), np.zeros((0, 3)), entanglement=np.zeros(0))
    assert ranking.order.shape == (0,) and ranking.scores.shape == (0,)
    assert rank_candidates(rule, [], np.zeros(0), entanglement=np.zeros(0)) == []


def test_the_emap_rules_prefer_calm_places_and_fuse_all_three_terms():
    entanglement = np.array([0.9, 0.0, 0.5, 1.0])
    emap = rank("emap", GRASPABILITY, entanglement=entanglement)
    g = GRASPABILITY / GRASPABILITY.max()
    np.testing.assert_allclose(emap.scores, g * (1 - entanglement))
    assert emap.order[-1] == 3  # the most entangled place in view scores 0
    fused = rank("emap-harmonic", GRASPABILITY, P_NOT_TANGLED, entanglement=entanglement)
    expected = 3 / (1 / g + 1 / P_NOT_TANGLED + 1 / np.maximum(1 - entanglement, 1e-300))
    expected[3] = 0.0
    np.testing.assert_allclose(fused.scores, expected)
    with pytest.raises(ValueError, match="entanglement"):
        rank("emap", GRASPABILITY)


def test_bad_arguments():
    with pytest.raises(TangleDrakeError, match="unknown selection rule"):
        rank("best", GRASPABILITY, P_NOT_TANGLED)
    with pytest.raises(ValueError, match="equally long"):
        rank("cnn", GRASPABILITY, P_NOT_TANGLED[:2])
    with pytest.raises(ValueError, match="non-negative"):
        rank("cnn", -GRASPABILITY, P_NOT_TANGLED)
    with pytest.raises(ValueError, match="finite"):
        rank("harmonic", GRASPABILITY, np.array([0.1, np.nan, 0.2, 0.3]))
    with pytest.raises(ValueError, match="poses"):
        rank("random", GRASPABILITY)
