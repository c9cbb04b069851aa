"""The hardware simulator and a controller over one in-process memq:// bus: a scripted arm
move with gripper close/open, and a whole pick by the unchanged pick diagram, complete; a status
outage stops the robot safely and a reset restarts it from where it stands; malformed commands
are refused by the robot side."""

import re

import cv2
import numpy as np
import pytest
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.drivers.limits import station_limits
from tangle_drake.hardware.loop import HardwareInTheLoop, run_with_hardware_sim
from tangle_drake.hardware.scripted import default_target, scripted_controller
from tangle_drake.scenario import load_scenario
from tangle_drake.station.safety import Mode

SMALL = """
directives:
- add_directives:
    file: package://nextage/nextage_with_gripper.dmd.yaml
model_drivers: {nextage: !NextageDriver {}, gripper: !ParallelJawDriver {}}
pile: {parts: [{part: u_hook, count: 3}]}
camera:
  name: camera
  width: 160
  height: 120
  focal: !FovDegrees {y: 45}
  renderer_class: RenderEngineVtk
"""


def _scenario(depth_format: str = "32F"):
    scenario = load_scenario(diagrams_dir() / "pick_demo.yaml")
    scenario.view_cameras = []
    scenario.pile.parts[0].count = 3
    scenario.camera.width, scenario.camera.height = 160, 120
    scenario.hardware.depth_format = depth_format
    return scenario


class Probe:
    """Reads both sides of a loop each period: what the robot was told and what it reports."""

    def __init__(self, loop: HardwareInTheLoop) -> None:
        self.loop = loop
        self.receiver = loop.robot.diagram.GetSubsystemByName("nextage.command_receiver")
        self.rows: list[dict] = []

    def station(self, name: str):
        context = self.loop.station.GetMyContextFromRoot(self.loop.controller.get_context())
        return self.loop.station.GetOutputPort(name).Eval(context)

    def record(self, _: HardwareInTheLoop) -> bool:
        robot_context = self.receiver.GetMyContextFromRoot(self.loop.robot.simulator.get_context())
        self.rows.append({
            "t": self.loop.time,
            "told": self.receiver.get_commanded_position_output_port().Eval(robot_context).copy(),
            "q": self.station("nextage.position_measured").copy(),
            "width": self.station("gripper.state_measured")[0],
            "mode": self.station("safety.report").mode})
        done = self.loop.controller_diagram.GetOutputPort("script.done")
        return done.Eval(self.loop.controller.get_context())[0] > 0.5

    def commands_received(self) -> int:
        """Arm commands the robot side has accepted so far."""
        subscriber = self.loop.robot.diagram.GetSubsystemByName("nextage.command.subscriber")
        return subscriber.get_output_port().Eval(subscriber.GetMyContextFromRoot(
            self.loop.robot.simulator.get_context())).valid

    def holding(self) -> bool:
        """Whether the robot side's watchdog holds the arm."""
        watchdog = self.loop.robot.diagram.GetSubsystemByName("nextage.command_watchdog")
        return watchdog.holding(watchdog.GetMyContextFromRoot(
            self.loop.robot.simulator.get_context()))

    def column(self, name: str) -> np.ndarray:
        return np.array([row[name] for row in self.rows])


def _within_speed_limits(told: np.ndarray, period: float) -> bool:
    """Whether the robot was never told to move a joint faster than its limit."""
    speed = np.abs(np.diff(told, axis=0)) / period
    return bool(np.all(speed <= station_limits(_scenario()).velocity))


def test_scripted_move_and_gripper_close_open_complete_with_the_state_following():
    loop = HardwareInTheLoop(_scenario(), scripted_controller)
    probe = Probe(loop)
    bad_commands = 0

    def step(loop_: HardwareInTheLoop) -> bool:
        nonlocal bad_commands
        if len(probe.rows) % 40 == 20:  # now and then a corrupt command reaches the robot
            loop_.lcm.Publish("NEXTAGE_COMMAND", b"\x01corrupt")
            loop_.lcm.Publish("WSG_COMMAND", b"\x01corrupt")
            bad_commands += 1
        return probe.record(loop_)

    assert loop.advance_until(step, timeout=6.0)
    loop.advance(0.3)  # let the fingers finish opening
    probe.record(loop)

    report = probe.station("safety.report")
    assert report.mode is Mode.RUNNING and report.message == "" and report.rejected == (0, 0, 0)
    q, told = probe.column("q"), probe.column("told")
    np.testing.assert_allclose(q[-1], default_target(), atol=2e-3)
    assert np.max(np.abs(q - told)) < 0.05  # the measured pose follows the command
    # A corrupt command replaces a good one, so the next step covers two periods' motion.
    assert _within_speed_limits(told, loop.period)
    widths = probe.column("width")
    assert widths.min() < 1e-3 and widths[-1] > 0.040
    assert widths[0] == pytest.approx(0.045, abs=1e-3)
    status = loop.station.GetSubsystemByName("nextage.status.subscriber")
    received = status.get_output_port().Eval(status.GetMyContextFromRoot(
        loop.controller.get_context()))
    assert received.valid == pytest.approx(loop.time / loop.period, abs=3)  # 200 Hz
    for name in ("nextage.command.subscriber", "gripper.command.subscriber"):
        robot_side = loop.robot.diagram.GetSubsystemByName(name)
        record = robot_side.get_output_port().Eval(robot_side.GetMyContextFromRoot(
            loop.robot.simulator.get_context()))
        assert record.rejected == bad_commands > 0


