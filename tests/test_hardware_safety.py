"""The safety supervisor alone: no command before fresh status, stops on stale status and on
commands past a limit, holds the measured pose, and restarts from it after a reset."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from tangle_drake.drivers.limits import RobotLimits
from tangle_drake.lcm_io.messages import Received
from tangle_drake.robot_model.nextage import NEXTAGE_JOINTS
from tangle_drake.scenario.hardware import HardwareConfig
from tangle_drake.station.safety import Mode, SafetySupervisor

LIMITS = RobotLimits(joint_names=NEXTAGE_JOINTS, units=("rad",) * 15,
                     position_lower=np.full(15, -2.0), position_upper=np.full(15, 2.0),
                     velocity=np.full(15, 1.0), gripper_max_width=0.045)
CONFIG = HardwareConfig()
PERIOD = CONFIG.command_period
LARM0 = NEXTAGE_JOINTS.index("LARM_JOINT0")


class Harness:
    """The supervisor with its inputs set by hand, advanced one command period per tick."""

    def __init__(self) -> None:
        self.system = SafetySupervisor(LIMITS, CONFIG,
                                       {"arm": "NEXTAGE_STATUS", "gripper": "WSG_STATUS"})
        self.simulator = Simulator(self.system)
        self.measured = np.full(15, 0.3)
        self.width = 0.02
        self.desired = self.measured.copy()
        self.gripper = 0.02
        self.counts = [0, 0]
        self.reset = 0.0
        self._fix()
        self.simulator.Initialize()

    @property
    def context(self):
        return self.simulator.get_mutable_context()

    def _fix(self) -> None:
        values = {"position_desired": self.desired, "gripper_desired": [self.gripper],
                  "position_measured": self.measured, "gripper_measured": [self.width, 0.0],
                  "arm_status": Received(valid=self.counts[0]),
                  "gripper_status": Received(valid=self.counts[1]), "reset": [self.reset]}
        for name, value in values.items():
            self.system.GetInputPort(name).FixValue(self.context, value)

    def tick(self, n: int = 1, arm: bool = True, gripper: bool = True) -> None:
        for _ in range(n):
            self.counts = [self.counts[0] + arm, self.counts[1] + gripper]
            self._fix()
            self.simulator.AdvanceTo(self.context.get_time() + PERIOD)

    def out(self, name: str):
        value = self.system.GetOutputPort(name).Eval(self.context)
        return value if name == "report" else np.array(value)

    def running(self) -> None:
        self.tick()
        assert self.out("report").mode is Mode.RUNNING


def test_nothing_is_sent_before_fresh_status_then_commands_start_at_the_measured_pose():
    h = Harness()
    h.desired = np.full(15, 1.0)
    h.tick(10, arm=False, gripper=False)
    assert h.out("send")[0] == 0 and h.out("ready")[0] == 0
    assert h.out("report").mode is Mode.WAITING
    h.tick(3, arm=True, gripper=False)  # the gripper's status is needed too
    assert h.out("send")[0] == 0
    h.tick()
    assert h.out("send")[0] == 1 and h.out("ready")[0] == 1
    np.testing.assert_array_equal(h.out("position_command"), h.measured)
    assert h.out("gripper_command")[0] == h.width
    h.desired = h.measured + 0.004  # 0.8 rad/s: within the limit
    h.gripper = 0.01
    h.tick()
    np.testing.assert_array_equal(h.out("position_command"), h.desired)
    assert h.out("gripper_command")[0] == 0.01


def test_stale_status_stops_sending_and_a_reset_restarts_from_the_measured_pose(caplog):
    h = Harness()
    h.running()
    h.gripper = 0.01
    h.tick()
    ticks = 0
    while h.out("fault")[0] == 0:
        h.desired = h.desired + 0.002
        h.tick(arm=False)
        ticks += 1
        assert ticks < 40
    # The last status was seen one tick before the pause; the stop comes on the first tick
    # that finds it older than the 100 ms timeout.
    assert ticks * PERIOD == pytest.approx(CONFIG.status_timeout + PERIOD, abs=1.5 * PERIOD)
    report = h.out("report")
    assert report.mode is Mode.FAULT
    assert "no valid NEXTAGE_STATUS for 105 ms (timeout 100 ms)" in report.message
    assert "safety stop" in caplog.text and "NEXTAGE_STATUS" in caplog.text
    # The last measured pose is old: nothing more is sent (the robot side's watchdog holds the
    # arm and keeps the gripper's last command, so a held part is not dropped).
    assert h.out("send")[0] == 0 and h.out("ready")[0] == 0

    h.measured = h.measured + 0.05  # where the robot came to rest
    h.tick(10)  # status is back, but a fault stays until reset
    assert h.out("fault")[0] == 1 and h.out("send")[0] == 0
    h.reset = 1.0
    h.tick()
    assert h.out("report").mode is Mode.RUNNING and h.out("report").message == ""
    assert h.out("send")[0] == 1
    np.testing.assert_array_equal(h.out("position_command"), h.measured)


def test_stale_gripper_status_stops_too():
    h = Harness()
    h.running()
    h.tick(25, gripper=False)
    assert "no valid WSG_STATUS" in h.out("report").message


@pytest.mark.parametrize(("change", "reason"), [
    (lambda h: h.desired.__setitem__(LARM0, 2.5),
     "command 2.5000 rad for LARM_JOINT0 is outside its limits [-2.0000, 2.0000]"),
    (lambda h: h.desired.__setitem__(LARM0, h.desired[LARM0] + 0.1),
     "command would move LARM_JOINT0 at 20.00 rad/s, above its limit 1.00 rad/s"),
    (lambda h: h.desired.__setitem__(LARM0, math.nan), "non-finite arm command for LARM_JOINT0"),
    (lambda h: setattr(h, "gripper", 0.06), "gripper width command 0.06 m outside [0, 0.045]"),
])
def test_a_command_past_a_limit_stops_and_holds_the_measured_pose(change, reason):
    h = Harness()
    h.running()
    h.measured = h.measured + 0.001  # the robot lags its command a little
    change(h)
    h.tick()
    report = h.out("report")
    assert report.mode is Mode.FAULT
    assert reason in report.message
    assert h.out("send")[0] == 1  # the status is fresh: the hold is commanded
    np.testing.assert_array_equal(h.out("position_command"), h.measured)
    assert h.out("gripper_command")[0] == h.width


def test_an_arm_that_does_not_follow_is_held_but_normal_servo_lag_is_not():
    h = Harness()
    h.running()
    # A move at 0.4 rad/s that the arm follows 0.035 rad behind: over the fixed tolerance
    # (0.03) but within its speed times the servo lag (0.04): lag, not a fault.
    for _ in range(80):
        h.measured = h.desired.copy() - 0.035
        h.desired = h.desired + 0.002
        h.tick()
        assert h.out("report").mode is Mode.RUNNING, h.out("report").message
    # Now the arm stops (blocked) while the command goes on, within every limit.
    stuck = h.measured.copy()
    ticks = 0
    while h.out("report").mode is Mode.RUNNING:
        h.measured = stuck
        h.desired = h.desired + 0.002
        h.tick()
        ticks += 1
        assert ticks < 100
    message = h.out("report").message
    assert "trails its command" in message and "for 0.2" in message
    np.testing.assert_array_equal(h.out("position_command"), stuck)
