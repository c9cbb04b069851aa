"""Runs ``tangle-drake hardware-sim`` and ``tangle-drake demo --hardware`` as two processes on a
``udpm://`` bus, the way a cell runs them, and reports what happened as JSON on stdout.

``python two_processes.py CASE SCENARIO WORKDIR`` is meant to run inside a private network
namespace (``tests/test_hardware_two_processes.py`` makes it), so the multicast stays there.
It also listens on the bus itself, to see what the controller commands and the robot reports.

Cases: ``pick`` (robot first, then the controller), ``late_robot`` (the controller first),
``silent`` (no robot), ``bridge_stops`` (the robot killed mid-pick), ``controller_killed``
(the controller killed mid-pick), ``lag`` (the simulator alone, behind real time).
"""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from drake import lcmt_iiwa_status
from pydrake.lcm import DrakeLcm

from tangle_drake.scenario.files import scenario_source

MID_PICK = 3.0
"""Wall seconds after the controller connects at which a process is killed: mid-pick."""


def command(*args: str) -> list[str]:
    """The ``tangle-drake`` console script beside this Python, as a user runs it."""
    script = Path(sys.executable).parent / "tangle-drake"
    found = str(script) if script.exists() else shutil.which("tangle-drake")
    return [found or "tangle-drake", *args]


class Listener:
    """Every message on the channels it is given, with its arrival time."""

    def __init__(self, url: str, channels: list[str]) -> None:
        self.lcm = DrakeLcm(url)
        self.seen: dict[str, list[tuple[float, bytes]]] = {c: [] for c in channels}
        for channel in channels:
            self.lcm.Subscribe(channel, lambda data, c=channel: self.seen[c].append(
                (time.monotonic(), data)))
        self._stop = False
        self._thread = threading.Thread(target=self._pump, daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        while not self._stop:
            self.lcm.HandleSubscriptions(20)

    def stop(self) -> None:
        self._stop = True
        self._thread.join()

    def times(self, channel: str) -> list[float]:
        return [t for t, _ in self.seen[channel]]


class Process:
    """A child process whose output goes to a file, read as it grows."""

    def __init__(self, name: str, args: list[str], workdir: Path) -> None:
        self.log = workdir / f"{name}.log"
        self._file = self.log.open("w")
        self.popen = subprocess.Popen(args, stdout=self._file, stderr=subprocess.STDOUT,
                                      cwd=workdir)

    def text(self) -> str:
        self._file.flush()
        return self.log.read_text()

    def wait_for(self, text: str, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.text():
                return True
            if self.popen.poll() is not None:
                return text in self.text()
            time.sleep(0.05)
        return False

    def finish(self, timeout: float) -> int | None:
        """The exit code, or None after killing a process that did not end in ``timeout``."""
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            return None


def run(case: str, scenario_files: list[str], workdir: Path) -> dict:
    scenario = scenario_source(scenario_files).load()
    url = scenario.lcm_buses["default"].lcm_url
    arm = scenario.model_drivers["gantry"]
    listener = Listener(url, [arm.command_channel, arm.status_channel])
    robot_args = command("hardware-sim", "--scenario", *scenario_files)
    picks = "1" if case in ("pick", "late_robot") else "3"  # the others stop it mid-pick
    controller_args = command("demo", "--hardware", "--picks", picks, "--scenario",
                              *scenario_files)
    result: dict = {"case": case}
    robot = controller = None
    try:
        if case == "lag":
            robot = Process("robot", [*robot_args, "--duration", "4"], workdir)
            result["robot_rc"] = robot.finish(120)
        elif case == "silent":
            start = time.monotonic()
            controller = Process("controller", controller_args, workdir)
            result["controller_rc"] = controller.finish(120)
            result["controller_seconds"] = time.monotonic() - start
        elif case in ("pick", "late_robot"):
            first, second = (robot_args, controller_args) if case == "pick" \
                else (controller_args, robot_args)
            a = Process("robot" if case == "pick" else "controller", first, workdir)
            time.sleep(3.0)
            b = Process("controller" if case == "pick" else "robot", second, workdir)
            robot, controller = (a, b) if case == "pick" else (b, a)
            result["controller_rc"] = controller.finish(240)
        elif case in ("bridge_stops", "controller_killed"):
            robot = Process("robot", robot_args, workdir)
            controller = Process("controller", controller_args, workdir)
            result["connected"] = controller.wait_for("robot connected", 120)
            time.sleep(MID_PICK)
            killed = robot if case == "bridge_stops" else controller
            killed.popen.send_signal(signal.SIGKILL)
            result["killed_at"] = time.monotonic()
            if case == "bridge_stops":
                result["controller_rc"] = controller.finish(30)
                result["controller_seconds"] = time.monotonic() - result["killed_at"]
            else:
                killed.finish(10)
                time.sleep(2.0)
        else:
            raise SystemExit(f"unknown case {case!r}")
    finally:
        for process in (robot, controller):
            if process is not None and process.popen.poll() is None:
                process.popen.send_signal(signal.SIGINT)
                process.finish(10)
        listener.stop()
    for name, process in (("robot", robot), ("controller", controller)):
        if process is not None:
            result[f"{name}_log"] = process.text()
    result["command_times"] = listener.times(arm.command_channel)
    result["status"] = [(t, list(lcmt_iiwa_status.decode(data).joint_position_measured))
                        for t, data in listener.seen[arm.status_channel]]
    return result


if __name__ == "__main__":
    case, directory, *scenario_files = sys.argv[1:]
    print(json.dumps(run(case, scenario_files, Path(directory))))
