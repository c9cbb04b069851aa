"""The ``Motion`` for a scenario's carrier: chosen by its driver, as the station's drivers are."""

from __future__ import annotations

from tangle_drake.bin_model import release_point
from tangle_drake.drivers.config import GantryDriver, NextageDriver
from tangle_drake.drivers.limits import station_limits
from tangle_drake.drivers.registry import carrier
from tangle_drake.errors import TangleDrakeError
from tangle_drake.planning.motion import Motion
from tangle_drake.scenario import Scenario


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

        settings = ArmMotionSettings(place_position=None if place is None else tuple(place))
        return ArmMotion(scenario.bin, settings, tray=scenario.tray)
    if isinstance(config, GantryDriver):
        from tangle_drake.planning.gantry_motion import GantryMotion

        return GantryMotion(scenario.bin, station_limits(scenario), return_home=return_home,
                            model=name, place=place)
    raise TangleDrakeError(f"no motion planner for {type(config).__name__}")
