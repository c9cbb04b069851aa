"""The hardware simulator: the simulated station behind the robot's LCM driver interface.

Like Drake's ``examples/hardware_sim``: it listens to command messages and sends status and
camera messages, nothing else, so a controller talking to it has no simulation-only ports to
cheat with. A real Nextage with its drivers (``docs/hardware.md``) takes its place.

Arm: ``lcmt_iiwa_command`` -> ``IiwaCommandReceiver`` (holds the measured pose until the
first command) -> ``nextage.position``; ``IiwaStatusSender`` -> ``lcmt_iiwa_status`` every
``hardware.status_period``. Gripper: the same with the WSG messages (width in mm). Camera:
colour and depth (``hardware.depth_format``) in one ``lcmt_image_array`` every
``hardware.camera_period``. Commands are checked as the station checks status (a robot driver
refuses malformed commands too); the grip force limit in them is not simulated (the gripper
model's actuator effort limit applies).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from drake import (
    lcmt_iiwa_command,
    lcmt_iiwa_status,
    lcmt_image_array,
    lcmt_schunk_wsg_command,
    lcmt_schunk_wsg_status,
)
from pydrake.lcm import DrakeLcmInterface
from pydrake.manipulation import (
    IiwaCommandReceiver,
    IiwaControlMode,
    IiwaStatusSender,
    SchunkWsgCommandReceiver,
    SchunkWsgStatusSender,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmBuses, LcmPublisherSystem
from pydrake.systems.primitives import ConstantVectorSource, Demultiplexer
from pydrake.systems.sensors import ImageToLcmImageArrayT, PixelType

from tangle_drake.hardware.images import DepthToMillimetres
from tangle_drake.hardware.lcm_systems import add_checked_subscriber, add_drake_message
from tangle_drake.hardware.limits import robot_limits
from tangle_drake.hardware.messages import check_iiwa_command, check_wsg_command
from tangle_drake.hardware.station import NUM_JOINTS, driver_lcm
from tangle_drake.pile import PileReport, drop_pile
from tangle_drake.scenario import Scenario
from tangle_drake.station import PLANT_NAME, build_station, hold_robot_still


@dataclass
class HardwareSim:
    """A running hardware simulator."""

    diagram: Diagram
    simulator: Simulator
    station: Diagram
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
    pile, state, width = _settle_pile(station, scenario, seed, progress)
    builder = DiagramBuilder()
    builder.AddSystem(station)
    lcm = driver_lcm(scenario, builder, lcm_buses, "tangle_drake hardware simulator")
    _add_arm_driver(builder, station, scenario, lcm)
    _add_gripper_driver(builder, station, scenario, lcm, width)
    _add_camera_driver(builder, station, scenario, lcm)
    diagram = builder.Build()
    diagram.set_name("hardware_sim")

    simulator = Simulator(diagram)
    plant = station.GetSubsystemByName(PLANT_NAME)
    plant.SetPositionsAndVelocities(
        plant.GetMyMutableContextFromRoot(simulator.get_mutable_context()), state)
    simulator.Initialize()
    return HardwareSim(diagram, simulator, station, pile)


def _settle_pile(station: Diagram, scenario: Scenario, seed: int | None,
                 progress: Callable[[str], None] | None) -> tuple[PileReport, np.ndarray, float]:
    """Drop the pile in ``station`` on its own, before any LCM system exists, so the drop
    sends nothing; returns the report, the plant's state and the gripper's opening."""
    simulator = Simulator(station)
    hold_robot_still(station, simulator.get_mutable_context())
    simulator.Initialize()
    report = drop_pile(simulator, scenario.bin, scenario.pile, seed=seed, progress=progress)
    plant = station.GetSubsystemByName(PLANT_NAME)
    context = plant.GetMyContextFromRoot(simulator.get_context())
    fingers = plant.GetPositions(context, plant.GetModelInstanceByName("gripper"))
    return report, plant.GetPositionsAndVelocities(context), float(fingers[1] - fingers[0])


def _add_arm_driver(builder: DiagramBuilder, station: Diagram, scenario: Scenario,
                    lcm: DrakeLcmInterface) -> None:
    config = scenario.hardware
    command = add_drake_message(builder, "nextage.command", add_checked_subscriber(
        builder, "nextage.command", config.nextage_command_channel, lcmt_iiwa_command,
        check_iiwa_command(NUM_JOINTS), lcm), lcmt_iiwa_command)
    receiver = builder.AddNamedSystem(
        "nextage.command_receiver",
        IiwaCommandReceiver(NUM_JOINTS, IiwaControlMode.kPositionOnly))
    builder.Connect(command.get_output_port(), receiver.get_message_input_port())
    builder.Connect(station.GetOutputPort("nextage.position_measured"),
                    receiver.get_position_measured_input_port())
    builder.Connect(receiver.get_commanded_position_output_port(),
                    station.GetInputPort("nextage.position"))

    status = builder.AddNamedSystem("nextage.status_sender", IiwaStatusSender(NUM_JOINTS))
    state = builder.AddNamedSystem("nextage.state_split",
                                   Demultiplexer([NUM_JOINTS, NUM_JOINTS]))
    builder.Connect(station.GetOutputPort("nextage.state_measured"), state.get_input_port())
    builder.Connect(receiver.get_commanded_position_output_port(),
                    status.get_position_commanded_input_port())
    builder.Connect(state.get_output_port(0), status.get_position_measured_input_port())
    builder.Connect(state.get_output_port(1), status.get_velocity_estimated_input_port())
    # Position control: no torque is commanded (the driver reports zeros, as the iiwa's does).
    no_torque = builder.AddNamedSystem("nextage.no_torque",
                                       ConstantVectorSource(np.zeros(NUM_JOINTS)))
    builder.Connect(no_torque.get_output_port(), status.get_torque_commanded_input_port())
    _publish(builder, "nextage.status_publisher", config.nextage_status_channel,
             lcmt_iiwa_status, lcm, config.status_period, status)


def _add_gripper_driver(builder: DiagramBuilder, station: Diagram, scenario: Scenario,
                        lcm: DrakeLcmInterface, width: float) -> None:
    config = scenario.hardware
    command = add_drake_message(builder, "gripper.command", add_checked_subscriber(
        builder, "gripper.command", config.wsg_command_channel, lcmt_schunk_wsg_command,
        check_wsg_command(robot_limits(scenario).gripper_max_width), lcm),
        lcmt_schunk_wsg_command)
    receiver = builder.AddNamedSystem(
        "gripper.command_receiver",
        SchunkWsgCommandReceiver(initial_position=width,
                                 initial_force=config.gripper_force_limit))
    builder.Connect(command.get_output_port(), receiver.get_input_port(0))
    builder.Connect(receiver.get_position_output_port(), station.GetInputPort("gripper.position"))
    status = builder.AddNamedSystem("gripper.status_sender", SchunkWsgStatusSender())
    builder.Connect(station.GetOutputPort("gripper.state_measured"),
                    status.get_state_input_port())
    _publish(builder, "gripper.status_publisher", config.wsg_status_channel,
             lcmt_schunk_wsg_status, lcm, config.status_period, status)


def _add_camera_driver(builder: DiagramBuilder, station: Diagram, scenario: Scenario,
                       lcm: DrakeLcmInterface) -> None:
    config = scenario.hardware
    images = builder.AddNamedSystem("camera.image_array",
                                    ImageToLcmImageArrayT(do_compress=False))
    builder.Connect(station.GetOutputPort("camera.rgb_image"),
                    images.DeclareImageInputPort[PixelType.kRgba8U]("color"))
    depth = station.GetOutputPort("camera.depth_image")
    if config.depth_format == "16U":
        millimetres = builder.AddNamedSystem("camera.depth_to_mm", DepthToMillimetres())
        builder.Connect(depth, millimetres.get_input_port())
        depth = millimetres.get_output_port()
        depth_input = images.DeclareImageInputPort[PixelType.kDepth16U]("depth")
    else:
        depth_input = images.DeclareImageInputPort[PixelType.kDepth32F]("depth")
    builder.Connect(depth, depth_input)
    _publish(builder, "camera.publisher", config.camera_channel, lcmt_image_array, lcm,
             config.camera_period, images)


def _publish(builder: DiagramBuilder, name: str, channel: str, lcm_type: type,
             lcm: DrakeLcmInterface, period: float, sender) -> None:
    publisher = builder.AddNamedSystem(name, LcmPublisherSystem.Make(
        channel, lcm_type, lcm, publish_period=period, use_cpp_serializer=True))
    builder.Connect(sender.get_output_port(), publisher.get_input_port())
