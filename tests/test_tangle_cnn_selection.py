"""Selection rules on hand-made scores: graspability, cnn, harmonic, random; ties and zeros."""

import numpy as np
import pytest

from tangle_drake.errors import TangleDrakeError
from tangle_drake.tangle_cnn.selection import RULES, normalised_graspability, select

GRASPABILITY = np.array([0.8, 0.4, 0.2, 0.6])
P_NOT_TANGLED = np.array([0.1, 0.9, 0.95, 0.5])


def test_graspability_and_cnn_take_their_own_maximum():
    assert select("graspability", GRASPABILITY, P_NOT_TANGLED).index == 0
    assert select("cnn", GRASPABILITY, P_NOT_TANGLED).index == 2
    assert np.array_equal(select("cnn", GRASPABILITY, P_NOT_TANGLED).scores, P_NOT_TANGLED)


def test_harmonic_mean_of_normalised_graspability_and_p_not_tangled():
    selection = select("harmonic", GRASPABILITY, P_NOT_TANGLED)
    g = GRASPABILITY / 0.8
    assert np.allclose(selection.scores, 2 * g * P_NOT_TANGLED / (g + P_NOT_TANGLED))
    assert np.allclose(selection.scores, [0.1818, 0.6429, 0.3958, 0.6], atol=1e-4)
    assert selection.index == 1  # neither the most graspable (0) nor the surest (2)


def test_harmonic_is_zero_where_either_term_is_zero():
    selection = select("harmonic", np.array([0.0, 0.5, 0.3]), np.array([1.0, 0.0, 0.2]))
    assert selection.scores[0] == 0 and selection.scores[1] == 0
    assert selection.index == 2
    all_zero = select("harmonic", np.zeros(3), np.array([0.2, 0.9, 0.4]))
    assert np.array_equal(all_zero.scores, np.zeros(3))
    assert all_zero.index == 0  # a full tie, graspability tied too: the first candidate
    assert np.array_equal(normalised_graspability(np.zeros(2)), np.zeros(2))


def test_ties_go_to_the_better_other_term_then_the_earlier_candidate():
    g = np.array([0.5, 0.9, 0.9, 0.7])
    p = np.array([0.8, 0.3, 0.6, 0.8])
    assert select("graspability", g, p).index == 2  # g tie 1/2: higher p
    assert select("cnn", g, p).index == 3  # p tie 0/3: higher g
    assert select("cnn", np.array([0.5, 0.5]), np.array([0.7, 0.7])).index == 0
    same = select("harmonic", np.ones(3), np.full(3, 0.5))
    assert same.index == 0


def test_random_is_uniform_among_the_candidates_and_seeded():
    def draws(seed: int) -> list[int]:
        rng = np.random.default_rng(seed)
        return [select("random", GRASPABILITY, P_NOT_TANGLED, rng).index for _ in range(4000)]

    first = draws(7)
    assert first == draws(7)
    counts = np.bincount(first, minlength=4)
    assert counts.min() > 900 and counts.max() < 1100
    assert np.allclose(select("random", GRASPABILITY, P_NOT_TANGLED,
                              np.random.default_rng(0)).scores, 0.25)
    with pytest.raises(ValueError, match="rng"):
        select("random", GRASPABILITY, P_NOT_TANGLED)


@pytest.mark.parametrize("rule", RULES)
def test_no_candidates_select_nothing(rule):
    selection = select(rule, np.zeros(0), np.zeros(0), np.random.default_rng(0))
    assert selection.index is None and selection.scores.shape == (0,)


def test_bad_arguments():
    with pytest.raises(TangleDrakeError, match="unknown selection rule"):
        select("best", GRASPABILITY, P_NOT_TANGLED)
    with pytest.raises(ValueError, match="equally long"):
        select("cnn", GRASPABILITY, P_NOT_TANGLED[:2])
    with pytest.raises(ValueError, match="non-negative"):
        select("cnn", -GRASPABILITY, P_NOT_TANGLED)
