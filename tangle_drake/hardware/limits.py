"""The robot's limits, read from the same model files the simulation uses, never copied."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.parsing import ModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant

from tangle_drake.errors import TangleDrakeError
from tangle_drake.paths import make_parser
from tangle_drake.robot import GRIPPER_JOINTS, NEXTAGE_JOINTS
from tangle_drake.scenario import Scenario


@dataclass(frozen=True)
class RobotLimits:
    """Joint position and speed limits of the 15 Nextage joints, and the gripper's stroke."""

    position_lower: np.ndarray
    """rad, ``NEXTAGE_JOINTS`` order."""
    position_upper: np.ndarray
    velocity: np.ndarray
    """Largest joint speed the robot's controller allows, rad/s."""
    gripper_max_width: float
    """Widest opening between the finger pads, m."""


def robot_limits(scenario: Scenario) -> RobotLimits:
    """Limits of the scenario's ``nextage`` and ``gripper`` models."""
    plant = MultibodyPlant(time_step=0.0)
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant,
                           make_parser(plant))
    plant.Finalize()
    for model in ("nextage", "gripper"):
        if not plant.HasModelInstanceNamed(model):
            raise TangleDrakeError(f"the hardware station needs a model named {model!r} in the "
                                   "scenario's directives")
    joints = [plant.GetJointByName(name) for name in NEXTAGE_JOINTS]
    left, right = (plant.GetJointByName(name) for name in GRIPPER_JOINTS)
    return RobotLimits(
        position_lower=np.array([j.position_lower_limits()[0] for j in joints]),
        position_upper=np.array([j.position_upper_limits()[0] for j in joints]),
        velocity=np.array([j.velocity_upper_limits()[0] for j in joints]),
        gripper_max_width=float(right.position_upper_limits()[0]
                                - left.position_lower_limits()[0]))
