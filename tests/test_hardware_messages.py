"""LCM message checks: good messages pass, every kind of malformed one is refused with a reason."""

import math
import zlib

import numpy as np
import pytest
from drake import (
    lcmt_iiwa_command,
    lcmt_iiwa_status,
    lcmt_image,
    lcmt_image_array,
    lcmt_schunk_wsg_command,
    lcmt_schunk_wsg_status,
)
from pydrake.common.value import AbstractValue

from tangle_drake.lcm_io.messages import (
    Received,
    ValidatingSerializer,
    check_iiwa_command,
    check_iiwa_status,
    check_image_array,
    check_wsg_command,
    check_wsg_status,
    decode_and_check,
)


def iiwa_status(positions, num_joints=None) -> lcmt_iiwa_status:
    message = lcmt_iiwa_status()
    message.num_joints = len(positions) if num_joints is None else num_joints
    message.joint_position_measured = list(positions)
    for name in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                 "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(message, name, [0.0] * len(positions))
    return message


def image(pixel_format, channel_type, width=4, height=3, pixel_bytes=4,
          compression=lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED) -> lcmt_image:
    message = lcmt_image()
    message.width, message.height = width, height
    message.row_stride = width * pixel_bytes
    message.data = bytes(message.row_stride * height)
    message.size = len(message.data)
    message.pixel_format, message.channel_type = pixel_format, channel_type
    message.compression_method = compression
    return message


def image_array(*images: lcmt_image) -> lcmt_image_array:
    message = lcmt_image_array()
    message.images = list(images)
    message.num_images = len(images)
    return message


COLOR = (lcmt_image.PIXEL_FORMAT_RGBA, lcmt_image.CHANNEL_TYPE_UINT8)
DEPTH_32F = (lcmt_image.PIXEL_FORMAT_DEPTH, lcmt_image.CHANNEL_TYPE_FLOAT32)
DEPTH_16U = (lcmt_image.PIXEL_FORMAT_DEPTH, lcmt_image.CHANNEL_TYPE_UINT16)
STATUS = check_iiwa_status(15)


def test_good_messages_pass_and_come_back_encoded():
    data = iiwa_status(np.linspace(-1, 1, 15)).encode()
    assert decode_and_check(lcmt_iiwa_status, data, STATUS) == (data, None)
    command = lcmt_iiwa_command()
    command.num_joints, command.joint_position = 15, [0.1] * 15
    assert check_iiwa_command(15)(command) is None
    wsg = lcmt_schunk_wsg_command()
    wsg.target_position_mm, wsg.force = 45.0, 40.0
    assert check_wsg_command(0.045)(wsg) is None
    assert check_wsg_status(lcmt_schunk_wsg_status()) is None
    for depth, pixel_bytes in ((DEPTH_32F, 4), (DEPTH_16U, 2)):
        array = image_array(image(*COLOR), image(*depth, pixel_bytes=pixel_bytes))
        assert check_image_array(4, 3)(array) is None


@pytest.mark.parametrize(("data", "reason"), [
    (iiwa_status([0.0] * 7).encode(), "num_joints is 7, expected 15"),
    (iiwa_status([0.0] * 14 + [math.nan]).encode(),
     "joint_position_measured has non-finite values at [14]"),
    (iiwa_status([0.0] * 15).encode()[:-5], "does not decode as lcmt_iiwa_status"),
    (iiwa_status([0.0] * 15).encode() + b"\x00\x01", "2 stray bytes after"),
    (b"\xde\xad\xbe\xef" * 3, "does not decode as lcmt_iiwa_status"),
    (b"", "does not decode as lcmt_iiwa_status"),
    (lcmt_schunk_wsg_status().encode(), "does not decode as lcmt_iiwa_status"),
])
def test_malformed_status_is_refused_with_the_reason(data, reason):
    encoded, error = decode_and_check(lcmt_iiwa_status, data, STATUS)
    assert encoded == b""
    assert reason in error


def test_malformed_commands_are_refused():
    command = lcmt_iiwa_command()
    command.num_joints, command.joint_position = 15, [0.0] * 15
    command.num_torques, command.joint_torque = 3, [0.0] * 3
    assert "num_torques is 3" in check_iiwa_command(15)(command)
    wsg = lcmt_schunk_wsg_command()
    wsg.target_position_mm, wsg.force = 80.0, 40.0
    assert "outside [0, 45]" in check_wsg_command(0.045)(wsg)
    wsg.target_position_mm, wsg.force = math.nan, 40.0
    assert "target_position_mm nan" in check_wsg_command(0.045)(wsg)
    wsg.target_position_mm, wsg.force = 10.0, -1.0
    assert "force -1.0" in check_wsg_command(0.045)(wsg)
    status = lcmt_schunk_wsg_status()
    status.actual_position_mm = math.inf
    assert "non-finite" in check_wsg_status(status)


@pytest.mark.parametrize(("images", "reason"), [
    ([image(*COLOR)], "needs an RGB or RGBA colour image and a depth image"),
    ([image(lcmt_image.PIXEL_FORMAT_BGRA, lcmt_image.CHANNEL_TYPE_UINT8), image(*DEPTH_32F)],
     "needs an RGB or RGBA colour image"),
    ([image(*COLOR), image(*DEPTH_32F, width=8, pixel_bytes=4)],
     "depth image is 8x3, the camera is 4x3"),
    ([image(*COLOR), image(lcmt_image.PIXEL_FORMAT_DEPTH, lcmt_image.CHANNEL_TYPE_FLOAT64)],
     "depth image has channel type"),
    ([image(*COLOR), image(*DEPTH_16U, pixel_bytes=4)], "row_stride 16, expected 8"),
    ([image(*COLOR, compression=lcmt_image.COMPRESSION_METHOD_JPEG), image(*DEPTH_32F)],
     "colour image compression"),
    ([image(*COLOR), image(*DEPTH_32F, compression=lcmt_image.COMPRESSION_METHOD_ZLIB)],
     "depth image does not decompress"),
])
def test_malformed_image_arrays_are_refused(images, reason):
    assert reason in check_image_array(4, 3)(image_array(*images))


def test_image_whose_size_disagrees_with_its_data_is_refused():
    depth = image(*DEPTH_32F)
    depth.data = depth.data[:-4]
    depth.size = len(depth.data)
    assert "has 44 bytes of pixels, expected 48" in \
        check_image_array(4, 3)(image_array(image(*COLOR), depth))
    depth.data = zlib.compress(bytes(48))
    depth.size = len(depth.data)
    depth.compression_method = lcmt_image.COMPRESSION_METHOD_ZLIB
    assert check_image_array(4, 3)(image_array(image(*COLOR), depth)) is None


def test_serializer_keeps_the_last_good_message_across_bad_ones(caplog):
    serializer = ValidatingSerializer(lcmt_iiwa_status, STATUS, "NEXTAGE_STATUS")
    value = serializer.CreateDefaultValue()
    assert value.get_value() == Received()
    good = iiwa_status([0.5] * 15).encode()
    serializer.Deserialize(good, value)
    for bad in (b"garbage", iiwa_status([0.0] * 7).encode(), b"garbage"):
        serializer.Deserialize(bad, value)
    record = value.get_value()
    assert (record.valid, record.rejected, record.data) == (1, 3, good)
    assert "does not decode" in record.last_error
    assert "rejected message 1 on NEXTAGE_STATUS" in caplog.text
    assert "num_joints is 7" in caplog.text
    assert isinstance(value, AbstractValue)
