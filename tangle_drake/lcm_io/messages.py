"""Decode and check the driver's LCM messages before Drake's C++ receivers see them.

Drake's receivers trust their input: an ``lcmt_iiwa_status`` with the wrong joint count throws
inside the simulator, and bytes that do not decode abort the whole process. A cable glitch or a
misconfigured driver must not do either, so every subscriber here decodes in Python first,
checks the message, and keeps the last good one; a bad one is counted, logged and dropped.

Status, images and sensor readings are also checked by their timestamp (one mechanism for
every such channel, :data:`STAMPS`): a message must be newer than the last one accepted. An
older one (out of order) is refused; one with the same stamp (a driver re-sending a frozen
status) is counted as a repeat and does not count as fresh, so the safety supervisor's
freshness rule sees through it.
"""

from __future__ import annotations

import logging
import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from drake import (
    lcmt_force_torque,
    lcmt_iiwa_command,
    lcmt_iiwa_status,
    lcmt_image,
    lcmt_image_array,
    lcmt_schunk_wsg_command,
    lcmt_schunk_wsg_status,
)
from pydrake.common.value import AbstractValue
from pydrake.systems.lcm import SerializerInterface

log = logging.getLogger(__name__)

Check = Callable[[object], "str | None"]
"""A message check: ``None`` if the decoded message is usable, else what is wrong with it."""

COLOR_CHANNELS = {lcmt_image.PIXEL_FORMAT_RGB: 3, lcmt_image.PIXEL_FORMAT_RGBA: 4}
"""Colour formats the station reads (8-bit channels), and their channel counts."""
DEPTH_DTYPES = {lcmt_image.CHANNEL_TYPE_FLOAT32: "<f4", lcmt_image.CHANNEL_TYPE_UINT16: "<u2"}
"""Depth channel types the station reads: 32F metres or 16U millimetres, little-endian."""


STAMPS: dict[type, Callable[[object], int]] = {
    lcmt_iiwa_status: lambda message: message.utime,
    lcmt_schunk_wsg_status: lambda message: message.utime,
    lcmt_image_array: lambda message: message.header.utime,
    lcmt_force_torque: lambda message: message.timestamp,
}
"""The timestamp (µs, the sender's clock) of every message kind checked for freshness."""


@dataclass(frozen=True)
class Received:
    """What one subscriber has taken from its channel so far."""

    valid: int = 0
    """Messages accepted (each newer than the one before, where the kind has a stamp)."""
    rejected: int = 0
    """Messages refused (undecodable, wrong sizes, non-finite values, out of order, ...)."""
    repeated: int = 0
    """Messages that repeated the last accepted one's stamp: dropped, and not fresh."""
    data: bytes = b""
    """The last accepted message, encoded; empty before the first."""
    stamp: int | None = None
    """The last accepted message's timestamp, µs."""
    last_error: str = ""
    """Why the last refused message was refused."""


class ValidatingSerializer(SerializerInterface):
    """An ``LcmSubscriberSystem`` serializer whose value is a :class:`Received` record.

    ``Deserialize`` gets the subscriber's previous record as ``abstract_value``, so the record
    keeps the last good message across bad ones without any state outside the context.
    """

    def __init__(self, lcm_type: type, check: Check, channel: str) -> None:
        SerializerInterface.__init__(self)
        self._lcm_type = lcm_type
        self._check = check
        self._channel = channel

    def CreateDefaultValue(self) -> AbstractValue:
        return AbstractValue.Make(Received())

    def Deserialize(self, buffer: bytes, abstract_value: AbstractValue) -> None:
        previous: Received = abstract_value.get_value()
        data = bytes(buffer)
        encoded, error = decode_and_check(self._lcm_type, data, self._check)
        stamp = None
        if error is None and self._lcm_type in STAMPS:
            stamp = int(STAMPS[self._lcm_type](self._lcm_type.decode(encoded)))
            if previous.stamp is not None and stamp == previous.stamp:
                abstract_value.set_value(replace(previous, repeated=previous.repeated + 1))
                return
            if previous.stamp is not None and stamp < previous.stamp:
                error = f"out of order: stamp {stamp} µs after {previous.stamp} µs"
        if error is None:
            abstract_value.set_value(replace(previous, valid=previous.valid + 1, data=encoded,
                                             stamp=stamp))
            return
        rejected = previous.rejected + 1
        # Log the first of a kind and then sparsely, so a misconfigured driver at 200 Hz
        # does not flood the console.
        if error != previous.last_error or rejected & (rejected - 1) == 0:
            log.warning("rejected message %d on %s: %s", rejected, self._channel, error)
        abstract_value.set_value(replace(previous, rejected=rejected, last_error=error))

    def Serialize(self, abstract_value: AbstractValue) -> bytes:
        raise NotImplementedError("ValidatingSerializer is for subscribers only")


def decode_and_check(lcm_type: type, data: bytes, check: Check) -> tuple[bytes, str | None]:
    """``(encoded, None)`` for a usable message, ``(b"", reason)`` otherwise.

    ``encoded`` is the message encoded again: Drake's C++ decoder demands that a message use
    every byte, which Python's decoder does not check.
    """
    try:
        message = lcm_type.decode(data)
        encoded = message.encode()
    except Exception as error:  # any decoding failure means a bad message
        return b"", f"does not decode as {lcm_type.__name__} ({type(error).__name__}: {error})"
    error = f"{len(data) - len(encoded)} stray bytes after the {lcm_type.__name__}" \
        if len(encoded) != len(data) else check(message)
    return (b"", error) if error else (encoded, None)


