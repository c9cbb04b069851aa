"""The hardware station: the simulated station's ports, spoken over the robot drivers' LCM.

``build_station(scenario, hardware=True)`` lands here. Each of the scenario's drivers adds its
LCM branch (:mod:`tangle_drake.drivers`), with the same port names, types and sizes as its
simulated branch (and no ``sim.*``), so the pick diagram does not change. Every incoming
message is checked (:mod:`tangle_drake.lcm_io.messages`) and every outgoing command passes
the :class:`~tangle_drake.station.safety.SafetySupervisor`, which adds:

============================= ====== ===================================================
port                          dir    meaning
============================= ====== ===================================================
``safety.reset``              in     (optional) rising edge re-arms after a fault
``safety.fault``              out    1 after a safety stop: the planner must stop its pick
``safety.ready``              out    1 while commands go through (fresh status, no fault)
``safety.report``             out    :class:`~tangle_drake.station.safety.SafetyReport`
============================= ====== ===================================================
"""

from __future__ import annotations

import time

from pydrake.lcm import DrakeLcmInterface
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmBuses, LcmSubscriberSystem

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers import camera, force_torque, joint_position, parallel_jaw
from tangle_drake.drivers.limits import station_limits
from tangle_drake.drivers.registry import carrier, gripper
from tangle_drake.lcm_io.buses import BusFinder
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.drivers import camera_channel
from tangle_drake.station.safety import SafetySupervisor


class HardwareStation(Diagram):
    """The hardware station diagram, which also knows its LCM subscribers, so a controller
    can be started once the robot has spoken (:meth:`initialize`)."""

    hardware = True

    def __init__(self, builder: DiagramBuilder, scenario: Scenario,
                 lcms: list[DrakeLcmInterface],
                 subscribers: dict[str, LcmSubscriberSystem]) -> None:
        super().__init__()
        builder.BuildInto(self)
        self.set_name("hardware_station")
        self.scenario = scenario
        self._lcms = lcms
        self._subscribers = subscribers
        """Each status and image subscriber by its channel, as the scenario names it (Drake's
        subscriber does not tell its channel in every release)."""
        self._startup_timeout = scenario.hardware.startup_timeout

    def wait_for_robot(self) -> None:
        """Handle the buses until every status and image channel has had a message; give up
        after ``hardware.startup_timeout`` wall-clock seconds."""
        deadline = time.monotonic() + self._startup_timeout
        while True:
            silent = [channel for channel, subscriber in self._subscribers.items()
                      if subscriber.WaitForMessage(0, None, 1e-9) == 0]
            if not silent:
                return
            if time.monotonic() >= deadline:
                raise TangleDrakeError(
                    f"no message on {', '.join(silent)} within {self._startup_timeout:g} s: is "
                    "the robot's driver bridge running on the scenario's LCM bus?")
            for lcm in self._lcms:
                lcm.HandleSubscriptions(10)

    def initialize(self, simulator: Simulator) -> None:
        """``simulator.Initialize()`` for a controller diagram that holds this station, with
        the robot's first status and image already in the station's context.

        Drake runs all initialization events as one batch on one context, so a system that
        reads ``{carrier}.state_measured`` in its own initialization event (``PickPlanner``
        does, to hold the arm) would see the station before its subscribers took in the first
        status: zeros. Here the station initializes first.
        """
        self.wait_for_robot()
        self.ExecuteInitializationEvents(
            self.GetMyMutableContextFromRoot(simulator.get_mutable_context()))
        simulator.Initialize()


def build_hardware_station(scenario: Scenario,
                           lcm_buses: LcmBuses | None = None) -> HardwareStation:
    """The station whose ports talk to the robot's drivers (see the module docstring).

    Without ``lcm_buses`` the scenario's ``lcm_buses`` are created in the diagram, as Drake's
    ``hardware_sim`` does; with them (one ``memq://`` instance shared by the hardware simulator
    and the controller in one process) the given instances are used.
    """
    builder = DiagramBuilder()
    buses = BusFinder(scenario, builder, lcm_buses, "tangle_drake hardware station")
    arm_name, arm_config = carrier(scenario.model_drivers)
    hand_name, hand_config = gripper(scenario.model_drivers)
    limits = station_limits(scenario)
    n = len(limits.joint_names)
    arm_status, arm = joint_position.add_status(
        builder, buses.find(arm_config.lcm_bus), arm_name, arm_config, n)
    hand_status, hand = parallel_jaw.add_status(
        builder, buses.find(hand_config.lcm_bus), hand_name, hand_config)
    sensors = {name: force_torque.add_interface(builder, buses.find(sensor.lcm_bus), name,
                                                sensor)
               for name, sensor in scenario.force_torque_sensors.items()}
    supervisor = builder.AddNamedSystem("safety", SafetySupervisor(
        limits, scenario.hardware, {"arm": arm_config.status_channel,
                                    "gripper": hand_config.status_channel,
                                    **{name: scenario.force_torque_sensors[name].channel
                                       for name in sensors}}))
    builder.ExportInput(supervisor.GetInputPort("position_desired"), f"{arm_name}.position")
    builder.ExportInput(supervisor.GetInputPort("gripper_desired"), f"{hand_name}.position")
    builder.ExportInput(supervisor.GetInputPort("reset"), "safety.reset")
    builder.Connect(arm.get_position_measured_output_port(),
                    supervisor.GetInputPort("position_measured"))
    builder.Connect(hand.get_state_output_port(), supervisor.GetInputPort("gripper_measured"))
    builder.Connect(arm_status.get_output_port(), supervisor.GetInputPort("arm_status"))
    builder.Connect(hand_status.get_output_port(), supervisor.GetInputPort("gripper_status"))
    for name, subscriber in sensors.items():  # a stale sensor stops the robot as status does
        builder.Connect(subscriber.get_output_port(), supervisor.GetInputPort(f"{name}_status"))
    for name in ("fault", "ready", "report"):
        builder.ExportOutput(supervisor.GetOutputPort(name), f"safety.{name}")
    send = supervisor.GetOutputPort("send")
    joint_position.add_command(builder, buses.find(arm_config.lcm_bus), arm_name, arm_config,
                               scenario.hardware, n,
                               supervisor.GetOutputPort("position_command"), send)
    parallel_jaw.add_command(builder, buses.find(hand_config.lcm_bus), hand_name, hand_config,
                             scenario.hardware, supervisor.GetOutputPort("gripper_command"),
                             send)
    images = camera.add_interface(builder, buses.find(scenario.camera.lcm_bus), scenario)
    subscribers = {arm_config.status_channel: arm_status, hand_config.status_channel: hand_status,
                   **{scenario.force_torque_sensors[name].channel: subscriber
                      for name, subscriber in sensors.items()},
                   camera_channel(scenario.camera): images}
    return HardwareStation(builder, scenario, buses.instances, subscribers)