def test_status_outage_stops_safely_and_a_reset_restarts_from_the_measured_pose():
    loop = HardwareInTheLoop(_scenario(), scripted_controller)
    probe = Probe(loop)
    for _ in range(60):  # 0.3 s: the arm is moving now
        loop.advance(loop.period)
        probe.record(loop)
    paused_at = loop.time
    while probe.rows[-1]["mode"] is not Mode.FAULT:
        loop.advance(loop.period, robot=False)  # the robot's status stops
        probe.record(loop)
        assert loop.time - paused_at < 0.2
    # The first channel to go 100 ms without a fresh message stops it: the wrist sensor's
    # (100 Hz) or the arm's status (200 Hz).
    assert loop.time - paused_at == pytest.approx(0.105, abs=0.015)
    report = probe.station("safety.report")
    assert re.search(r"no valid (NEXTAGE_STATUS|WRIST_FORCE_TORQUE) for 1\d\d ms",
                     report.message), report.message
    assert probe.station("safety.fault")[0] == 1
    loop.advance(loop.period)  # the robot takes in what was sent before the stop
    probe.record(loop)
    sent = probe.commands_received()

    # The robot is back. Its last measured pose is old, so the controller sends nothing more;
    # the robot side's watchdog holds the arm once the commands have stopped.
    for _ in range(round(2 * _scenario().hardware.command_timeout / loop.period)):
        loop.advance(loop.period)
        probe.record(loop)
    assert probe.commands_received() == sent
    assert probe.holding()
    still = probe.column("q")[-20:]
    assert np.ptp(still, axis=0).max() < 1e-4
    # It finished the last command it was given before the stop, and stays there.
    np.testing.assert_allclose(still[-1], probe.rows[-1]["told"], atol=0.03)
    assert probe.rows[-1]["mode"] is Mode.FAULT

    station_context = loop.station.GetMyContextFromRoot(loop.controller.get_context())
    loop.station.GetInputPort("safety.reset").FixValue(station_context, [1.0])
    rearm = len(probe.rows)
    assert loop.advance_until(probe.record, timeout=6.0)
    restarted = next(i for i in range(rearm, len(probe.rows))
                     if probe.rows[i]["mode"] is Mode.RUNNING)
    told = probe.column("told")[restarted:]
    # The first command after the restart is the measured pose: no jump, then a smooth move.
    np.testing.assert_allclose(told[1], probe.rows[restarted]["q"], atol=2e-3)
    assert _within_speed_limits(told, loop.period)
    assert np.max(np.abs(np.diff(told, axis=0))) / loop.period < 1.0  # the script's own pace
    np.testing.assert_allclose(probe.rows[-1]["q"], default_target(), atol=5e-3)


@pytest.mark.parametrize("depth_format", ["32F", "16U"])
def test_camera_images_over_lcm_match_the_simulated_camera(depth_format):
    # No controller around the station: nothing commands the robot, which holds still.
    loop = run_with_hardware_sim(_scenario(depth_format), lambda station: station, 0.25)
    context = loop.station.GetMyContextFromRoot(loop.controller.get_context())
    depth = np.array(loop.station.GetOutputPort("camera.depth_image").Eval(context).data)
    rgb = np.array(loop.station.GetOutputPort("camera.rgb_image").Eval(context).data)
    truth_context = loop.robot.station.GetMyContextFromRoot(loop.robot.simulator.get_context())
    true_depth = np.array(loop.robot.station.GetOutputPort("camera.depth_image")
                          .Eval(truth_context).data)
    true_rgb = np.array(loop.robot.station.GetOutputPort("camera.rgb_image")
                        .Eval(truth_context).data)
    assert depth.shape == true_depth.shape == (120, 160, 1)
    # The image is up to one camera period old and the pile still creeps by a hair.
    assert np.abs(rgb.astype(int) - true_rgb).max() <= 2
    seen = np.isfinite(true_depth) & (true_depth > 0)
    assert seen.mean() > 0.3  # the bin and the pile; the ground has no visual geometry
    np.testing.assert_array_equal(np.isfinite(depth), np.isfinite(true_depth))
    tolerance = 1e-3 if depth_format == "16U" else 0.0  # Drake truncates to whole mm
    assert np.mean(np.abs(depth[seen] - true_depth[seen]) <= tolerance + 1e-4) > 0.995
    assert loop.station.GetOutputPort("safety.report").Eval(context).mode is Mode.RUNNING


