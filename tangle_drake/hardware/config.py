"""The scenario's LCM buses and ``hardware`` section: the rates and timeouts of the LCM link.

Loaded with the rest of :class:`tangle_drake.scenario.Scenario` by Drake's ``yaml_load_typed``.
The default bus is in-process (``memq://``): a scenario must name a network URL on purpose
before anything leaves the process (see ``docs/hardware.md``).
"""

# No `from __future__ import annotations`: Drake's YAML loader needs real field types.

from dataclasses import dataclass

from pydrake.lcm import DrakeLcmParams

from tangle_drake.errors import TangleDrakeError

IN_PROCESS_URL = "memq://"
"""LCM's in-process transport: messages never leave the process that made the ``DrakeLcm``."""

DEPTH_FORMATS = ("32F", "16U")


def default_lcm_buses() -> dict[str, DrakeLcmParams]:
    """One bus, ``default``, in-process only (Drake's own default would be UDP multicast)."""
    return {"default": DrakeLcmParams(lcm_url=IN_PROCESS_URL)}


@dataclass
class HardwareConfig:
    """How fast and how fresh the LCM link between the station and the robot's drivers is
    (``build_station(..., hardware=True)``). Which bus and channel each model's messages use
    is its driver's (``model_drivers``); the camera's bus is ``camera.lcm_bus``."""

    command_period: float = 0.005
    """Seconds between command messages (200 Hz, the rate of the robot's servo loop)."""
    status_period: float = 0.005
    """Seconds between status messages from the hardware simulator (200 Hz)."""
    camera_period: float = 0.2
    """Seconds between image messages from the hardware simulator (5 Hz)."""
    depth_format: str = "32F"
    """How the hardware simulator sends depth: ``32F`` metres, or ``16U`` millimetres (0: too
    close or nothing seen, 65535: too far), as most depth-camera drivers do."""
    status_timeout: float = 0.1
    """Arm or gripper status older than this (s) stops the robot: it holds its measured pose."""
    startup_timeout: float = 5.0
    """Wall-clock seconds the controller waits at start for the first status and image
    (``HardwareStation.initialize``)."""
    tracking_tolerance: float = 0.03
    """A joint may trail its command by this much (rad or m) at any speed..."""
    tracking_lag: float = 0.1
    """...or by its commanded speed times this, s (the servos' lag)..."""
    tracking_time: float = 0.2
    """...and by more for at most this long, s, before the arm is held (it is blocked, or
    the driver does not follow). Measured on the hardware simulator: the scripted move and the
    picks stay within 0.02 rad of these bounds (tests/test_hardware_loop.py)."""

    def validate(self, where: str) -> None:
        """Refuse values the station cannot run with, naming the field."""
        for name in ("command_period", "status_period", "camera_period", "status_timeout",
                     "tracking_tolerance", "tracking_lag", "tracking_time"):
            if not getattr(self, name) > 0:
                raise TangleDrakeError(f"scenario field '{where}.{name}' must be positive")
        if self.startup_timeout < 0:
            raise TangleDrakeError(f"scenario field '{where}.startup_timeout' must be >= 0")
        if self.status_timeout < 2 * max(self.command_period, self.status_period):
            raise TangleDrakeError(f"scenario field '{where}.status_timeout' must be at least "
                                   "two status and command periods")
        if self.depth_format not in DEPTH_FORMATS:
            raise TangleDrakeError(f"scenario field '{where}.depth_format' must be one of "
                                   f"{', '.join(DEPTH_FORMATS)}")
