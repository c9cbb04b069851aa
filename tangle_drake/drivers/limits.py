"""The robot's limits, read from the same model files the simulation uses, never copied."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.multibody.parsing import ModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import make_parser
from tangle_drake.drivers import joint_position, parallel_jaw
from tangle_drake.drivers.registry import carrier, gripper
from tangle_drake.scenario import Scenario


@dataclass(frozen=True)
class RobotLimits:
    """Joint position and speed limits of the gripper's carrier, and the gripper's stroke."""

    joint_names: tuple[str, ...]
    """The carrier's joints, in command order."""
    units: tuple[str, ...]
    """Each joint's unit: ``rad`` (revolute) or ``m`` (prismatic)."""
    position_lower: np.ndarray
    """rad or m, ``joint_names`` order."""
    position_upper: np.ndarray
    velocity: np.ndarray
    """Largest joint speed the robot's controller allows (inf where the model gives none)."""
    gripper_max_width: float
    """Widest opening between the finger pads, m."""


def station_limits(scenario: Scenario) -> RobotLimits:
    """Limits of the scenario's carrier and gripper models (``model_drivers``)."""
    arm, _ = carrier(scenario.model_drivers)
    hand, _ = gripper(scenario.model_drivers)
    plant = MultibodyPlant(time_step=0.0)
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant,
                           make_parser(plant))
    plant.Finalize()
    for model in (arm, hand):
        if not plant.HasModelInstanceNamed(model):
            raise TangleDrakeError(f"scenario field 'model_drivers.{model}' names no model the "
                                   "directives add")
    names = joint_position.joint_names(plant, arm)
    joints = [plant.GetJointByName(name, plant.GetModelInstanceByName(arm)) for name in names]
    return RobotLimits(
        joint_names=tuple(names),
        units=tuple("m" if j.type_name() == "prismatic" else "rad" for j in joints),
        position_lower=np.array([j.position_lower_limits()[0] for j in joints]),
        position_upper=np.array([j.position_upper_limits()[0] for j in joints]),
        velocity=np.array([j.velocity_upper_limits()[0] for j in joints]),
        gripper_max_width=parallel_jaw.max_opening(plant, hand))
