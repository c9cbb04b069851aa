"""The parallel-jaw gripper's driver: every branch, and the facts of its two fingers.

The gripper model has two prismatic finger joints (``robot.GRIPPER_JOINTS``: the −y finger,
then the +y one) moving symmetrically; everything outside this module speaks of the opening
between the finger pads and its rate, as a WSG driver reports them. Simulation: the width
command goes through a discrete-derivative interpolator and :data:`WIDTH_TO_FINGERS` to the
fingers' PD servos. Hardware station: ``lcmt_schunk_wsg_status`` (mm) becomes
``{model}.state_measured`` (m); commands leave as ``lcmt_schunk_wsg_command`` with the
driver's force limit. Robot side: the reverse, for the hardware simulator.
"""

from __future__ import annotations

import numpy as np
from drake import lcmt_schunk_wsg_command, lcmt_schunk_wsg_status
from pydrake.lcm import DrakeLcmInterface
from pydrake.manipulation import (
    SchunkWsgCommandReceiver,
    SchunkWsgCommandSender,
    SchunkWsgStatusReceiver,
    SchunkWsgStatusSender,
)
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, OutputPort
from pydrake.systems.lcm import LcmSubscriberSystem
from pydrake.systems.primitives import MatrixGain, StateInterpolatorWithDiscreteDerivative

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.lcm_io.lcm_systems import (
    GatedPublisher,
    add_checked_subscriber,
    add_drake_message,
    add_publisher,
)
from tangle_drake.lcm_io.messages import check_wsg_command, check_wsg_status
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.robot_model.nextage import GRIPPER_JOINTS
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.drivers import ParallelJawDriver
from tangle_drake.scenario.hardware import HardwareConfig

FINGERS_TO_WIDTH = np.array([[-1.0, 1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 1.0]])
"""[q_left, q_right, v_left, v_right] -> [width, width rate]."""
WIDTH_TO_FINGERS = 0.5 * np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])
"""[width, width rate] -> the symmetric fingers' [q_left, q_right, v_left, v_right]."""

EMPTY_FRACTION = 0.25
"""Fingers closed below this fraction of the wire's diameter hold nothing (the compliant pads
squeeze a held wire to about half its diameter; empty fingers close to under 1 mm)."""
DEFAULT_WIRE_DIAMETER = 0.006
"""The wire assumed where the part's is unknown (a mesh part), m."""


def empty_grasp_width(wire_diameter: float | None) -> float:
    """The opening below which the fingers hold nothing, for the thinnest wire in the bin
    (``None``: unknown, :data:`DEFAULT_WIRE_DIAMETER`), m. The one empty-grasp rule."""
    return EMPTY_FRACTION * (DEFAULT_WIRE_DIAMETER if wire_diameter is None else wire_diameter)


def finger_positions(width: float, spec: GripperSpec = DEFAULT_GRIPPER) -> np.ndarray:
    """Finger joint positions ``[q_left, q_right]`` that open the fingers ``width`` apart.

    Widths outside ``[0, spec.max_opening]`` are refused rather than clipped: asking for them
    is a bug in the caller.
    """
    if not 0.0 <= width <= spec.max_opening:
        raise ValueError(f"gripper width {width!r} m outside [0, {spec.max_opening}]")
    return WIDTH_TO_FINGERS[:2, 0] * width


def opening(finger_q: np.ndarray) -> float:
    """The opening between the pads for finger positions ``[q_left, q_right]``, m."""
    return float(FINGERS_TO_WIDTH[0, :2] @ np.asarray(finger_q, float))


def set_home(plant: MultibodyPlant, name: str, config: ParallelJawDriver,
             scenario: Scenario) -> None:
    """The fingers start where the model (or its directive) puts them."""


def add_simulated(builder: DiagramBuilder, plant: MultibodyPlant, name: str,
                  config: ParallelJawDriver, scenario: Scenario) -> None:
    """``{name}.position`` (width) in; ``{name}.state_measured`` ([width, rate]) out."""
    model = plant.GetModelInstanceByName(name)
    if plant.num_positions(model) != 2:
        raise TangleDrakeError(f"the gripper model {name!r} must have exactly two finger "
                               "joints")
    interpolator = builder.AddNamedSystem(
        f"{name}.command_interpolator",
        StateInterpolatorWithDiscreteDerivative(1, plant.time_step(),
                                                suppress_initial_transient=True))
    to_fingers = builder.AddNamedSystem(f"{name}.width_to_fingers",
                                        MatrixGain(WIDTH_TO_FINGERS))
    builder.Connect(interpolator.get_output_port(), to_fingers.get_input_port())
    builder.Connect(to_fingers.get_output_port(), plant.get_desired_state_input_port(model))
    builder.ExportInput(interpolator.get_input_port(), f"{name}.position")
    width = builder.AddNamedSystem(f"{name}.state_to_width", MatrixGain(FINGERS_TO_WIDTH))
    builder.Connect(plant.get_state_output_port(model), width.get_input_port())
    builder.ExportOutput(width.get_output_port(), f"{name}.state_measured")


