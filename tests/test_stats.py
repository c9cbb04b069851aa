"""The benchmark's confidence intervals against published values."""

import numpy as np
import pytest

from tangle_drake.common.stats import detectable_difference, paired_difference, wilson


@pytest.mark.parametrize(("successes", "n", "lower", "upper"), [
    # Newcombe (1998), "Two-sided confidence intervals for the single proportion", Table II,
    # method 3 (score interval without continuity correction).
    (81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611),
    (1, 29, 0.0061, 0.1718),
    # Fagerland, Lydersen & Laake, Statistical Analysis of Contingency Tables, ch. 2.
    (13, 16, 0.5699, 0.9341),
])
def test_wilson_interval_matches_published_values(successes, n, lower, upper):
    low, high = wilson(successes, n)
    assert low == pytest.approx(lower, abs=5e-5)
    assert high == pytest.approx(upper, abs=5e-5)


def test_wilson_interval_holds_its_rate_even_at_all_or_nothing():
    # 10 of 10's upper end computed to 1 - 1e-16, and the report's error bars went negative.
    for n in range(1, 201):
        for successes in (0, 1, n - 1, n):
            low, high = wilson(successes, n)
            assert 0.0 <= low <= successes / n <= high <= 1.0
    assert wilson(10, 10)[1] == 1.0 and wilson(0, 10)[0] == 0.0


def test_wilson_interval_of_nothing_is_everything_and_bad_counts_are_refused():
    assert wilson(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        wilson(3, 2)


def paired(both: int, a_only: int, b_only: int, neither: int):
    a = [True] * both + [True] * a_only + [False] * b_only + [False] * neither
    b = [True] * both + [False] * a_only + [True] * b_only + [False] * neither
    return paired_difference(a, b)


def test_paired_difference_matches_newcombes_square_and_add_interval():
    # Fagerland et al., ch. 8: complete response before and after consolidation therapy
    # (Cavo et al. 2012), table [[59, 6], [16, 80]]: -0.0621 (95 % CI -0.1186 to -0.0046);
    # the exact conditional McNemar test gives P = 0.0525.
    result = paired(59, 6, 16, 80)
    assert result.n == 161
    assert result.difference == pytest.approx(-0.0621, abs=5e-5)
    assert result.lower == pytest.approx(-0.1186, abs=5e-5)
    assert result.upper == pytest.approx(-0.0046, abs=5e-5)
    assert (result.a_only, result.b_only) == (6, 16)
    assert result.p_value == pytest.approx(0.0525, abs=5e-5)


def test_mcnemar_is_the_exact_binomial_test_of_the_discordant_trials():
    # 13 of 16 discordant trials one way: the exact binomial test's P = 0.02127 (Fagerland
    # et al., ch. 2); the trials both methods got right or wrong do not count.
    assert paired(40, 13, 3, 7).p_value == pytest.approx(0.02127, abs=5e-6)


def test_paired_difference_of_identical_methods_is_zero_and_symmetric():
    same = paired(30, 0, 0, 20)
    assert same.difference == 0 and same.p_value == 1.0
    assert same.lower < 0 < same.upper
    ab, ba = paired(10, 7, 2, 5), paired(10, 2, 7, 5)
    assert ab.difference == pytest.approx(-ba.difference)
    assert (ab.lower, ab.upper) == pytest.approx((-ba.upper, -ba.lower))
    assert paired_difference([], []).n == 0
    with pytest.raises(ValueError):
        paired_difference([True], [])


def test_the_detectable_difference_is_found_four_times_in_five():
    # Cavo et al.'s table: 22 of 161 trials discordant: 2.80 * sqrt(0.1366 / 161) = 8.2 pts.
    assert paired(59, 6, 16, 80).detectable == pytest.approx(0.0816, abs=5e-4)
    n, split = 200, 0.2
    shift = detectable_difference(round(split * n), n)
    rng = np.random.default_rng(0)
    # Trials where A alone succeeds, B alone, or neither split them, the rates differing
    # by the detectable difference: McNemar's test at the 5 % level finds it ~80 % of runs.
    draws = rng.multinomial(n, [(split + shift) / 2, (split - shift) / 2, 1 - split], 4000)
    a_only, b_only = draws[:, 0], draws[:, 1]
    found = np.abs(a_only - b_only) / np.sqrt(np.maximum(a_only + b_only, 1)) > 1.96
    assert found.mean() == pytest.approx(0.8, abs=0.04)
    assert paired(30, 0, 0, 20).detectable > 0  # never split: still no proof of equality
    assert detectable_difference(0, 0) == 1.0
