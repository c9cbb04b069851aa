"""The scenario's LCM buses and ``hardware`` section: channels, rates and timeouts of the driver.

Loaded with the rest of :class:`tangle_drake.scenario.Scenario` by Drake's ``yaml_load_typed``.
The default bus is in-process (``memq://``): a scenario must name a network URL on purpose
before anything leaves the process (see ``docs/hardware.md``).
"""

# No `from __future__ import annotations`: Drake's YAML loader needs real field types.

from dataclasses import dataclass
from typing import TYPE_CHECKING

from pydrake.lcm import DrakeLcmParams

from tangle_drake.errors import TangleDrakeError
from tangle_drake.gripper import DEFAULT_GRIPPER

if TYPE_CHECKING:
    from tangle_drake.scenario import Scenario

IN_PROCESS_URL = "memq://"
"""LCM's in-process transport: messages never leave the process that made the ``DrakeLcm``."""

DEPTH_FORMATS = ("32F", "16U")


def network_bus_url(scenario: "Scenario", instead: str) -> str:
    """The URL of the scenario's hardware bus, refused if no other process can reach it (a
    controller or simulator on ``memq://`` alone would wait forever); ``instead`` says what to
    do then."""
    bus = scenario.hardware.lcm_bus
    url = scenario.lcm_buses[bus].lcm_url
    if url.startswith(IN_PROCESS_URL):
        raise TangleDrakeError(
            f"the scenario's LCM bus {bus!r} is {url!r}, which no other process can reach; "
            f"set lcm_buses.{bus}.lcm_url to the robot network's URL (see docs/hardware.md), "
            f"or {instead}")
    return url or "the default LCM URL"


def default_lcm_buses() -> dict[str, DrakeLcmParams]:
    """One bus, ``default``, in-process only (Drake's own default would be UDP multicast)."""
    return {"default": DrakeLcmParams(lcm_url=IN_PROCESS_URL)}


@dataclass
class HardwareConfig:
    """How the station talks to the robot's drivers (``build_station(..., hardware=True)``)."""

    lcm_bus: str = "default"
    """Name of the bus in the scenario's ``lcm_buses`` that carries every channel below."""
    nextage_command_channel: str = "NEXTAGE_COMMAND"
    """``lcmt_iiwa_command``, 15 joint positions in ``NEXTAGE_JOINTS`` order, rad."""
    nextage_status_channel: str = "NEXTAGE_STATUS"
    """``lcmt_iiwa_status`` for the same 15 joints (rad, rad/s)."""
    wsg_command_channel: str = "WSG_COMMAND"
    """``lcmt_schunk_wsg_command``: opening width between the finger pads in mm, force in N."""
    wsg_status_channel: str = "WSG_STATUS"
    """``lcmt_schunk_wsg_status``: measured width (mm) and its rate (mm/s)."""
    camera_channel: str = "DRAKE_RGBD_CAMERA_IMAGES"
    """``lcmt_image_array`` with one colour (RGB/RGBA 8-bit) and one depth image."""
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
    gripper_force_limit: float = DEFAULT_GRIPPER.grip_force
    """Grip force limit sent with every gripper command, N."""

    def validate(self, where: str, bus_names: list[str]) -> None:
        """Refuse values the station cannot run with, naming the field."""
        if self.lcm_bus not in bus_names:
            raise TangleDrakeError(f"scenario field '{where}.lcm_bus' names no bus in "
                                   f"'lcm_buses' ({', '.join(sorted(bus_names)) or 'none'})")
        channels = [self.nextage_command_channel, self.nextage_status_channel,
                    self.wsg_command_channel, self.wsg_status_channel, self.camera_channel]
        if not all(channels) or len(set(channels)) != len(channels):
            raise TangleDrakeError(f"scenario field '{where}': the five channel names must be "
                                   "non-empty and different")
        for name in ("command_period", "status_period", "camera_period", "status_timeout",
                     "gripper_force_limit"):
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