def held_command(plant: MultibodyPlant, plant_context: Context, name: str) -> np.ndarray:
    """The command that keeps the fingers where they are: their opening."""
    return np.array([opening(plant.GetPositions(plant_context,
                                                plant.GetModelInstanceByName(name)))])


def max_opening(plant: MultibodyPlant, name: str) -> float:
    """The widest opening the finger joints' limits allow, m."""
    model = plant.GetModelInstanceByName(name)
    left, right = (plant.GetJointByName(joint, model) for joint in GRIPPER_JOINTS)
    return opening([left.position_lower_limits()[0], right.position_upper_limits()[0]])


# --- the hardware station's side ------------------------------------------------------------

def add_status(builder: DiagramBuilder, lcm: DrakeLcmInterface, name: str,
               config: ParallelJawDriver) -> tuple[LcmSubscriberSystem, SchunkWsgStatusReceiver]:
    """The gripper's status as ``{name}.state_measured``."""
    subscriber = add_checked_subscriber(builder, f"{name}.status", config.status_channel,
                                        lcmt_schunk_wsg_status, check_wsg_status, lcm)
    message = add_drake_message(builder, f"{name}.status", subscriber, lcmt_schunk_wsg_status)
    receiver = builder.AddNamedSystem(f"{name}.status_receiver", SchunkWsgStatusReceiver())
    builder.Connect(message.get_output_port(), receiver.get_status_input_port())
    builder.ExportOutput(receiver.get_state_output_port(), f"{name}.state_measured")
    return subscriber, receiver


def add_command(builder: DiagramBuilder, lcm: DrakeLcmInterface, name: str,
                config: ParallelJawDriver, hardware: HardwareConfig, command: OutputPort,
                send: OutputPort) -> None:
    """Publish the width ``command`` with the force limit while ``send`` is 1."""
    sender = builder.AddNamedSystem(f"{name}.command_sender",
                                    SchunkWsgCommandSender(config.force_limit))
    builder.Connect(command, sender.get_position_input_port())
    publisher = builder.AddNamedSystem(
        f"{name}.command_publisher",
        GatedPublisher(config.command_channel, lcmt_schunk_wsg_command, lcm,
                       hardware.command_period))
    builder.Connect(sender.get_output_port(), publisher.get_input_port(0))
    builder.Connect(send, publisher.get_input_port(1))


# --- the robot's side, played by the hardware simulator -------------------------------------

def add_robot_side(builder: DiagramBuilder, station: Diagram, lcm: DrakeLcmInterface,
                   name: str, config: ParallelJawDriver, scenario: Scenario,
                   held: np.ndarray) -> None:
    """Width commands from LCM into ``station`` (holding ``held`` until the first one); the
    measured width back as status. The force limit is not simulated (the finger actuators'
    effort limit applies)."""
    command = add_drake_message(builder, f"{name}.command", add_checked_subscriber(
        builder, f"{name}.command", config.command_channel, lcmt_schunk_wsg_command,
        check_wsg_command(max_opening(station.plant, name)), lcm),
        lcmt_schunk_wsg_command)
    receiver = builder.AddNamedSystem(
        f"{name}.command_receiver",
        SchunkWsgCommandReceiver(initial_position=float(held[0]),
                                 initial_force=config.force_limit))
    builder.Connect(command.get_output_port(), receiver.get_input_port(0))
    builder.Connect(receiver.get_position_output_port(), station.GetInputPort(f"{name}.position"))
    status = builder.AddNamedSystem(f"{name}.status_sender", SchunkWsgStatusSender())
    builder.Connect(station.GetOutputPort(f"{name}.state_measured"),
                    status.get_state_input_port())
    add_publisher(builder, f"{name}.status_publisher", config.status_channel,
                  lcmt_schunk_wsg_status, lcm, scenario.hardware.status_period,
                  status.get_output_port())
