"""The hardware path as a cell runs it: ``tangle-drake hardware-sim`` and ``tangle-drake demo
--hardware`` as two processes on a real ``udpm://`` bus, inside a network namespace the test
makes (only ``lo``, a multicast route on it: nothing leaves it). Where the namespace cannot be
made, the tests skip and say why."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tangle_drake.cli import SAFETY_STOP_EXIT
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.files import scenario_source
from tangle_drake.scenario.hardware import HardwareConfig

HARNESS = Path(__file__).with_name("two_processes.py")
URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
BASE = "floating_gripper.yaml"
"""The shipped scenario both processes start from; the test's overlay goes on it."""
NAMESPACE = "ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec \"$@\""


def _namespace_problem() -> str | None:
    try:
        done = subprocess.run(["unshare", "-n", "sh", "-c", NAMESPACE, "sh", "true"],
                              capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"cannot run unshare: {error}"
    if done.returncode != 0:
        return ("cannot make a private network namespace with a multicast route "
                f"(unshare -n; needs root or user namespaces): {done.stderr.strip()}")
    return None


pytestmark = pytest.mark.skipif(bool(problem := _namespace_problem()), reason=problem or "")


def _scenario(tmp_path: Path, startup_timeout: float | None = None, extra: str = "") -> Path:
    """An overlay on the floating gripper, as a user would write one: three parts (light
    enough that two processes keep real time on two cores), a multicast bus, and the default
    start-up timeout unless one is given. Both processes take ``--scenario BASE OVERLAY``."""
    fields = [] if startup_timeout is None else [f"startup_timeout: {startup_timeout}"]
    hardware = ", ".join(fields + ([extra] if extra else []))
    path = tmp_path / "net.yaml"
    path.write_text("pile: {parts: [{part: u_hook, count: 3}]}\n"
                    f"lcm_buses: {{default: {{lcm_url: \"{URL}\"}}}}\n"
                    f"hardware: {{{hardware}}}\n")
    return path


def _load(overlay: Path) -> Scenario:
    return scenario_source([BASE, overlay]).load()


def _run(case: str, scenario: Path, tmp_path: Path) -> dict:
    done = subprocess.run(
        ["unshare", "-n", "sh", "-c", NAMESPACE, "sh", sys.executable, str(HARNESS), case,
         str(tmp_path), BASE, str(scenario)],
        capture_output=True, text=True, timeout=400, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _no_traceback(result: dict) -> None:
    for name in ("robot_log", "controller_log"):
        assert "Traceback" not in result.get(name, ""), result[name]


def test_two_processes_on_a_real_bus_deliver_a_part(tmp_path):
    result = _run("pick", _scenario(tmp_path), tmp_path)
    _no_traceback(result)
    assert result["controller_rc"] == 0, result["controller_log"]
    assert "robot connected" in result["controller_log"]
    assert "1 delivered" in result["controller_log"], result["controller_log"]
    assert len(result["command_times"]) > 100  # the commands crossed the bus


def test_a_controller_started_first_waits_for_the_robot_and_picks(tmp_path):
    result = _run("late_robot", _scenario(tmp_path), tmp_path)
    _no_traceback(result)
    assert result["controller_rc"] == 0, result["controller_log"]
    log = result["controller_log"]
    assert log.index("waiting for the robot") < log.index("robot connected")
    assert "1 delivered" in log, log


def test_a_silent_robot_gets_a_clear_error_naming_the_channels(tmp_path):
    result = _run("silent", _scenario(tmp_path, startup_timeout=2.0), tmp_path)
    _no_traceback(result)
    assert result["controller_rc"] == 2
    assert "error: no message on GANTRY_STATUS, WSG_STATUS" in result["controller_log"]
    assert "within 2 s" in result["controller_log"]
    assert result["command_times"] == []


def _killed_mid_pick(case: str, tmp_path: Path) -> tuple[dict, HardwareConfig]:
    """Run ``case`` (one side killed once the controller has connected) on the light
    scenario: what happened, and the scenario's hardware timeouts."""
    scenario = _scenario(tmp_path)
    result = _run(case, scenario, tmp_path)
    _no_traceback(result)
    assert result["connected"], result["controller_log"]
    return result, _load(scenario).hardware


def test_a_bridge_that_stops_mid_pick_ends_the_controller_naming_the_stale_channel(tmp_path):
    result, hardware = _killed_mid_pick("bridge_stops", tmp_path)
    timeout = hardware.status_timeout
    log = result["controller_log"]
    assert result["controller_rc"] == SAFETY_STOP_EXIT, log
    # Every channel of the stopped bridge goes stale; the first past its timeout is named.
    assert re.search(r"error: safety stop .*no valid (GANTRY_STATUS|WSG_STATUS|"
                     r"WRIST_FORCE_TORQUE) for 1\d\d ms", log), log
    assert result["controller_seconds"] <= timeout + 1.0
    # Nothing is commanded once the status is stale (a little slack for scheduling).
    late = [t for t in result["command_times"] if t > result["killed_at"] + timeout + 0.2]
    assert late == []
    assert any(t > result["killed_at"] - 1.0 for t in result["command_times"])  # it was moving


def test_a_controller_killed_mid_pick_leaves_the_robot_holding_its_pose(tmp_path):
    result, hardware = _killed_mid_pick("controller_killed", tmp_path)
    timeout = hardware.command_timeout
    assert "no command on GANTRY_COMMAND" in result["robot_log"]
    assert "holding the measured pose" in result["robot_log"]
    held = np.array([q for t, q in result["status"] if t > result["killed_at"] + timeout + 0.3])
    assert len(held) > 100, "the robot went on reporting its status"
    assert np.ptp(held, axis=0).max() < 1e-3, np.ptp(held, axis=0)


def test_the_hardware_simulator_says_when_it_falls_behind_real_time(tmp_path):
    # 100 camera images a second of 640 x 480 cannot be rendered and sent in real time here.
    result = _run("lag", _scenario(tmp_path, extra="camera_period: 0.01"), tmp_path)
    _no_traceback(result)
    assert result["robot_rc"] == 0, result["robot_log"]
    assert "behind real time by" in result["robot_log"], result["robot_log"]