def test_the_demo_picks_one_part_through_the_hardware_interface():
    """``tangle-drake demo --hardware --with-hardware-sim``: the unchanged pick diagram, its
    station built with hardware=True, against the hardware simulator: one whole pick (look,
    plan, approach, grasp, lift, check, place)."""
    from tangle_drake.episode.demo import DemoOptions, run_demo
    from tangle_drake.pick.diagram import pick_settings
    from tangle_drake.pick.outcome import Outcome

    scenario = load_scenario(diagrams_dir() / "pick_demo.yaml")
    scenario.view_cameras = []
    scenario.pile.parts[0].count = 3
    lines = []
    (record,) = run_demo(DemoOptions(picks=1, scenario=scenario, rule="graspability",
                                     hardware=True, with_hardware_sim=True, open_loop=True),
                         lines.append)
    # Whether the fingers catch a wire is physics; what the interface must deliver is a whole
    # pick (no safety stop) whose outcome the controller read from the gripper's measured
    # width alone (the hardware station has no simulation-only ports).
    assert record.outcome is not Outcome.FAILED, record.describe()
    assert record.truth.lifted is None
    assert (record.outcome is Outcome.NONE) == (record.width < pick_settings(scenario).empty_width)
    assert any("over memq://" in line for line in lines), lines
    assert "parts in the bin" in lines[-1]


def test_the_closed_loop_weighs_over_lcm_with_the_same_diagram(tmp_path):
    """The closed loop against the hardware simulator: the wrist sensor's messages are all
    the controller has to count the parts with, and all the pick log labels grasps with."""
    from tangle_drake.dataset import load_samples
    from tangle_drake.episode.demo import DemoOptions, run_demo
    from tangle_drake.pick.recovery import Disposition

    scenario = load_scenario(diagrams_dir() / "floating_gripper.yaml")
    scenario.view_cameras = []
    scenario.pile.parts[0].count = 4
    records = run_demo(DemoOptions(picks=1, scenario=scenario, rule="graspability", seed=1,
                                   hardware=True, with_hardware_sim=True,
                                   log_picks=tmp_path / "log", pictures=tmp_path / "pictures"),
                       lambda _: None)
    assert all(r.truth.lifted is None for r in records)  # no simulation-only count
    assert records[-1].disposition is Disposition.DELIVERED, [r.describe() for r in records]
    assert records[-1].estimate.count == 1 and records[-1].outcome.value == "one part"
    logged = load_samples(tmp_path / "log", ("label", "outcome", "sim_lifted", "pile_seed"))
    weighed = [r for r in records if r.verdict is not None]
    assert len(logged["label"]) == len(weighed) >= 1
    assert logged["outcome"][-1] == 1 and logged["label"][-1] == 0  # weighed one: not tangled
    assert (logged["sim_lifted"] == -1).all()  # hardware: no simulation count
    # Its picture: no side view on hardware, the wrist's weighing in words instead.
    picture = cv2.imread(str(tmp_path / "pictures" / f"pick_{records[-1].index:03d}.png"))
    width = scenario.camera.width
    assert picture is not None and picture[:, :width].std() > 10
    panel = picture[:scenario.camera.height, width:]
    assert (panel.max(axis=2) > 0).mean() < 0.05  # text on black, not a rendered scene


@pytest.mark.parametrize("carrier", ["nextage", "gantry"])
def test_hardware_sim_command_checks_in_process_and_refuses_an_unreachable_bus(
        carrier, tmp_path, capsys):
    scenario = tmp_path / "small.yaml"
    text = SMALL if carrier == "nextage" else SMALL.replace(
        "package://nextage/nextage_with_gripper.dmd.yaml",
        "package://gantry/floating_gripper.dmd.yaml").replace(
        "nextage: !NextageDriver", "gantry: !GantryDriver")
    scenario.write_text(text)
    assert run_command("hardware-sim", "--scenario", str(scenario), "--check") == 0
    out = capsys.readouterr().out
    assert "scripted motion finished" in out and "safety running" in out
    assert f"{carrier} within 0.00" in out
    with pytest.raises(TangleDrakeError, match="which no other process can reach"):
        run_command("hardware-sim", "--scenario", str(scenario))


def test_a_command_past_a_joint_limit_never_reaches_the_robot_over_lcm():
    scenario = _scenario()
    limits = station_limits(scenario)
    j = limits.joint_names.index("LARM_JOINT0")
    target = default_target()
    target[j] = limits.position_upper[j] + 0.3
    loop = HardwareInTheLoop(scenario, lambda station: scripted_controller(station, target))
    probe = Probe(loop)
    loop.advance_until(lambda lp: probe.record(lp) or probe.rows[-1]["mode"] is Mode.FAULT,
                       timeout=6.0)
    report = probe.station("safety.report")
    assert report.mode is Mode.FAULT and "LARM_JOINT0 is outside its limits" in report.message
    loop.advance(0.1)
    probe.record(loop)
    told = probe.column("told")[:, j]
    assert told.max() <= limits.position_upper[j] + 1e-9  # what the robot was told
