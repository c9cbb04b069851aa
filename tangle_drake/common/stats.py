"""Confidence intervals for success rates, and for the difference of two methods on the
same trials.

- :func:`wilson`: the Wilson score interval of one proportion (Newcombe 1998a, method 3),
  good at small n and near 0 or 1, where the textbook Wald interval fails;
- :func:`paired_difference`: the difference of two success rates measured on the same
  trials, with Newcombe's (1998b, method 10) square-and-add interval from the two Wilson
  intervals and the correlation of the pairs, and the exact McNemar test on the discordant
  trials (one method succeeded, the other did not), and the smallest difference the trials
  could detect (:func:`detectable_difference`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from scipy.stats import binomtest, norm

CONFIDENCE = 0.95
POWER = 0.8
"""The chance of detecting a difference of :func:`detectable_difference`'s size."""


def _z(confidence: float) -> float:
    return float(norm.ppf(0.5 + confidence / 2))


def wilson(successes: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The Wilson score interval (lower, upper) of ``successes`` out of ``n``; (0, 1) for
    ``n = 0``, where nothing is known."""
    if not 0 <= successes <= n:
        raise ValueError(f"successes must lie in [0, n], got {successes} of {n}")
    if n == 0:
        return 0.0, 1.0
    z = _z(confidence)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # The interval holds p; rounding alone can put 10 of 10's upper end at 1 - 1e-16.
    return min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half))


@dataclass(frozen=True)
class PairedDifference:
    """Method A's success rate minus method B's, over the trials both ran."""

    n: int
    rate_a: float
    rate_b: float
    difference: float
    lower: float
    upper: float
    a_only: int
    """Trials where A succeeded and B did not."""
    b_only: int
    """Trials where B succeeded and A did not."""
    p_value: float
    """Exact two-sided McNemar test of A = B (the binomial test of the discordant trials)."""
    detectable: float
    """The smallest true difference these trials detect with :data:`POWER` at the interval's
    level (:func:`detectable_difference`)."""


def paired_difference(a: Sequence[bool], b: Sequence[bool],
                      confidence: float = CONFIDENCE) -> PairedDifference:
    """Newcombe's interval for ``mean(a) - mean(b)``, ``a[i]`` and ``b[i]`` the two methods'
    successes on trial ``i``."""
    if len(a) != len(b):
        raise ValueError(f"paired samples differ in length: {len(a)} and {len(b)}")
    n = len(a)
    both = sum(1 for x, y in zip(a, b, strict=True) if x and y)
    a_only = sum(1 for x, y in zip(a, b, strict=True) if x and not y)
    b_only = sum(1 for x, y in zip(a, b, strict=True) if y and not x)
    neither = n - both - a_only - b_only
    if n == 0:
        return PairedDifference(0, 0.0, 0.0, 0.0, -1.0, 1.0, 0, 0, 1.0, 1.0)
    p1, p2 = (both + a_only) / n, (both + b_only) / n
    l1, u1 = wilson(both + a_only, n, confidence)
    l2, u2 = wilson(both + b_only, n, confidence)
    phi = _phi(both, a_only, b_only, neither)
    difference = p1 - p2
    lower = difference - math.sqrt(max(0.0, (p1 - l1) ** 2 + (u2 - p2) ** 2
                                       - 2 * phi * (p1 - l1) * (u2 - p2)))
    upper = difference + math.sqrt(max(0.0, (p2 - l2) ** 2 + (u1 - p1) ** 2
                                       - 2 * phi * (p2 - l2) * (u1 - p1)))
    discordant = a_only + b_only
    p_value = binomtest(a_only, discordant).pvalue if discordant else 1.0
    return PairedDifference(n, p1, p2, difference, max(-1.0, lower), min(1.0, upper),
                            a_only, b_only, float(p_value),
                            detectable_difference(discordant, n, confidence))


def detectable_difference(discordant: int, n: int, confidence: float = CONFIDENCE,
                          power: float = POWER) -> float:
    """The smallest difference of two success rates that ``n`` paired trials detect with
    ``power``, when ``discordant`` of them split the methods: McNemar's normal approximation,
    ``(z_(1-alpha/2) + z_power) * sqrt(d / n)`` with ``d`` the discordant fraction (Connor
    1987). Methods that never split (``discordant`` 0) are taken to split once: no run shows
    that two methods can never differ. 1 for no trials."""
    if n == 0:
        return 1.0
    d = max(discordant, 1) / n
    return min(1.0, (_z(confidence) + float(norm.ppf(power))) * math.sqrt(d / n))


def _phi(both: int, a_only: int, b_only: int, neither: int) -> float:
    """The correlation of the pairs, with Newcombe's continuity correction of a positive one
    (``ad - bc`` less ``n / 2``, not below zero); 0 when a margin is empty."""
    margins = (both + a_only) * (b_only + neither) * (both + b_only) * (a_only + neither)
    if margins == 0:
        return 0.0
    n = both + a_only + b_only + neither
    cross = both * neither - a_only * b_only
    if cross > 0:
        cross = max(0.0, cross - n / 2)
    return cross / math.sqrt(margins)
