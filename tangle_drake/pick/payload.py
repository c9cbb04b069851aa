"""Weighing what came up: the payload estimator, from the wrist force/torque sensor alone.

The pick planner says when (``request``): ``TARE`` with the open gripper at the pre-grasp,
and ``WEIGH`` at the top of the lift (each request anew, so a second weighing starts afresh).
The estimator takes samples only while the carrier is stopped, and only once it has been
stopped for ``settle_time`` (a load swings on after the arm stops); any motion starts the
window again, so nothing is weighed while the arm accelerates.
The estimate is the mean vertical support force over the window minus the tare, in part
weights. It reads no ``sim.`` port: on hardware it is the same system.

Confidence: the estimate's distance to the nearest whole number of parts and its standard
error, and a load that swings (samples spread far beyond the sensor's noise) is flagged. A
count is acted on only when it is near a whole number, the load is still, and it is almost
surely right (``min_confidence``); so that a noisier sensor still gets there, a tare and a
weighing go on past ``window`` until the count's standard error is below ``target_std`` (or
``max_window``): at the default sensor noise they end at ``window``.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, replace
from statistics import NormalDist

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

G = 9.81
"""Standard gravity, m/s² (the plant's)."""
_FZ = 2
"""Index of the vertical force in ``[fx, fy, fz, tx, ty, tz]``."""


class PayloadPhase(enum.Enum):
    """What the planner asks of the estimator."""

    IDLE = "idle"
    TARE = "tare"
    """The gripper holds nothing: measure what the sensor reads then."""
    WEIGH = "weigh"
    """The gripper holds what came up: weigh it."""


@dataclass(frozen=True)
class PayloadRequest:
    """The planner's request: what to do, and which request this is (a new ``serial`` starts
    a new tare or weighing even in the same phase)."""

    phase: PayloadPhase = PayloadPhase.IDLE
    serial: int = 0


@dataclass(frozen=True)
class PayloadSettings:
    """How the estimator weighs (SI units)."""

    part_mass: float
    """One part's mass, kg (the scenario's part, or the weighed one)."""
    sensor_noise: float = 0.1
    """Standard deviation of one force sample, N (the sensor's)."""
    settle_time: float = 0.1
    """The carrier must have been stopped this long before samples count, s."""
    window: float = 0.2
    """Seconds of samples in a weighing (and at least this much for a tare)."""
    period: float = 0.01
    """Seconds between looks at the sensor (its sample period)."""
    stopped_speed: float = 0.005
    """The carrier counts as stopped while every joint moves slower than this (rad/s, m/s)."""
    swing_factor: float = 3.0
    """A load whose samples spread more than this many times the sensor's noise swings."""
    max_fraction: float = 0.25
    """An estimate farther than this from a whole number of parts is not trusted."""
    min_confidence: float = 0.99
    """A count less likely than this to be right is not trusted (at five times the default
    sensor noise, counts near a whole number were often the wrong one: several parts
    delivered as one)."""
    target_std: float = 0.12
    """A weighing goes on past ``window`` until the count's standard error is below this,
    parts (a tare, until its share is below this over the square root of two)..."""
    max_window: float = 1.0
    """...or for at most this long, s (within the planner's waits for a tare and a
    weighing)."""

    def __post_init__(self) -> None:
        for name in ("part_mass", "sensor_noise", "settle_time", "window", "period",
                     "stopped_speed", "swing_factor", "target_std"):
            if not getattr(self, name) > 0:
                raise ValueError(f"PayloadSettings.{name} must be positive")
        if not 0 < self.max_fraction <= 0.5:
            raise ValueError("PayloadSettings.max_fraction must be in (0, 0.5]")
        if not 0.5 <= self.min_confidence < 1:
            raise ValueError("PayloadSettings.min_confidence must be in [0.5, 1)")
        if not self.max_window >= self.window:
            raise ValueError("PayloadSettings.max_window must be at least window")


@dataclass(frozen=True)
class PayloadEstimate:
    """The last weighing."""

    ready: bool = False
    """A weighing has finished since the last ``WEIGH`` began."""
    parts: float = math.nan
    """What the load weighs, in parts (a real number)."""
    count: int | None = None
    """``parts`` rounded; ``None`` before a weighing."""
    std: float = math.nan
    """Standard error of ``parts``."""
    confidence: float = 0.0
    """The chance that ``count`` is right, from the estimate's distance to it and its
    standard error: near 1 on a whole number, 0.5 half-way between two."""
    swinging: bool = False
    """The samples spread far beyond the sensor's noise: the load was still moving."""
    trusted: bool = False
    """Near a whole number, not swinging, almost surely right: the count may be acted on."""
    samples: int = 0
    support: float = math.nan
    """The weighing's mean vertical support force, N (the put-back's force limit is below
    it)."""
    part_weight: float = math.nan
    """One part's weight, N."""
    tared: bool = False
    """A full window of tare samples has been taken since the last ``TARE`` request."""


@dataclass(frozen=True)
class _State:
    request: PayloadRequest = PayloadRequest()
    stopped_since: float | None = None
    tare: float | None = None
    tare_samples: int = 0
    tared: bool = False
    window: tuple[float, ...] = ()
    estimate: PayloadEstimate = field(default_factory=PayloadEstimate)


def estimate_from(samples: np.ndarray, tare: float, settings: PayloadSettings,
                  tare_samples: int | None = None) -> PayloadEstimate:
    """The estimate of a window of vertical support forces (N), less ``tare`` (the mean of
    ``tare_samples`` samples, as many as ``samples`` by default: its error counts too)."""
    weight = settings.part_mass * G
    parts = (float(np.mean(samples)) - tare) / weight
    spread = float(np.std(samples))
    tare_samples = tare_samples or len(samples)
    std = (max(spread, settings.sensor_noise) / weight
           * math.sqrt(1 / len(samples) + 1 / tare_samples))
    count = max(round(parts), 0)
    fraction = abs(parts - count)
    # The chance that the true load rounds to ``count``, the estimate being Gaussian.
    confidence = 0.5 * (math.erf((0.5 - fraction) / (std * math.sqrt(2)))
                        + math.erf((0.5 + fraction) / (std * math.sqrt(2))))
    swinging = spread > settings.swing_factor * settings.sensor_noise
    trusted = (fraction <= settings.max_fraction and not swinging
               and confidence >= settings.min_confidence)
    return PayloadEstimate(True, parts, count, std, confidence, swinging, trusted,
                           len(samples), float(np.mean(samples)), weight)


def best_count_std(settings: PayloadSettings, drift: float, interval: float) -> float:
    """The standard error of a count at best, in parts: the sensor's noise averaged over
    ``max_window`` for the tare and for the weighing, and its bias's random walk (``drift``,
    N per root second) over the ``interval`` between them, s (taring does not remove that)."""
    samples = max(1, round(settings.max_window / settings.period))
    weight = settings.part_mass * G
    noise = settings.sensor_noise * math.sqrt(2 / samples)
    return math.hypot(noise, drift * math.sqrt(interval)) / weight


def surest_count_std(settings: PayloadSettings) -> float:
    """The largest standard error at which a count on a whole number is still trusted
    (its confidence reaches ``min_confidence``), parts."""
    return 0.5 / NormalDist().inv_cdf(0.5 + settings.min_confidence / 2)


def tare_is_precise(samples: int, settings: PayloadSettings) -> bool:
    """Whether a tare of ``samples`` samples leaves room in ``target_std`` for the weighing:
    its share of a count's standard error is below ``target_std`` over the root of two."""
    share = settings.sensor_noise / (settings.part_mass * G) / math.sqrt(max(samples, 1))
    return share <= settings.target_std / math.sqrt(2)


class PayloadEstimator(LeafSystem):
    """Counts the parts the gripper holds from the wrist sensor (see the module docstring).

    Inputs: ``force_torque`` (the station's ``wrist.force_torque``), ``carrier_state`` (the
    carrier's ``state_measured``: positions then velocities), ``request`` (a
    :class:`PayloadRequest`). Output ``payload`` (a :class:`PayloadEstimate`).
    """

    def __init__(self, settings: PayloadSettings, carrier_state_size: int) -> None:
        super().__init__()
        self._settings = settings
        self._samples = max(1, round(settings.window / settings.period))
        self._max_samples = max(self._samples, round(settings.max_window / settings.period))
        # A tare is a rolling window: of ``window`` where that is precise enough (the default
        # sensor), else as long as the carrier stands still, up to ``max_window``.
        self._tare_samples = self._samples if tare_is_precise(self._samples, settings) else \
            self._max_samples
        self._force = self.DeclareVectorInputPort("force_torque", 6)
        self._carrier = self.DeclareVectorInputPort("carrier_state", carrier_state_size)
        self._request = self.DeclareAbstractInputPort("request",
                                                      AbstractValue.Make(PayloadRequest()))
        self._state = self.DeclareAbstractState(AbstractValue.Make(_State()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(settings.period, 0.0, self._update)
        self.DeclareAbstractOutputPort(
            "payload", lambda: AbstractValue.Make(PayloadEstimate()),
            lambda context, value: value.set_value(replace(
                self._get(context).estimate, tared=self._get(context).tared)),
            {self.abstract_state_ticket(self._state)})

    @property
    def settings(self) -> PayloadSettings:
        return self._settings

    def _get(self, context: Context) -> _State:
        return context.get_abstract_state(self._state).get_value()

    def _update(self, context: Context, state: State) -> None:
        old = self._get(context)
        new = self._next(context, old)
        if new != old:
            state.get_mutable_abstract_state(self._state).set_value(new)

    def _next(self, context: Context, s: _State) -> _State:
        t = context.get_time()
        request = self._request.Eval(context) if self._request.HasValue(context) \
            else PayloadRequest()
        phase = request.phase
        if request != s.request:  # a new tare or weighing starts from nothing
            s = replace(s, request=request, window=())
            if phase is PayloadPhase.TARE:
                s = replace(s, tare=None, tared=False)
            if phase is PayloadPhase.WEIGH:
                s = replace(s, estimate=PayloadEstimate())
        if phase is PayloadPhase.IDLE:
            return s
        state = self._carrier.Eval(context)
        speed = float(np.max(np.abs(state[len(state) // 2:]), initial=0.0))
        if speed > self._settings.stopped_speed:
            return replace(s, stopped_since=None, window=())
        since = t if s.stopped_since is None else s.stopped_since
        s = replace(s, stopped_since=since)
        if t - since < self._settings.settle_time - 1e-9:
            return s
        fz = float(self._force.Eval(context)[_FZ])
        tare = phase is PayloadPhase.TARE
        window = (*s.window, fz)[-(self._tare_samples if tare else self._max_samples):]
        s = replace(s, window=window)
        n, settings = len(window), self._settings
        if tare:
            return replace(s, tare=float(np.mean(window)), tare_samples=n,
                           tared=n >= self._samples and (tare_is_precise(n, settings)
                                                         or n >= self._max_samples))
        if n >= self._samples and s.tare is not None and not s.estimate.ready:
            estimate = estimate_from(np.array(window), s.tare, settings, s.tare_samples)
            if estimate.std <= settings.target_std or estimate.swinging or \
                    n >= self._max_samples:
                return replace(s, estimate=estimate)
        return s
