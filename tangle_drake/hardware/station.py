"""The hardware station: the simulated station's ports, spoken over the robot driver's LCM.

``build_station(scenario, hardware=True)`` lands here. Same port names, types and sizes as the
simulated station (no ``sim.*``), so the pick diagram does not change:

============================= ====== ===================================================
port                          dir    LCM behind it
============================= ====== ===================================================
``nextage.position``          in     ``lcmt_iiwa_command`` (15 joints) on NEXTAGE_COMMAND
``nextage.position_measured`` out    ``lcmt_iiwa_status`` on NEXTAGE_STATUS
``nextage.state_measured``    out    the same status: [positions, velocities]
``gripper.position``          in     ``lcmt_schunk_wsg_command`` (mm) on WSG_COMMAND
``gripper.state_measured``    out    ``lcmt_schunk_wsg_status`` (mm, mm/s) on WSG_STATUS
``camera.rgb_image``          out    ``lcmt_image_array`` on DRAKE_RGBD_CAMERA_IMAGES
``camera.depth_image``        out    the same array's depth (32F m or 16U mm), metres here
``safety.reset``              in     (optional) rising edge re-arms after a fault
``safety.fault``              out    1 after a safety stop: the planner must stop its pick
``safety.ready``              out    1 while commands go through (fresh status, no fault)
``safety.report``             out    :class:`~tangle_drake.hardware.safety.SafetyReport`
============================= ====== ===================================================

Channel names, rates and timeouts come from the scenario's ``hardware`` section and the bus
from its ``lcm_buses``. Every incoming message is checked (:mod:`.messages`) and every
outgoing command passes the :class:`~tangle_drake.hardware.safety.SafetySupervisor`.
"""

from __future__ import annotations

import time

