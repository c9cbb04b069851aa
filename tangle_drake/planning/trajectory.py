"""Joint-space trajectories within velocity and acceleration limits, and their collision checks.

A leg between two configurations is a straight line in joint space run with a synchronised
trapezoidal speed profile (all joints start and stop together, rest to rest): the limits hold
exactly and analytically, with no optimisation. A leg through several waypoints (a Cartesian
line split for straightness) does not stop at them, which would shake a held part: it follows
a C2 cubic spline through them with one trapezoidal profile of its path parameter, slowed
until the spline's slopes and curvatures keep every joint within its limits. A leg may also be
capped in path speed (the tool centre's, for slow moves near the pile). Polynomials are cubic
Hermite pieces: exact for the straight legs' quadratic pieces, a fine sampling of the others.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

MIN_DURATION = 1e-3
"""Duration of a move that goes nowhere, s (trajectories need increasing break times)."""
_SPLINE_SAMPLES = 201
"""Points at which a spline's slopes and curvatures are bounded."""
_SAMPLE_PERIOD = 0.01
"""Spacing of the Hermite samples of a move through waypoints, s."""


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


def through_waypoints(waypoints: Sequence[np.ndarray], velocity: np.ndarray | float,
                      acceleration: np.ndarray | float, path_length: float = 0.0,
                      max_path_speed: float = math.inf) -> PiecewisePolynomial:
    """One rest-to-rest move through ``waypoints`` (at least two) without stopping at them.

    The path is a C2 cubic spline q(s) through the waypoints, s in [0, 1] spaced by their
    joint-space distances; s(t) is a trapezoidal profile whose top speed and acceleration
    keep |q'(s) s'| and |q''(s) s'^2 + q'(s) s''| within the limits, with a margin for the
    sampling: each term gets at most half the acceleration limit.
    """
    points = [np.asarray(q, float) for q in waypoints]
    if len(points) == 2:
        return rest_to_rest(points[0], points[1], velocity, acceleration, path_length,
                            max_path_speed)
    samples = np.column_stack(points)
    gaps = np.linalg.norm(np.diff(samples, axis=1), axis=0)
    breaks = np.concatenate([[0.0], np.cumsum(gaps)]) / max(gaps.sum(), 1e-12)
    slope_start = (samples[:, 1] - samples[:, 0]) / breaks[1]
    slope_end = (samples[:, -1] - samples[:, -2]) / (1.0 - breaks[-2])
    path = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(
        breaks, samples, slope_start.reshape(-1, 1), slope_end.reshape(-1, 1))
    grid = np.linspace(0.0, 1.0, _SPLINE_SAMPLES)
    path_dot = path.derivative(1)
    slope = np.max(np.abs(path_dot.vector_values(grid)), axis=1)
    curvature = np.max(np.abs(path.derivative(2).vector_values(grid)), axis=1)
    n = len(slope)
    velocity = np.broadcast_to(np.asarray(velocity, float), (n,))
    acceleration = np.broadcast_to(np.asarray(acceleration, float), (n,))
    speed = float(np.min(velocity / np.maximum(slope, 1e-12)))
    speed = min(speed, float(np.min(np.sqrt(acceleration / 2 / np.maximum(curvature, 1e-12)))))
    if path_length > 0:
        speed = min(speed, max_path_speed / path_length)
    accel = float(np.min(acceleration / 2 / np.maximum(slope, 1e-12)))
    kinks, s, s_dot = _profile(speed, accel)
    profile = PiecewisePolynomial.CubicHermite(kinks, np.array([s]), np.array([s_dot]))
    # The profile's breaks (where s'' jumps) and a fine grid, less grid points next to a break.
    grid = np.linspace(0.0, kinks[-1], max(2, math.ceil(kinks[-1] / _SAMPLE_PERIOD) + 1))
    grid = grid[np.min(np.abs(grid[:, None] - np.array(kinks)[None, :]), axis=1) > 1e-6]
    times = np.sort(np.concatenate([kinks, grid]))
    s_of_t = np.clip(profile.vector_values(times)[0], 0.0, 1.0)
    s_dot = profile.derivative(1).vector_values(times)[0]
    q = path.vector_values(s_of_t)
    q_dot = path_dot.vector_values(s_of_t) * s_dot
    return PiecewisePolynomial.CubicHermite(times, q, q_dot)


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
