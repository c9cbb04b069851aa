"""The hardware simulator: the simulated station behind the robot's LCM driver interface.

Like Drake's ``examples/hardware_sim``: it listens to command messages and sends status and
camera messages, nothing else, so a controller talking to it has no simulation-only ports to
cheat with. A real Nextage with its drivers (``docs/hardware.md``) takes its place.

Each of the scenario's drivers plays its robot side (:mod:`tangle_drake.drivers`): commands
in, checked as the station checks status (a robot driver refuses malformed commands too);
status every ``hardware.status_period``; the camera's colour and depth
(``hardware.depth_format``) every ``hardware.camera_period``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmBuses

from tangle_drake.drivers import camera, force_torque
from tangle_drake.drivers.registry import driver_module
from tangle_drake.lcm_io.buses import BusFinder
from tangle_drake.scenario import Scenario
from tangle_drake.station import SimulatedStation, build_station
from tangle_drake.station.pile import PileReport, PileSettler


@dataclass
class HardwareSim:
    """A running hardware simulator."""

    diagram: Diagram
    simulator: Simulator
    station: SimulatedStation
    """The simulated station inside: ground truth for tests and tools, never for a controller."""
    pile: PileReport


def build_hardware_sim(scenario: Scenario, lcm_buses: LcmBuses | None = None,
                       seed: int | None = None,
                       progress: Callable[[str], None] | None = None) -> HardwareSim:
    """Drop a pile in the simulated station, then put the driver interface around it.

    Returns it initialized at t = 0 with the settled pile. Without ``lcm_buses`` the scenario's
    buses are created (a network URL there puts the messages on that network).
    """
    station = build_station(scenario)
    pile, state, held = _settle_pile(station, scenario, seed, progress)
    builder = DiagramBuilder()
    builder.AddSystem(station)
    buses = BusFinder(scenario, builder, lcm_buses, "tangle_drake hardware simulator")
    for name, config in scenario.model_drivers.items():
        driver_module(config).add_robot_side(builder, station, buses.find(config.lcm_bus), name,
                                             config, scenario, held[name])
    for name, sensor in scenario.force_torque_sensors.items():
        force_torque.add_robot_side(builder, station, buses.find(sensor.lcm_bus), name, sensor)
    camera.add_robot_side(builder, station, buses.find(scenario.camera.lcm_bus), scenario)
    diagram = builder.Build()
    diagram.set_name("hardware_sim")

    simulator = Simulator(diagram)
    station.set_plant_state(simulator.get_mutable_context(), state)
    simulator.Initialize()
    return HardwareSim(diagram, simulator, station, pile)


def _settle_pile(station: SimulatedStation, scenario: Scenario, seed: int | None,
                 progress: Callable[[str], None] | None,
                 ) -> tuple[PileReport, np.ndarray, dict[str, np.ndarray]]:
    """Drop the pile in ``station`` on its own, before any LCM system exists, so the drop
    sends nothing; returns the report, the plant's state and each driver's held command."""
    settler = PileSettler(station, scenario)
    pile = settler.settle(seed, progress)
    plant_context = station.plant_context(settler.simulator.get_context())
    held = {name: driver_module(config).held_command(station.plant, plant_context, name)
            for name, config in scenario.model_drivers.items()}
    return pile.report, pile.state, held
