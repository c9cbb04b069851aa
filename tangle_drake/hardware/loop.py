"""Hardware in the loop in one process: the hardware simulator and a controller over ``memq://``.

Both sides share one fresh in-process LCM instance, whatever the scenario's ``lcm_buses`` say,
so nothing leaves the process. Each side has its own diagram and simulator, as it would in its
own process; they are advanced in turn, one status period at a time, so what one side sends in a
period the other reads in the next, as over a network with a few milliseconds of latency.
"""

from __future__ import annotations

from collections.abc import Callable

from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram
from pydrake.systems.lcm import LcmBuses

from tangle_drake.hardware.hardware_sim import HardwareSim, build_hardware_sim
from tangle_drake.lcm_io.buses import used_buses
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.hardware import IN_PROCESS_URL
from tangle_drake.station import build_hardware_station

ControllerFactory = Callable[[Diagram], Diagram]
"""Builds the controller's root diagram around the given hardware station (e.g. the pick
diagram, or :func:`tangle_drake.hardware.scripted.scripted_controller`)."""


class HardwareInTheLoop:
    """The hardware simulator (``robot``) and a controller (``controller``) in lockstep."""

    def __init__(self, scenario: Scenario, make_controller: ControllerFactory,
                 seed: int | None = None,
                 progress: Callable[[str], None] | None = None) -> None:
        self.lcm = DrakeLcm(IN_PROCESS_URL)
        buses = LcmBuses()
        for bus in used_buses(scenario):
            buses.Add(bus, self.lcm)
        self.period = scenario.hardware.status_period
        self.station = build_hardware_station(scenario, buses)
        self.controller_diagram = make_controller(self.station)
        self.robot: HardwareSim = build_hardware_sim(scenario, buses, seed, progress)
        # The robot speaks first, so its first status and image are waiting when the
        # controller initializes (which waits for them, as it would for a real robot).
        self.robot.simulator.AdvanceTo(self.period)
        self.controller = Simulator(self.controller_diagram)
        self.station.initialize(self.controller)

    @property
    def time(self) -> float:
        """The controller's time, s."""
        return self.controller.get_context().get_time()

    def advance(self, duration: float, robot: bool = True) -> None:
        """Advance the controller by ``duration`` and, unless ``robot`` is False, the robot too
        (a paused robot sends nothing, as when its driver hangs or a cable is pulled)."""
        end = self.time + duration
        while self.time < end - 1e-9:
            step = min(self.period, end - self.time)
            if robot:
                robot_context = self.robot.simulator.get_context()
                self.robot.simulator.AdvanceTo(robot_context.get_time() + step)
            self.controller.AdvanceTo(self.time + step)

    def get_context(self) -> Context:
        """The controller's context, so code that drives a controller ``Simulator`` (read the
        context, ``AdvanceTo``) can drive the loop unchanged."""
        return self.controller.get_context()

    def AdvanceTo(self, time: float) -> None:
        """Advance both sides until the controller's time is ``time``."""
        self.advance(time - self.time)

    def advance_until(self, done: Callable[[HardwareInTheLoop], bool], timeout: float) -> bool:
        """Advance period by period until ``done(self)`` or ``timeout`` seconds; whether done."""
        end = self.time + timeout
        while not done(self):
            if self.time >= end - 1e-9:
                return False
            self.advance(self.period)
        return True


def run_with_hardware_sim(scenario: Scenario, make_controller: ControllerFactory,
                          duration: float, seed: int | None = None,
                          until: Callable[[HardwareInTheLoop], bool] | None = None,
                          progress: Callable[[str], None] | None = None) -> HardwareInTheLoop:
    """Run a controller against the hardware simulator for ``duration`` s (or ``until``)."""
    loop = HardwareInTheLoop(scenario, make_controller, seed, progress)
    loop.advance_until(until or (lambda _: False), duration)
    return loop