from drake import (
    lcmt_iiwa_command,
    lcmt_iiwa_status,
    lcmt_image_array,
    lcmt_schunk_wsg_command,
    lcmt_schunk_wsg_status,
)
from pydrake.lcm import DrakeLcmInterface
from pydrake.manipulation import (
    IiwaCommandSender,
    IiwaControlMode,
    IiwaStatusReceiver,
    SchunkWsgCommandSender,
    SchunkWsgStatusReceiver,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import (
    ApplyLcmBusConfig,
    LcmBuses,
    LcmInterfaceSystem,
    LcmSubscriberSystem,
)
from pydrake.systems.primitives import Multiplexer

from tangle_drake.errors import TangleDrakeError
from tangle_drake.hardware.config import HardwareConfig
from tangle_drake.hardware.images import ImageArrayToImages
from tangle_drake.hardware.lcm_systems import (
    GatedPublisher,
    add_checked_subscriber,
    add_drake_message,
)
from tangle_drake.hardware.limits import robot_limits
from tangle_drake.hardware.messages import (
    check_iiwa_status,
    check_image_array,
    check_wsg_status,
)
from tangle_drake.hardware.safety import SafetySupervisor
from tangle_drake.robot import NEXTAGE_JOINTS
from tangle_drake.scenario import Scenario

NUM_JOINTS = len(NEXTAGE_JOINTS)


def driver_lcm(scenario: Scenario, builder: DiagramBuilder,
               lcm_buses: LcmBuses | None, who: str) -> DrakeLcmInterface:
    """The LCM instance of the scenario's ``hardware.lcm_bus``, pumped by ``builder``'s diagram.

    Without ``lcm_buses`` the scenario's ``lcm_buses`` are created in the diagram, as Drake's
    ``hardware_sim`` does; with them (one ``memq://`` instance shared by the hardware simulator
    and the controller in one process) the given instance is used.
    """
    bus = scenario.hardware.lcm_bus
    if lcm_buses is None:
        return ApplyLcmBusConfig(scenario.lcm_buses, builder).Find(who, bus)
    lcm = lcm_buses.Find(who, bus)
    builder.AddNamedSystem("lcm_interface", LcmInterfaceSystem(lcm))
    return lcm


class HardwareStation(Diagram):
    """The hardware station diagram, which also knows its LCM subscribers, so a controller
    can be started once the robot has spoken (:meth:`initialize`)."""

    def __init__(self, builder: DiagramBuilder, lcm: DrakeLcmInterface,
                 subscribers: list[LcmSubscriberSystem], startup_timeout: float) -> None:
        super().__init__()
        builder.BuildInto(self)
        self.set_name("hardware_station")
        self._lcm = lcm
        self._subscribers = subscribers
        self._startup_timeout = startup_timeout

    def wait_for_robot(self) -> None:
        """Handle the bus until every status and image channel has had a message; give up
        after ``hardware.startup_timeout`` wall-clock seconds."""
        deadline = time.monotonic() + self._startup_timeout
        while True:
            silent = [s.get_channel_name() for s in self._subscribers
                      if s.WaitForMessage(0, None, 1e-9) == 0]
            if not silent:
                return
            if time.monotonic() >= deadline:
                raise TangleDrakeError(
                    f"no message on {', '.join(silent)} within {self._startup_timeout:g} s: is "
                    "the robot's driver bridge running on the scenario's LCM bus?")
            self._lcm.HandleSubscriptions(10)

    def initialize(self, simulator: Simulator) -> None:
        """``simulator.Initialize()`` for a controller diagram that holds this station, with
        the robot's first status and image already in the station's context.

        Drake runs all initialization events as one batch on one context, so a system that
        reads ``nextage.state_measured`` in its own initialization event (``PickPlanner`` does,
        to hold the arm) would see the station before its subscribers took in the first
        status: zeros. Here the station initializes first.
        """
        self.wait_for_robot()
        self.ExecuteInitializationEvents(
            self.GetMyMutableContextFromRoot(simulator.get_mutable_context()))
        simulator.Initialize()


def build_hardware_station(scenario: Scenario,
                           lcm_buses: LcmBuses | None = None) -> HardwareStation:
    """The station whose ports talk to the robot's drivers (see the module docstring)."""
    builder = DiagramBuilder()
    lcm = driver_lcm(scenario, builder, lcm_buses, "tangle_drake hardware station")
    arm_status, arm = _add_arm_status(builder, scenario.hardware, lcm)
    gripper_status, gripper = _add_gripper_status(builder, scenario.hardware, lcm)
    supervisor = builder.AddNamedSystem(
        "safety", SafetySupervisor(robot_limits(scenario), scenario.hardware))
    builder.ExportInput(supervisor.GetInputPort("position_desired"), "nextage.position")
    builder.ExportInput(supervisor.GetInputPort("gripper_desired"), "gripper.position")
    builder.ExportInput(supervisor.GetInputPort("reset"), "safety.reset")
    builder.Connect(arm.get_position_measured_output_port(),
                    supervisor.GetInputPort("position_measured"))
    builder.Connect(gripper.get_state_output_port(), supervisor.GetInputPort("gripper_measured"))
    builder.Connect(arm_status.get_output_port(), supervisor.GetInputPort("arm_status"))
    builder.Connect(gripper_status.get_output_port(), supervisor.GetInputPort("gripper_status"))
    for name in ("fault", "ready", "report"):
        builder.ExportOutput(supervisor.GetOutputPort(name), f"safety.{name}")
    _add_command_publishers(builder, scenario.hardware, lcm, supervisor)
    camera = _add_camera(builder, scenario, lcm)
    return HardwareStation(builder, lcm, [arm_status, gripper_status, camera],
                           scenario.hardware.startup_timeout)


def _add_arm_status(builder: DiagramBuilder, config: HardwareConfig,
                    lcm: DrakeLcmInterface) -> tuple[LcmSubscriberSystem, IiwaStatusReceiver]:
    subscriber = add_checked_subscriber(
        builder, "nextage.status", config.nextage_status_channel, lcmt_iiwa_status,
        check_iiwa_status(NUM_JOINTS), lcm)
    message = add_drake_message(builder, "nextage.status", subscriber, lcmt_iiwa_status)
    receiver = builder.AddNamedSystem("nextage.status_receiver", IiwaStatusReceiver(NUM_JOINTS))
    builder.Connect(message.get_output_port(), receiver.get_input_port())
    state = builder.AddNamedSystem("nextage.state", Multiplexer([NUM_JOINTS, NUM_JOINTS]))
    builder.Connect(receiver.get_position_measured_output_port(), state.get_input_port(0))
    builder.Connect(receiver.get_velocity_estimated_output_port(), state.get_input_port(1))
    builder.ExportOutput(receiver.get_position_measured_output_port(),
                         "nextage.position_measured")
    builder.ExportOutput(state.get_output_port(), "nextage.state_measured")
    return subscriber, receiver


def _add_gripper_status(builder: DiagramBuilder, config: HardwareConfig, lcm: DrakeLcmInterface,
                        ) -> tuple[LcmSubscriberSystem, SchunkWsgStatusReceiver]:
    subscriber = add_checked_subscriber(
        builder, "gripper.status", config.wsg_status_channel, lcmt_schunk_wsg_status,
        check_wsg_status, lcm)
    message = add_drake_message(builder, "gripper.status", subscriber, lcmt_schunk_wsg_status)
    receiver = builder.AddNamedSystem("gripper.status_receiver", SchunkWsgStatusReceiver())
    builder.Connect(message.get_output_port(), receiver.get_status_input_port())
    builder.ExportOutput(receiver.get_state_output_port(), "gripper.state_measured")
    return subscriber, receiver


def _add_command_publishers(builder: DiagramBuilder, config: HardwareConfig,
                            lcm: DrakeLcmInterface, supervisor: SafetySupervisor) -> None:
    arm = builder.AddNamedSystem(
        "nextage.command_sender", IiwaCommandSender(NUM_JOINTS, IiwaControlMode.kPositionOnly))
    builder.Connect(supervisor.GetOutputPort("position_command"), arm.get_position_input_port())
    gripper = builder.AddNamedSystem(
        "gripper.command_sender", SchunkWsgCommandSender(config.gripper_force_limit))
    builder.Connect(supervisor.GetOutputPort("gripper_command"),
                    gripper.get_position_input_port())
    for name, channel, lcm_type, sender in (
            ("nextage", config.nextage_command_channel, lcmt_iiwa_command, arm),
            ("gripper", config.wsg_command_channel, lcmt_schunk_wsg_command, gripper)):
        publisher = builder.AddNamedSystem(
            f"{name}.command_publisher",
            GatedPublisher(channel, lcm_type, lcm, config.command_period))
        builder.Connect(sender.get_output_port(), publisher.get_input_port(0))
        builder.Connect(supervisor.GetOutputPort("send"), publisher.get_input_port(1))


def _add_camera(builder: DiagramBuilder, scenario: Scenario,
                lcm: DrakeLcmInterface) -> LcmSubscriberSystem:
    config = scenario.hardware
    subscriber = add_checked_subscriber(
        builder, "camera.images", config.camera_channel, lcmt_image_array,
        check_image_array(scenario.camera.width, scenario.camera.height), lcm)
    images = builder.AddNamedSystem("camera.to_images", ImageArrayToImages())
    builder.Connect(subscriber.get_output_port(), images.get_input_port())
    builder.ExportOutput(images.GetOutputPort("color_image"), "camera.rgb_image")
    builder.ExportOutput(images.GetOutputPort("depth_image"), "camera.depth_image")
    return subscriber