def check_iiwa_status(num_joints: int) -> Check:
    """Checks an ``lcmt_iiwa_status``: the joint count and finite positions and velocities."""
    def check(message: lcmt_iiwa_status) -> str | None:
        if message.num_joints != num_joints:
            return f"num_joints is {message.num_joints}, expected {num_joints}"
        return (_non_finite("joint_position_measured", message.joint_position_measured)
                or _non_finite("joint_velocity_estimated", message.joint_velocity_estimated)
                or _non_finite("joint_position_commanded", message.joint_position_commanded))
    return check


def check_iiwa_command(num_joints: int) -> Check:
    """Checks an ``lcmt_iiwa_command``: position-only or position + torque, all finite."""
    def check(message: lcmt_iiwa_command) -> str | None:
        if message.num_joints != num_joints:
            return f"num_joints is {message.num_joints}, expected {num_joints}"
        if message.num_torques not in (0, num_joints):
            return f"num_torques is {message.num_torques}, expected 0 or {num_joints}"
        return (_non_finite("joint_position", message.joint_position)
                or _non_finite("joint_torque", message.joint_torque))
    return check


def check_force_torque(message: lcmt_force_torque) -> str | None:
    """Checks an ``lcmt_force_torque``: six finite values."""
    return _non_finite("force/torque", [message.fx, message.fy, message.fz, message.tx,
                                        message.ty, message.tz])


def check_wsg_status(message: lcmt_schunk_wsg_status) -> str | None:
    """Checks an ``lcmt_schunk_wsg_status``: finite width, rate and force."""
    return _non_finite("status", [message.actual_position_mm, message.actual_speed_mm_per_s,
                                  message.actual_force])


def check_wsg_command(max_width: float) -> Check:
    """Checks an ``lcmt_schunk_wsg_command``: a width in [0, ``max_width``] m, a force >= 0."""
    def check(message: lcmt_schunk_wsg_command) -> str | None:
        width_mm, force = message.target_position_mm, message.force
        if not 0.0 <= width_mm <= max_width * 1e3:
            return f"target_position_mm {width_mm!r} outside [0, {max_width * 1e3:g}]"
        if not (math.isfinite(force) and force >= 0.0):
            return f"force {force!r} is not a finite force >= 0"
        return None
    return check


def check_image_array(width: int, height: int) -> Check:
    """Checks an ``lcmt_image_array``: its first RGB/RGBA image and its first depth image
    exist, match the scenario's camera size (the intrinsics perception uses), and hold
    exactly their pixels, uncompressed or zlib-compressed."""
    def check(message: lcmt_image_array) -> str | None:
        color = next((i for i in message.images if i.pixel_format in COLOR_CHANNELS), None)
        depth = next((i for i in message.images
                      if i.pixel_format == lcmt_image.PIXEL_FORMAT_DEPTH), None)
        if color is None or depth is None:
            return "needs an RGB or RGBA colour image and a depth image"
        if color.channel_type != lcmt_image.CHANNEL_TYPE_UINT8:
            return f"colour image has channel type {color.channel_type}, expected 8-bit"
        if depth.channel_type not in DEPTH_DTYPES:
            return (f"depth image has channel type {depth.channel_type}; use 32F metres or "
                    "16U millimetres")
        if depth.bigendian:
            return "depth image is big-endian"
        return (_image_problem("colour", color, COLOR_CHANNELS[color.pixel_format], width,
                               height)
                or _image_problem("depth", depth,
                                  np.dtype(DEPTH_DTYPES[depth.channel_type]).itemsize, width,
                                  height))
    return check


def image_bytes(image: lcmt_image) -> bytes:
    """The pixels of ``image``, decompressed if it was sent with zlib."""
    data = bytes(image.data[:image.size])
    if image.compression_method == lcmt_image.COMPRESSION_METHOD_ZLIB:
        return zlib.decompress(data)
    return data


def _image_problem(kind: str, image: lcmt_image, pixel_bytes: int, width: int,
                   height: int) -> str | None:
    if (image.width, image.height) != (width, height):
        return f"{kind} image is {image.width}x{image.height}, the camera is {width}x{height}"
    if image.row_stride != width * pixel_bytes:
        return f"{kind} image row_stride {image.row_stride}, expected {width * pixel_bytes}"
    if image.compression_method not in (lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED,
                                        lcmt_image.COMPRESSION_METHOD_ZLIB):
        return (f"{kind} image compression {image.compression_method} is not supported "
                "(send it uncompressed or zlib)")
    try:
        size = len(image_bytes(image))
    except zlib.error as error:
        return f"{kind} image does not decompress ({error})"
    if size != height * image.row_stride:
        return f"{kind} image has {size} bytes of pixels, expected {height * image.row_stride}"
    return None


def _non_finite(name: str, values: Sequence[float]) -> str | None:
    bad = [i for i, value in enumerate(values) if not math.isfinite(value)]
    return f"{name} has non-finite values at {bad}" if bad else None
