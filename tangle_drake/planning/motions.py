"""The ``Motion`` for a scenario's carrier: chosen by its driver, as the station's drivers are."""

from __future__ import annotations

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers.limits import station_limits
from tangle_drake.drivers.registry import carrier
from tangle_drake.planning.motion import Motion
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.drivers import GantryDriver, NextageDriver
from tangle_drake.station.bin_model import release_point


def scenario_mode(scenario: Scenario, source: str) -> str:
    """``floating`` for a scenario whose gripper rides the gantry, ``arm`` for the Nextage."""
    try:
        _, config = carrier(scenario.model_drivers)
    except TangleDrakeError as error:
        raise TangleDrakeError(f"{source}: {error}") from error
    return "floating" if isinstance(config, GantryDriver) else "arm"


def motion_for(scenario: Scenario, *, return_home: bool = True) -> Motion:
    """The motion planner of the scenario's carrier: ``ArmMotion`` for a ``!NextageDriver``
    (IK and collision checks), ``GantryMotion`` for a ``!GantryDriver``; picked parts are
    released over the scenario's tray, if it has one.

    ``return_home=False`` ends a gantry pick at the top of the lift (the benchmark's count);
    the arm always returns home.
    """
    name, config = carrier(scenario.model_drivers)
    place = None if scenario.tray is None else release_point(scenario.tray)
    if isinstance(config, NextageDriver):
        if name != "nextage":
            raise TangleDrakeError(f"scenario field 'model_drivers.{name}': the Nextage's arm "
                                   "motion plans for a model named 'nextage'")
        from tangle_drake.planning.arm_motion import ArmMotion, ArmMotionSettings

        settings = ArmMotionSettings(
            velocity_limit=_rated(scenario, name, config.planning_velocity_limit),
            acceleration_limit=config.planning_acceleration_limit,
            slow_speed=config.planning_slow_speed,
            place_position=None if place is None else tuple(place))
        return ArmMotion(scenario.bin, settings, tray=scenario.tray)
    if isinstance(config, GantryDriver):
        from tangle_drake.planning.gantry_motion import GantryMotion

        return GantryMotion(scenario.bin, station_limits(scenario), return_home=return_home,
                            model=name, place=place)
    raise TangleDrakeError(f"no motion planner for {type(config).__name__}")


def _rated(scenario: Scenario, name: str, velocity: float) -> float:
    """``velocity``, checked against the rated speed of every joint an arm's pick moves (the
    chest and the left arm, as the model files give them)."""
    limits = station_limits(scenario)
    rated = min(v for joint, v in zip(limits.joint_names, limits.velocity, strict=True)
                if joint == "CHEST_JOINT0" or joint.startswith("LARM_"))
    if velocity > rated:
        raise TangleDrakeError(f"scenario field 'model_drivers.{name}.planning_velocity_limit': "
                               f"{velocity} rad/s is faster than the slowest moving joint's "
                               f"rated speed, {rated:.3f} rad/s")
    return velocity
