"""The payload estimator: counts parts from the wrist sensor's vertical force, only while the
carrier is stopped, with a confidence, and flags a swinging load."""

import math

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from tangle_drake.pick.payload import (
    G,
    PayloadEstimator,
    PayloadPhase,
    PayloadRequest,
    PayloadSettings,
    estimate_from,
)

PART = 0.0328  # kg, a U-hook
SETTINGS = PayloadSettings(part_mass=PART)
GRIPPER = 4.22  # N


class Scripted(LeafSystem):
    """A wrist sensor, a carrier's state and the planner's phase, as functions of time."""

    def __init__(self, force, speed, phase) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("force_torque", 6, lambda c, out: out.SetFromVector(
            [0, 0, force(c.get_time()), 0, 0, 0]), {self.time_ticket()})
        self.DeclareVectorOutputPort("carrier_state", 8, lambda c, out: out.SetFromVector(
            [0, 0, 0, 0, speed(c.get_time()), 0, 0, 0]), {self.time_ticket()})
        self.DeclareAbstractOutputPort(
            "request", lambda: AbstractValue.Make(PayloadRequest()),
            lambda c, v: v.set_value(PayloadRequest(
                phase(c.get_time()), int(phase(c.get_time()) is PayloadPhase.WEIGH))),
            {self.time_ticket()})


def run(force, speed=lambda t: 0.0, phase=None, until=2.0, settings=SETTINGS):
    """The estimate at ``until``; tare over [0, 0.5), weigh from 0.5 s on by default."""
    phase = phase or (lambda t: PayloadPhase.TARE if t < 0.5 else PayloadPhase.WEIGH)
    builder = DiagramBuilder()
    source = builder.AddSystem(Scripted(force, speed, phase))
    estimator = builder.AddSystem(PayloadEstimator(settings, 8))
    for port in ("force_torque", "carrier_state", "request"):
        builder.Connect(source.GetOutputPort(port), estimator.GetInputPort(port))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(until)
    context = estimator.GetMyContextFromRoot(simulator.get_context())
    return estimator.GetOutputPort("payload").Eval(context)


@pytest.mark.parametrize("parts", [0, 1, 2, 3])
def test_counts_the_parts_hanging_below_the_sensor(parts):
    rng = np.random.default_rng(parts)
    noise = 0.1 * rng.standard_normal(400)

    def force(t: float) -> float:
        load = GRIPPER + (parts * PART * G if t >= 0.5 else 0.0)
        return load + noise[round(t * 100) % 400]

    estimate = run(force)
    assert estimate.ready and estimate.count == parts and estimate.trusted
    assert estimate.parts == pytest.approx(parts, abs=0.25)
    # The standard error counts the tare's 20 samples as well as the weighing's.
    floor = SETTINGS.sensor_noise * math.sqrt(2 / 20) / (PART * G)
    assert estimate.samples == 20 and floor - 1e-12 <= estimate.std < 1.5 * floor


def test_no_estimate_while_the_carrier_moves_and_the_window_starts_again_when_it_stops():
    def force(t):
        return GRIPPER + (PART * G if t >= 0.5 else 0.0)

    def speed(t):
        return 0.2 if 0.5 <= t < 1.5 else 0.0  # still rising after the weighing was asked for

    assert not run(force, speed, until=1.5).ready
    assert not run(force, speed, until=1.65).ready  # 0.1 s settling + 0.2 s window not yet
    late = run(force, speed, until=1.95)
    assert late.ready and late.count == 1 and late.samples == 20


def test_a_swinging_load_is_flagged_and_not_trusted():
    def force(t):
        swing = 0.8 * math.sin(2 * math.pi * 3.0 * t) if t >= 0.5 else 0.0
        return GRIPPER + (PART * G if t >= 0.5 else 0.0) + swing

    estimate = run(force)
    assert estimate.ready and estimate.swinging and not estimate.trusted


def test_half_way_between_two_counts_is_low_confidence():
    estimate = estimate_from(np.full(20, 1.5 * PART * G), 0.0, SETTINGS)
    assert estimate.confidence == pytest.approx(0.5, abs=0.01) and not estimate.trusted
    sure = estimate_from(np.full(20, 2.0 * PART * G), 0.0, SETTINGS)
    assert sure.count == 2 and sure.confidence > 0.99 and sure.trusted


def test_a_noisy_sensor_weighs_longer_and_a_doubtful_count_is_not_trusted():
    noisy = PayloadSettings(part_mass=PART, sensor_noise=0.5)  # five times the default
    doubtful = estimate_from(np.full(20, 1.1 * PART * G), 0.0, noisy)
    assert doubtful.count == 1 and doubtful.confidence < noisy.min_confidence
    assert not doubtful.trusted  # near a whole number, but likely another one
    rng = np.random.default_rng(5)
    noise = 0.5 * rng.standard_normal(600)

    def force(t: float) -> float:
        return GRIPPER + (PART * G if t >= 1.2 else 0.0) + noise[int(t / 0.01)]

    phase = lambda t: PayloadPhase.TARE if t < 1.2 else PayloadPhase.WEIGH  # noqa: E731
    quiet = run(lambda t: GRIPPER + PART * G * (t >= 1.2) + 0.1 * noise[int(t / 0.01)] / 0.5,
                phase=phase, until=3.0)
    estimate = run(force, phase=phase, until=3.0, settings=noisy)
    assert quiet.samples == 20  # the default sensor: the default window
    assert estimate.samples > 3 * quiet.samples  # the noisy one: until the count is sure
    assert estimate.std < 0.3  # 0.49 parts over the default window
    assert not estimate.trusted or estimate.count == 1  # a count acted on is never wrong


def test_nothing_is_weighed_before_a_tare():
    estimate = run(lambda t: GRIPPER, phase=lambda t: PayloadPhase.WEIGH)
    assert not estimate.ready


def test_settings_refuse_nonsense():
    with pytest.raises(ValueError, match="part_mass"):
        PayloadSettings(part_mass=0.0)
    with pytest.raises(ValueError, match="max_fraction"):
        PayloadSettings(part_mass=0.03, max_fraction=0.7)


def test_a_sensor_too_coarse_for_the_part_is_warned_about_before_any_work():
    from dataclasses import replace

    from tangle_drake.pick.diagram import weighing_warning
    from tangle_drake.scenario import PartCount
    from tangle_drake.scenario.drivers import ForceTorqueSensor
    from tangle_drake.scenario.files import resolve_scenario

    scenario = resolve_scenario("floating_gripper.yaml")
    assert weighing_warning(scenario) is None  # the shipped sensor weighs a U-hook surely
    coarse = replace(scenario, force_torque_sensors={"wrist": ForceTorqueSensor(
        force_noise=0.5, force_drift=0.05)})
    warning = weighing_warning(coarse)
    assert warning.startswith("warning:") and "32.8 g" in warning and "±0.38 parts" in warning
    heavy = replace(coarse, pile=replace(coarse.pile, parts=[PartCount("j_hook", 15)]))
    assert weighing_warning(heavy) is None  # a heavier part is weighed surely enough
    assert weighing_warning(replace(scenario, force_torque_sensors={})) is None
