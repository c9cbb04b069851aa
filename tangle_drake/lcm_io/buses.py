"""The LCM buses a scenario's drivers and camera talk on, and finding them in a diagram."""

from __future__ import annotations

from pydrake.lcm import DrakeLcm, DrakeLcmInterface
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.lcm import LcmBuses, LcmInterfaceSystem

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.hardware import IN_PROCESS_URL


def used_buses(scenario: Scenario) -> list[str]:
    """The names of the buses the scenario's drivers, sensors and top camera use, each once."""
    names = [config.lcm_bus for config in scenario.model_drivers.values()]
    names += [sensor.lcm_bus for sensor in scenario.force_torque_sensors.values()]
    names.append(scenario.camera.lcm_bus)
    return list(dict.fromkeys(names))


def network_bus_url(scenario: Scenario, instead: str) -> str:
    """The URL of the scenario's hardware buses, refused if no other process can reach one (a
    controller or simulator on ``memq://`` alone would wait forever); ``instead`` says what to
    do then. The first bus's URL is returned."""
    urls = []
    for bus in used_buses(scenario):
        url = scenario.lcm_buses[bus].lcm_url
        if url.startswith(IN_PROCESS_URL):
            raise TangleDrakeError(
                f"the scenario's LCM bus {bus!r} is {url!r}, which no other process can reach; "
                f"set lcm_buses.{bus}.lcm_url to the robot network's URL (see "
                f"docs/hardware.md), or {instead}")
        urls.append(url or "the default LCM URL")
    return urls[0]


class BusFinder:
    """The LCM instance of each bus name, pumped by the diagram being built.

    Without ``lcm_buses`` each bus the station uses gets its own ``DrakeLcm`` from the
    scenario's ``lcm_buses`` (as Drake's ``hardware_sim`` makes them, but as instances that
    publish: ``ApplyLcmBusConfig`` hands out its pumping systems, which Python cannot publish
    through); with them, the given instances are used. Each instance gets one
    ``LcmInterfaceSystem``.
    """

    def __init__(self, scenario: Scenario, builder: DiagramBuilder,
                 lcm_buses: LcmBuses | None, who: str) -> None:
        self._who = who
        self._builder = builder
        self._scenario = scenario
        self._given = lcm_buses
        self._made: dict[str, DrakeLcm] = {}
        self.instances: list[DrakeLcmInterface] = []
        """Every distinct instance found so far."""

    def find(self, bus: str) -> DrakeLcmInterface:
        if self._given is not None:
            lcm = self._given.Find(self._who, bus)
        elif bus in self._made:
            lcm = self._made[bus]
        else:
            if bus not in self._scenario.lcm_buses:
                raise TangleDrakeError(f"{self._who}: the scenario has no LCM bus {bus!r}")
            lcm = self._made[bus] = DrakeLcm(self._scenario.lcm_buses[bus])
        if not any(lcm is known for known in self.instances):
            self.instances.append(lcm)
            name = "lcm_interface" if len(self.instances) == 1 else f"lcm_interface.{bus}"
            self._builder.AddNamedSystem(name, LcmInterfaceSystem(lcm))
        return lcm
