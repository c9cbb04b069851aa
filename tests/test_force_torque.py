"""The wrist force/torque sensor: it weighs what hangs below it, with the noise it is given,
replays the same samples from a restored context, and reaches the controller over LCM."""

from dataclasses import replace

import numpy as np
import pytest
from drake import lcmt_force_torque
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers.force_torque import sample_draws
from tangle_drake.hardware.loop import run_with_hardware_sim
from tangle_drake.pick.load_path import LoadPathMonitor, held_and_resting
from tangle_drake.pick.payload import (
    PayloadEstimator,
    PayloadPhase,
    PayloadRequest,
    PayloadSettings,
)
from tangle_drake.scenario import PartCount
from tangle_drake.scenario.drivers import ForceTorqueSensor
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.station import build_station

G = 9.81


def small(name: str, parts: int = 1, **sensor):
    scenario = resolve_scenario(name)
    return replace(scenario, view_cameras=[],
                   pile=replace(scenario.pile, parts=[PartCount("u_hook", parts)]),
                   force_torque_sensors={"wrist": ForceTorqueSensor(**sensor)})


def samples(station, simulator, start: float, count: int) -> np.ndarray:
    context = simulator.get_mutable_context()
    port = station.GetOutputPort("wrist.force_torque")
    rows = []
    for k in range(count):
        simulator.AdvanceTo(start + 0.01 * (k + 1))
        rows.append(port.Eval(context).copy())
    return np.array(rows)


def gripper_mass(station, context) -> float:
    plant = station.plant
    model = plant.GetModelInstanceByName("gripper")
    return sum(plant.get_body(i).get_mass(station.plant_context(context))
               for i in plant.GetBodyIndices(model))


@pytest.mark.parametrize("name", ["floating_gripper.yaml", "pick_demo.yaml"])
def test_the_sensor_weighs_the_gripper_with_its_noise(name):
    station = build_station(small(name))
    simulator = Simulator(station)
    station.hold_still(simulator.get_mutable_context())
    simulator.Initialize()
    simulator.AdvanceTo(0.5)
    wrench = samples(station, simulator, 0.5, 80)
    weight = gripper_mass(station, simulator.get_context()) * G
    assert wrench[:, 2].mean() == pytest.approx(weight, abs=0.05)  # the support force, +z
    assert np.abs(wrench[:, :2].mean(axis=0)).max() < 0.06
    assert wrench[:, :3].std(axis=0) == pytest.approx([0.1] * 3, rel=0.3)
    assert wrench[:, 3:].std(axis=0) == pytest.approx([0.005] * 3, rel=0.35)
    # Independent from sample to sample, so a mean over a window is as good as it should be.
    noise = wrench[:, 2] - wrench[:, 2].mean()
    assert abs(np.corrcoef(noise[:-1], noise[1:])[0, 1]) < 0.3
    assert abs(wrench[:20, 2].mean() - weight) < 4 * 0.1 / np.sqrt(20)
    # Samples come in the stream's steps of 0.01 N.
    assert np.allclose(wrench[:, :3] * 100, np.round(wrench[:, :3] * 100), atol=1e-6)


def test_a_part_in_the_fingers_adds_its_weight_and_a_restored_context_replays_the_samples():
    scenario = small("floating_gripper.yaml", force_noise=0.0, torque_noise=0.0,
                     force_drift=0.0, torque_drift=0.0)
    station = build_station(scenario)
    plant = station.plant
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    station.hold_still(context)
    simulator.Initialize()
    start = context.Clone()
    simulator.AdvanceTo(0.3)
    empty = samples(station, simulator, 0.3, 20)[:, 2].mean()
    # Put the part between the open fingers of the parked gripper, then close them on it.
    simulator.get_mutable_context().SetTimeStateAndParametersFrom(start)
    gripper = plant.GetBodyByName("gripper_base")
    X_WG = gripper.EvalPoseInWorld(station.plant_context(context))
    tcp = plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(station.plant_context(context))
    part = station.pile_bodies[0]
    station.GetInputPort("gripper.position").FixValue(context, [0.04])
    simulator.Initialize()
    simulator.AdvanceTo(0.3)
    plant.SetFreeBodyPose(station.mutable_plant_context(context), part,
                          RigidTransform(X_WG.rotation(), tcp.translation()))
    station.GetInputPort("gripper.position").FixValue(context, [0.0])
    simulator.AdvanceTo(1.0)
    held = samples(station, simulator, 1.0, 30)[:, 2].mean()
    mass = part.get_mass(station.plant_context(context))
    assert held - empty == pytest.approx(mass * G, abs=0.03)

    # The same start and the same inputs give the same samples, noise included.
    noisy = build_station(small("floating_gripper.yaml"))
    runs = []
    for _ in range(2):
        sim = Simulator(noisy)
        noisy.hold_still(sim.get_mutable_context())
        sim.Initialize()
        runs.append(samples(noisy, sim, 0.0, 10))
    assert np.array_equal(runs[0], runs[1])
    other = build_station(small("floating_gripper.yaml", seed=1))
    sim = Simulator(other)
    other.hold_still(sim.get_mutable_context())
    sim.Initialize()
    assert not np.array_equal(runs[0], samples(other, sim, 0.0, 10))


