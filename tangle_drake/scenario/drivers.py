"""The scenario's drivers, as data: what runs each actuated model, in simulation and over LCM.

As in Drake's ``hardware_sim`` and the ``manipulation`` package, ``Scenario.model_drivers``
maps a model instance's name to one of these tagged configs:

.. code-block:: yaml

    model_drivers:
      nextage: !NextageDriver {}
      gripper: !ParallelJawDriver {force_limit: 40.0}

The station builder (:mod:`tangle_drake.station`) looks each up in
:mod:`tangle_drake.drivers` and builds its simulated branch or its LCM branch there; both give
the same ``{model}.{port}`` names. A driver for a new kind of model is a config here and a
module there, not a change to the station.

No ``from __future__ import annotations``: Drake's YAML loader needs real field types.
"""

from dataclasses import dataclass

from pydrake.systems.sensors import CameraConfig

from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import (
    PLANNING_ACCELERATION_LIMIT,
    PLANNING_SLOW_SPEED,
    PLANNING_VELOCITY_LIMIT,
)


@dataclass
class JointPositionDriver:
    """A position-servoed carrier of the gripper: ``{model}.position`` in (one command per
    joint, in the model's joint order), ``{model}.position_measured`` and
    ``{model}.state_measured`` ([q, v]) out. Over LCM: ``lcmt_iiwa_command`` /
    ``lcmt_iiwa_status``, which carry any number of joints."""

    lcm_bus: str = "default"
    """The bus in the scenario's ``lcm_buses`` that carries both channels."""
    command_channel: str = ""
    status_channel: str = ""


@dataclass
class NextageDriver(JointPositionDriver):
    """The Nextage's 15 joints (``robot.NEXTAGE_JOINTS``), starting at ``robot.HOME``; picks
    are planned by ``ArmMotion`` (IK and collision checks)."""

    command_channel: str = "NEXTAGE_COMMAND"
    status_channel: str = "NEXTAGE_STATUS"
    planning_velocity_limit: float = PLANNING_VELOCITY_LIMIT
    """Joint speed the pick's free moves are planned with, rad/s, at most the slowest moving
    joint's rated speed (the chest's 1.92). The default is the ROS stack's conservative one."""
    planning_acceleration_limit: float = PLANNING_ACCELERATION_LIMIT
    """Joint acceleration the pick's moves are planned with, rad/s²."""
    planning_slow_speed: float = PLANNING_SLOW_SPEED
    """Tool-centre speed over the slow stretch next to the pile (the last of the descent, the
    first of the lift), m/s."""


@dataclass
class GantryDriver(JointPositionDriver):
    """The 4-axis gantry of the floating gripper (x, y, z slides, yaw turn), starting parked
    behind the bin; picks are planned by ``GantryMotion`` (no IK)."""

    command_channel: str = "GANTRY_COMMAND"
    status_channel: str = "GANTRY_STATUS"


@dataclass
class ParallelJawDriver:
    """A two-finger parallel gripper: ``{model}.position`` in (the opening between the finger
    pads, m), ``{model}.state_measured`` ([width, width rate]) out. Over LCM:
    ``lcmt_schunk_wsg_command`` / ``lcmt_schunk_wsg_status`` (mm, mm/s)."""

    lcm_bus: str = "default"
    command_channel: str = "WSG_COMMAND"
    status_channel: str = "WSG_STATUS"
    force_limit: float = DEFAULT_GRIPPER.grip_force
    """Grip force limit sent with every command, N."""


@dataclass
class ForceTorqueSensor:
    """A 6-axis force/torque sensor in the weld above ``model::body`` (the wrist: between the
    carrier's flange and the gripper): ``{name}.force_torque`` out, ``[fx, fy, fz, tx, ty, tz]``
    in world coordinates, the force and torque (about the weld's origin) that the carrier
    exerts on what hangs below it, so a held part of mass m adds ``m g`` to ``fz``. Over LCM:
    ``lcmt_force_torque`` on ``channel``.

    The defaults are those of a Robotiq FT 300-S class wrist sensor: 100 Hz, 0.1 N and
    0.005 N·m noise, streamed in steps of 0.01 N and 0.001 N·m. Simulated, the plant's reaction
    force at the weld is sampled every ``period``, low-pass filtered, and given
    Gaussian noise and a random-walk bias, all from ``seed``.
    """

    model: str = "gripper"
    body: str = "gripper_base"
    lcm_bus: str = "default"
    channel: str = "WRIST_FORCE_TORQUE"
    period: float = 0.01
    """Seconds between samples, s."""
    force_noise: float = 0.1
    """Standard deviation of each force sample's noise, N."""
    torque_noise: float = 0.005
    """...of each torque sample's, N·m."""
    force_drift: float = 0.01
    """Random-walk bias of the forces, N per square-root second (taring removes it)."""
    torque_drift: float = 0.0005
    """...of the torques, N·m per square-root second."""
    force_resolution: float = 0.01
    """Samples are rounded to this, N."""
    torque_resolution: float = 0.001
    """...and this, N·m."""
    cutoff_frequency: float = 30.0
    """Corner of the first-order low-pass filter on the samples, Hz (0: none)."""
    seed: int = 0


DriverConfig = NextageDriver | GantryDriver | ParallelJawDriver
"""Every driver kind a scenario may name (the tag is the class name)."""

CARRIER_DRIVERS = (NextageDriver, GantryDriver)
"""Drivers of what carries the gripper; a picking station has exactly one."""


def camera_channel(config: CameraConfig) -> str:
    """A camera's ``lcmt_image_array`` channel, named as Drake's camera configs name it (the
    bus is the camera config's own ``lcm_bus``)."""
    return f"DRAKE_RGBD_CAMERA_IMAGES_{config.name}"
