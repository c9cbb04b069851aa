"""Which driver module builds which scenario driver, and which model drivers a station has."""

from __future__ import annotations

from types import ModuleType

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers import joint_position, parallel_jaw
from tangle_drake.scenario.drivers import (
    CARRIER_DRIVERS,
    DriverConfig,
    GantryDriver,
    NextageDriver,
    ParallelJawDriver,
)

_MODULES: dict[type, ModuleType] = {NextageDriver: joint_position,
                                    GantryDriver: joint_position,
                                    ParallelJawDriver: parallel_jaw}


def driver_module(config: DriverConfig) -> ModuleType:
    """The module with the simulated, hardware-station and robot-side branches of ``config``."""
    try:
        return _MODULES[type(config)]
    except KeyError:
        raise TangleDrakeError(f"no driver implementation for {type(config).__name__}") from None


def carrier(drivers: dict[str, DriverConfig]) -> tuple[str, DriverConfig]:
    """The one model that carries the gripper (the arm or the gantry), and its driver."""
    found = [(name, c) for name, c in drivers.items() if isinstance(c, CARRIER_DRIVERS)]
    if len(found) != 1:
        kinds = " or ".join(f"!{kind.__name__}" for kind in CARRIER_DRIVERS)
        raise TangleDrakeError(f"picking needs a robot: the scenario's model_drivers must have "
                               f"exactly one {kinds} (the gripper's carrier), not "
                               f"{len(found)}")
    return found[0]


def gripper(drivers: dict[str, DriverConfig]) -> tuple[str, ParallelJawDriver]:
    """The one gripper model and its driver."""
    found = [(name, c) for name, c in drivers.items() if isinstance(c, ParallelJawDriver)]
    if len(found) != 1:
        raise TangleDrakeError("the scenario's model_drivers must have exactly one "
                               f"!ParallelJawDriver, not {len(found)}")
    return found[0]
