"""Joint-space trajectories within velocity and acceleration limits, and their collision checks.

Each leg is a straight line in joint space run with a synchronised trapezoidal speed profile
(all joints start and stop together, rest to rest). The limits then hold exactly and
analytically, with no optimisation and no between-sample violations; legs are short enough
that stopping between them costs little (a stop from the slow Cartesian speeds near the pile
takes milliseconds). A leg may also be capped in tool-centre speed, for slow moves near the
pile. Polynomials are cubic Hermite pieces, which reproduce the profile's quadratic pieces
exactly.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

MIN_DURATION = 1e-3
"""Duration of a move that goes nowhere, s (trajectories need increasing break times)."""


def _profile(speed: float, acceleration: float) -> tuple[list[float], list[float], list[float]]:
    """Breaks, path parameter s and its rate for a rest-to-rest move of s from 0 to 1."""
    if speed * speed / acceleration <= 1.0:  # reaches full speed: trapezoid
        t_ramp = speed / acceleration
        s_ramp = 0.5 * speed * t_ramp
        t_cruise = (1.0 - 2.0 * s_ramp) / speed
        return ([0.0, t_ramp, t_ramp + t_cruise, 2 * t_ramp + t_cruise],
                [0.0, s_ramp, 1.0 - s_ramp, 1.0], [0.0, speed, speed, 0.0])
    t_ramp = math.sqrt(1.0 / acceleration)  # triangle
    return [0.0, t_ramp, 2 * t_ramp], [0.0, 0.5, 1.0], [0.0, acceleration * t_ramp, 0.0]


def rest_to_rest(q0: np.ndarray, q1: np.ndarray, velocity: np.ndarray | float,
                 acceleration: np.ndarray | float, path_length: float = 0.0,
                 max_path_speed: float = math.inf) -> PiecewisePolynomial:
    """A straight move from ``q0`` to ``q1`` starting and ending at rest.

    ``velocity`` and ``acceleration`` bound each coordinate (scalars or per coordinate);
    ``max_path_speed`` bounds the speed along a path of ``path_length`` metres that the line
    maps to, taken as traversed uniformly in s (e.g. the tool centre on a Cartesian leg).
    A zero move is a hold of :data:`MIN_DURATION`.
    """
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    delta = q1 - q0
    velocity = np.broadcast_to(np.asarray(velocity, float), delta.shape)
    acceleration = np.broadcast_to(np.asarray(acceleration, float), delta.shape)
    moving = np.abs(delta) > 1e-12
    if not moving.any():
        return hold(q0, MIN_DURATION)
    # ds/dt and d2s/dt2 that keep every coordinate (and the path) within its limits.
    speed = float(np.min(velocity[moving] / np.abs(delta[moving])))
    if path_length > 0:
        speed = min(speed, max_path_speed / path_length)
    accel = float(np.min(acceleration[moving] / np.abs(delta[moving])))
    breaks, s, s_dot = _profile(speed, accel)
    samples = np.outer(delta, s) + q0[:, None]
    rates = np.outer(delta, s_dot)
    return PiecewisePolynomial.CubicHermite(breaks, samples, rates)


def hold(q: np.ndarray, duration: float) -> PiecewisePolynomial:
    """Stay at ``q`` for ``duration`` seconds."""
    q = np.asarray(q, float).reshape(-1, 1)
    return PiecewisePolynomial.ZeroOrderHold([0.0, duration], np.hstack([q, q]))


def chain(legs: Sequence[PiecewisePolynomial]) -> PiecewisePolynomial:
    """The legs one after another, starting at t = 0."""
    result = legs[0].Clone()
    result.shiftRight(-result.start_time())
    for leg in legs[1:]:
        leg = leg.Clone()
        leg.shiftRight(result.end_time() - leg.start_time())
        result.ConcatenateInTime(leg)
    return result


def line_samples(q0: np.ndarray, q1: np.ndarray, step: float) -> np.ndarray:
    """Points on the joint-space line from ``q0`` to ``q1``, at most ``step`` apart in every
    coordinate, ends included, (N, n)."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    count = max(1, math.ceil(float(np.max(np.abs(q1 - q0), initial=0.0)) / step))
    s = np.linspace(0.0, 1.0, count + 1)[:, None]
    return q0 + s * (q1 - q0)


def first_violation(path: Sequence[np.ndarray], step: float,
                    is_clear: Callable[[np.ndarray], bool]) -> np.ndarray | None:
    """The first sampled configuration along the polyline ``path`` that ``is_clear`` rejects,
    or ``None`` when every sample passes."""
    for q0, q1 in itertools.pairwise(path):
        for q in line_samples(q0, q1, step):
            if not is_clear(q):
                return q
    return None
