"""Joint position drivers (the Nextage, the gantry): every branch of the kind, one module.

Simulation: ``{model}.position`` goes through a discrete-derivative interpolator to the
model's joint PD servos (desired [q, v], as Drake's iiwa driver does it); the measured state
is the model's own. Hardware station: ``lcmt_iiwa_status`` becomes ``{model}.position_measured``
and ``{model}.state_measured``; the commands leave as ``lcmt_iiwa_command`` behind the safety
supervisor. Robot side (the hardware simulator): ``lcmt_iiwa_command`` into the simulated
station's command (holding the measured pose until the first one), status every
``hardware.status_period``. Vectors are in the model's position order.
"""

from __future__ import annotations

import numpy as np
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from pydrake.lcm import DrakeLcmInterface
from pydrake.manipulation import (
    IiwaCommandReceiver,
    IiwaCommandSender,
    IiwaControlMode,
    IiwaStatusReceiver,
    IiwaStatusSender,
)
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, OutputPort
from pydrake.systems.lcm import LcmSubscriberSystem
from pydrake.systems.primitives import (
    ConstantVectorSource,
    Demultiplexer,
    MatrixGain,
    Multiplexer,
    StateInterpolatorWithDiscreteDerivative,
)

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.lcm_io.lcm_systems import (
    GatedPublisher,
    add_checked_subscriber,
    add_drake_message,
    add_publisher,
)
from tangle_drake.lcm_io.messages import check_iiwa_command, check_iiwa_status
from tangle_drake.lcm_io.watchdog import CommandWatchdog
from tangle_drake.robot_model.nextage import HOME
from tangle_drake.scenario import BinConfig, Scenario
from tangle_drake.scenario.drivers import GantryDriver, JointPositionDriver, NextageDriver
from tangle_drake.scenario.hardware import HardwareConfig

GANTRY_PARK_OFFSET = 0.25
"""How far behind the bin's centre (along −x) the gantry parks, out of the camera's view, m."""
GANTRY_PARK_HEIGHT = 1.2
"""World z of the gantry's yaw link when parked, m."""


def gantry_home(bin_config: BinConfig) -> np.ndarray:
    """Where the gantry waits (x, y, z, yaw): behind the bin, high, yaw 0."""
    return np.array([bin_config.center[0] - GANTRY_PARK_OFFSET, bin_config.center[1],
                     GANTRY_PARK_HEIGHT, 0.0])


def home_positions(config: JointPositionDriver, scenario: Scenario) -> np.ndarray:
    """The model's starting (and waiting) positions."""
    if isinstance(config, NextageDriver):
        return HOME.copy()
    if isinstance(config, GantryDriver):
        return gantry_home(scenario.bin)
    raise TangleDrakeError(f"no home pose for {type(config).__name__}")


def joint_names(plant: MultibodyPlant, name: str) -> list[str]:
    """The model's one-degree-of-freedom joints in position order (the command's order)."""
    model = plant.GetModelInstanceByName(name)
    joints = [plant.get_joint(i) for i in plant.GetJointIndices(model)]
    joints = sorted((j for j in joints if j.num_positions() == 1), key=lambda j: j.position_start())
    if len(joints) != plant.num_positions(model):
        raise TangleDrakeError(f"model {name!r}: a joint position driver needs one-degree-of-"
                               "freedom joints only")
    return [j.name() for j in joints]


def _check_actuation_order(plant: MultibodyPlant, name: str) -> None:
    """The servos' desired state is in actuator order: it must be the position order."""
    model = plant.GetModelInstanceByName(name)
    starts = [plant.get_joint_actuator(i).joint().position_start()
              for i in plant.GetJointActuatorIndices(model)]
    if len(starts) != plant.num_positions(model) or starts != sorted(starts):
        raise TangleDrakeError(f"model {name!r}: every joint needs one actuator (with "
                               "drake:controller_gains), declared in joint order")


def set_home(plant: MultibodyPlant, name: str, config: JointPositionDriver,
             scenario: Scenario) -> None:
    plant.SetDefaultPositions(plant.GetModelInstanceByName(name),
                              home_positions(config, scenario))


def add_simulated(builder: DiagramBuilder, plant: MultibodyPlant, name: str,
                  config: JointPositionDriver, scenario: Scenario) -> None:
    """``{name}.position`` in; ``{name}.position_measured`` and ``{name}.state_measured`` out."""
    _check_actuation_order(plant, name)
    model = plant.GetModelInstanceByName(name)
    n = plant.num_positions(model)
    interpolator = builder.AddNamedSystem(
        f"{name}.command_interpolator",
        StateInterpolatorWithDiscreteDerivative(n, plant.time_step(),
                                                suppress_initial_transient=True))
    builder.Connect(interpolator.get_output_port(), plant.get_desired_state_input_port(model))
    builder.ExportInput(interpolator.get_input_port(), f"{name}.position")
    position = builder.AddNamedSystem(
        f"{name}.position_selector", MatrixGain(np.hstack([np.eye(n), np.zeros((n, n))])))
    builder.Connect(plant.get_state_output_port(model), position.get_input_port())
    builder.ExportOutput(position.get_output_port(), f"{name}.position_measured")
    builder.ExportOutput(plant.get_state_output_port(model), f"{name}.state_measured")