class TareThenWeigh(LeafSystem):
    """The planner's requests: tare until 0.6 s, nothing, then weigh from 1.0 s."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareAbstractOutputPort(
            "request", lambda: AbstractValue.Make(PayloadRequest()),
            lambda context, value: value.set_value(
                PayloadRequest(PayloadPhase.TARE, 1) if context.get_time() < 0.6
                else PayloadRequest(PayloadPhase.WEIGH, 2) if context.get_time() >= 1.0
                else PayloadRequest()),
            {self.time_ticket()})


@pytest.mark.parametrize("held", [0, 1, 2])
def test_the_estimator_counts_the_parts_in_the_simulated_fingers(held):
    """The estimator on the station's own noisy sensor, the station inside a larger diagram:
    tared open, then none, one or two U-hooks closed in the pads, side by side."""
    scenario = small("floating_gripper.yaml", parts=2)
    builder = DiagramBuilder()
    station = builder.AddSystem(build_station(scenario))
    plant = station.plant
    part_mass = station.pile_bodies[0].get_mass(plant.CreateDefaultContext())
    estimator = builder.AddSystem(PayloadEstimator(PayloadSettings(part_mass=part_mass), 8))
    requests = builder.AddSystem(TareThenWeigh())
    load_path = builder.AddSystem(LoadPathMonitor(plant))
    builder.Connect(station.GetOutputPort("sim.contact_results"),
                    load_path.GetInputPort("contact_results"))
    builder.Connect(station.GetOutputPort("wrist.force_torque"),
                    estimator.GetInputPort("force_torque"))
    builder.Connect(station.GetOutputPort("gantry.state_measured"),
                    estimator.GetInputPort("carrier_state"))
    builder.Connect(requests.get_output_port(), estimator.GetInputPort("request"))
    simulator = Simulator(builder.Build())
    root = simulator.get_mutable_context()
    own = station.GetMyMutableContextFromRoot(root)
    station.hold_still(own)
    station.GetInputPort("gripper.position").FixValue(own, [0.04])
    simulator.Initialize()
    simulator.AdvanceTo(0.7)
    assert estimator.GetOutputPort("payload").Eval(
        estimator.GetMyContextFromRoot(root)).tared
    tcp = plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(station.plant_context(root))
    for k in range(held):  # 7 mm apart across the pads: 6 mm wires, side by side
        across = tcp.rotation().matrix() @ np.array([(k - (held - 1) / 2) * 0.007, 0.0, 0.0])
        plant.SetFreeBodyPose(station.mutable_plant_context(root), station.pile_bodies[k],
                              RigidTransform(tcp.rotation(), tcp.translation() + across))
    station.GetInputPort("gripper.position").FixValue(own, [0.0])
    simulator.AdvanceTo(1.6)
    estimate = estimator.GetOutputPort("payload").Eval(estimator.GetMyContextFromRoot(root))
    assert estimate.ready and estimate.trusted and estimate.count == held
    assert estimate.confidence > 0.99
    lifted = [station.pile_bodies[k].EvalPoseInWorld(station.plant_context(root))
              .translation()[2] > 0.5 for k in range(2)]
    assert sum(lifted) == held
    held_now, resting = load_path.GetOutputPort("held_count").Eval(
        load_path.GetMyContextFromRoot(root))
    assert (held_now, resting) == (held, 0)


def test_the_load_path_follows_chains_of_touching_parts():
    gripper, parts, bin_floor = frozenset({0, 1}), frozenset({10, 11, 12, 13}), 5
    touching = {0: {10}, 10: {0, 11}, 11: {10, bin_floor}, 12: {bin_floor},
                bin_floor: {11, 12}, 13: {12}}
    touching[12].add(13)
    held, resting = held_and_resting(touching, parts, gripper)
    assert held == {10, 11}  # 11 hangs from 10; 12 and 13 only touch the bin and each other
    assert resting == {11}  # 11 still rests on the bin floor: the wrist reads it light
    assert held_and_resting({}, parts, gripper) == (set(), set())


def test_each_sample_draws_its_own_noise():
    draws = [np.concatenate(sample_draws(0, k)) for k in range(500)]
    now, then = np.array(draws[1:]), np.array(draws[:-1])
    correlation = np.corrcoef(np.hstack([then, now]).T)[:12, 12:]
    assert np.abs(correlation).max() < 0.2
    assert not np.array_equal(sample_draws(3, 7)[0], sample_draws(4, 7)[0])


def test_a_sensor_needs_a_body_hanging_from_a_weld():
    with pytest.raises(TangleDrakeError, match="no_such_body is in no model"):
        build_station(small("floating_gripper.yaml", body="no_such_body"))
    with pytest.raises(TangleDrakeError, match="hangs from no weld"):
        build_station(small("floating_gripper.yaml", body="left_finger"))


def test_the_controller_reads_the_sensor_over_lcm_and_refuses_a_malformed_message():
    scenario = small("floating_gripper.yaml")
    scenario.camera.width, scenario.camera.height = 64, 48
    loop = run_with_hardware_sim(scenario, lambda station: station, 0.3)
    context = loop.station.GetMyContextFromRoot(loop.controller.get_context())
    received = loop.station.GetOutputPort("wrist.force_torque").Eval(context).copy()
    truth_context = loop.robot.station.GetMyContextFromRoot(loop.robot.simulator.get_context())
    truth = loop.robot.station.GetOutputPort("wrist.force_torque").Eval(truth_context)
    assert received[2] == pytest.approx(truth[2], abs=0.35)  # a sample or so apart
    assert received[2] == pytest.approx(4.22, abs=0.3)
    bad = lcmt_force_torque()
    bad.fz = float("nan")
    loop.lcm.Publish("WRIST_FORCE_TORQUE", bad.encode())
    loop.advance(0.005, robot=False)
    subscriber = loop.station.GetSubsystemByName("wrist.subscriber")
    record = subscriber.get_output_port().Eval(subscriber.GetMyContextFromRoot(
        loop.controller.get_context()))
    assert record.rejected == 1 and "non-finite" in record.last_error


def test_a_held_part_stays_put_in_the_pads_during_a_shake():
    """Shaking must not make a held wire creep or pivot between the pads (a contact-model
    artefact would): the target moves less than 2 mm relative to the gripper."""
    from tangle_drake.drivers.limits import station_limits
    from tangle_drake.planning.gantry_motion import GantryMotion

    scenario = small("floating_gripper.yaml")
    station = build_station(scenario)
    plant = station.plant
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    station.hold_still(context)
    station.GetInputPort("gripper.position").FixValue(context, [0.04])
    simulator.Initialize()
    simulator.AdvanceTo(0.3)
    gripper = plant.GetBodyByName("gripper_base")
    tcp = plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(station.plant_context(context))
    part = station.pile_bodies[0]
    plant.SetFreeBodyPose(station.mutable_plant_context(context), part,
                          RigidTransform(tcp.rotation(), tcp.translation()))
    station.GetInputPort("gripper.position").FixValue(context, [0.0])
    simulator.AdvanceTo(1.0)

    def part_in_gripper():
        plant_context = station.plant_context(context)
        return gripper.EvalPoseInWorld(plant_context).InvertAndCompose(
            part.EvalPoseInWorld(plant_context))

    before = part_in_gripper()
    motion = GantryMotion(scenario.bin, station_limits(scenario))
    hold = station.GetOutputPort("gantry.position_measured").Eval(context).copy()
    shake = motion.plan_shake(hold)
    start = context.get_time()
    worst = 0.0
    while context.get_time() < start + shake.end_time() + 0.2:
        t = min(context.get_time() - start, shake.end_time())
        station.GetInputPort("gantry.position").FixValue(context, shake.value(t).ravel())
        simulator.AdvanceTo(context.get_time() + 0.01)
        worst = max(worst, float(np.linalg.norm(
            part_in_gripper().translation() - before.translation())))
    assert shake.end_time() > 0.3  # it did shake
    assert worst < 0.002
