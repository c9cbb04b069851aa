"""The scenario's LCM buses and ``hardware`` section: the rates and timeouts of the LCM link.

Loaded with the rest of :class:`tangle_drake.scenario.Scenario` by Drake's ``yaml_load_typed``.
The default bus is in-process (``memq://``): a scenario must name a network URL on purpose
before anything leaves the process (see ``docs/hardware.md``).
"""

# No `from __future__ import annotations`: Drake's YAML loader needs real field types.

import ipaddress
import os
from dataclasses import dataclass

from pydrake.lcm import DrakeLcmParams

from tangle_drake.common.errors import TangleDrakeError

IN_PROCESS_URL = "memq://"
"""LCM's in-process transport: messages never leave the process that made the ``DrakeLcm``."""

DEPTH_FORMATS = ("32F", "16U")

LCM_PROVIDERS = ("udpm", "mpudpm", "memq", "tcpq", "file")
"""The transports LCM knows; for any other, LCM only prints a line and sends nothing."""
LCM_DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
"""LCM's own default, for an empty ``lcm_url`` with no ``LCM_DEFAULT_URL`` in the
environment."""


def check_lcm_url(url: str, where: str) -> None:
    """Refuse, naming ``where``, a URL that LCM cannot open: LCM itself prints a line and goes
    on, so a process would say it serves a bus that carries nothing."""
    url = url or os.environ.get("LCM_DEFAULT_URL") or LCM_DEFAULT_URL
    provider, separator, rest = url.partition("://")
    if not separator or provider not in LCM_PROVIDERS:
        raise TangleDrakeError(f"scenario field '{where}' is {url!r}: an LCM URL starts with "
                               f"one of {', '.join(p + '://' for p in LCM_PROVIDERS)}")
    if provider not in ("udpm", "mpudpm"):
        return
    address, _, options = rest.partition("?")
    host, _, port = address.partition(":")
    try:
        multicast = ipaddress.IPv4Address(host).is_multicast
    except ValueError:
        multicast = False
    if not multicast:
        raise TangleDrakeError(f"scenario field '{where}' is {url!r}: {host!r} is no IPv4 "
                               "multicast address (224.0.0.0 to 239.255.255.255)")
    if port and not (port.isdigit() and 0 < int(port) < 65536):
        raise TangleDrakeError(f"scenario field '{where}' is {url!r}: port {port!r} is not "
                               "a number from 1 to 65535")
    for option in filter(None, options.split("&")):
        key, _, value = option.partition("=")
        if key == "ttl" and not (value.isdigit() and int(value) < 256):
            raise TangleDrakeError(f"scenario field '{where}' is {url!r}: ttl must be a "
                                   "number from 0 to 255")


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
    command_timeout: float = 0.25
    """The robot side's watchdog (``hardware-sim``; a real driver's duty in
    ``docs/hardware.md``): once commands have begun, a command channel silent this long (s)
    makes the arm hold the pose it measures then, until commands come again."""
    startup_timeout: float = 30.0
    """Wall-clock seconds the controller waits at start for the first status and image
    (``HardwareStation.initialize``): long enough for a robot, or ``hardware-sim`` settling
    its pile, started after the controller."""
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
                     "command_timeout",
                     "tracking_tolerance", "tracking_lag", "tracking_time"):
            if not getattr(self, name) > 0:
                raise TangleDrakeError(f"scenario field '{where}.{name}' must be positive")
        if self.startup_timeout < 0:
            raise TangleDrakeError(f"scenario field '{where}.startup_timeout' must be >= 0")
        for name in ("status_timeout", "command_timeout"):
            if getattr(self, name) < 2 * max(self.command_period, self.status_period):
                raise TangleDrakeError(f"scenario field '{where}.{name}' must be at least two "
                                       "status and command periods")
        if self.depth_format not in DEPTH_FORMATS:
            raise TangleDrakeError(f"scenario field '{where}.depth_format' must be one of "
                                   f"{', '.join(DEPTH_FORMATS)}")