def held_command(plant: MultibodyPlant, plant_context: Context, name: str) -> np.ndarray:
    """The command that holds the model where it is: its positions."""
    return plant.GetPositions(plant_context, plant.GetModelInstanceByName(name))


# --- the hardware station's side ------------------------------------------------------------

def add_status(builder: DiagramBuilder, lcm: DrakeLcmInterface, name: str,
               config: JointPositionDriver, n: int,
               ) -> tuple[LcmSubscriberSystem, IiwaStatusReceiver]:
    """The robot's status as ``{name}.position_measured`` and ``{name}.state_measured``."""
    subscriber = add_checked_subscriber(builder, f"{name}.status", config.status_channel,
                                        lcmt_iiwa_status, check_iiwa_status(n), lcm)
    message = add_drake_message(builder, f"{name}.status", subscriber, lcmt_iiwa_status)
    receiver = builder.AddNamedSystem(f"{name}.status_receiver", IiwaStatusReceiver(n))
    builder.Connect(message.get_output_port(), receiver.get_input_port())
    state = builder.AddNamedSystem(f"{name}.state", Multiplexer([n, n]))
    builder.Connect(receiver.get_position_measured_output_port(), state.get_input_port(0))
    builder.Connect(receiver.get_velocity_estimated_output_port(), state.get_input_port(1))
    builder.ExportOutput(receiver.get_position_measured_output_port(),
                         f"{name}.position_measured")
    builder.ExportOutput(state.get_output_port(), f"{name}.state_measured")
    return subscriber, receiver


def add_command(builder: DiagramBuilder, lcm: DrakeLcmInterface, name: str,
                config: JointPositionDriver, hardware: HardwareConfig, n: int,
                command: OutputPort, send: OutputPort) -> None:
    """Publish ``command`` (checked by the supervisor) while ``send`` is 1."""
    sender = builder.AddNamedSystem(f"{name}.command_sender",
                                    IiwaCommandSender(n, IiwaControlMode.kPositionOnly))
    builder.Connect(command, sender.get_position_input_port())
    publisher = builder.AddNamedSystem(
        f"{name}.command_publisher",
        GatedPublisher(config.command_channel, lcmt_iiwa_command, lcm, hardware.command_period))
    builder.Connect(sender.get_output_port(), publisher.get_input_port(0))
    builder.Connect(send, publisher.get_input_port(1))


# --- the robot's side, played by the hardware simulator -------------------------------------

def add_robot_side(builder: DiagramBuilder, station: Diagram, lcm: DrakeLcmInterface,
                   name: str, config: JointPositionDriver, scenario: Scenario,
                   held: np.ndarray) -> None:
    """Commands from LCM into ``station``'s ``{name}.position`` through the command watchdog;
    its state back as status. (``held`` is not needed: Drake's receiver holds the measured
    pose until a command.)"""
    n = station.GetInputPort(f"{name}.position").size()
    subscriber = add_checked_subscriber(builder, f"{name}.command", config.command_channel,
                                        lcmt_iiwa_command, check_iiwa_command(n), lcm)
    command = add_drake_message(builder, f"{name}.command", subscriber, lcmt_iiwa_command)
    receiver = builder.AddNamedSystem(f"{name}.command_receiver",
                                      IiwaCommandReceiver(n, IiwaControlMode.kPositionOnly))
    builder.Connect(command.get_output_port(), receiver.get_message_input_port())
    measured = station.GetOutputPort(f"{name}.position_measured")
    builder.Connect(measured, receiver.get_position_measured_input_port())
    watchdog = builder.AddNamedSystem(f"{name}.command_watchdog", CommandWatchdog(
        n, config.command_channel, scenario.hardware.command_timeout,
        scenario.hardware.status_period))
    builder.Connect(subscriber.get_output_port(), watchdog.get_input_port(0))
    builder.Connect(receiver.get_commanded_position_output_port(), watchdog.get_input_port(1))
    builder.Connect(measured, watchdog.get_input_port(2))
    builder.Connect(watchdog.get_output_port(), station.GetInputPort(f"{name}.position"))

    status = builder.AddNamedSystem(f"{name}.status_sender", IiwaStatusSender(n))
    state = builder.AddNamedSystem(f"{name}.state_split", Demultiplexer([n, n]))
    builder.Connect(station.GetOutputPort(f"{name}.state_measured"), state.get_input_port())
    builder.Connect(watchdog.get_output_port(), status.get_position_commanded_input_port())
    builder.Connect(state.get_output_port(0), status.get_position_measured_input_port())
    builder.Connect(state.get_output_port(1), status.get_velocity_estimated_input_port())
    # Position control: no torque is commanded (the driver reports zeros, as the iiwa's does).
    no_torque = builder.AddNamedSystem(f"{name}.no_torque", ConstantVectorSource(np.zeros(n)))
    builder.Connect(no_torque.get_output_port(), status.get_torque_commanded_input_port())
    add_publisher(builder, f"{name}.status_publisher", config.status_channel, lcmt_iiwa_status,
                  lcm, scenario.hardware.status_period, status.get_output_port())
