"""Meshcat opens on the work: the replay's initial camera frames the bin, with the arm."""

import base64
import re
import struct

import numpy as np
import pytest
from pydrake.geometry import Meshcat, MeshcatParams

from tangle_drake.pick.meshcat_view import (
    bin_corners,
    frame_coordinates,
    frame_share,
    frame_the_work,
    work_view,
)
from tangle_drake.scenario_files import resolve_scenario

MIN_SHARE = 0.06
"""The bin's corners must span at least this share of a 3:2 frame (a far side view from
(-3, 0, 1.5) m at the world origin: 0.1 %)."""


def _replay_vector(html: str, marker: bytes) -> np.ndarray:
    """The three doubles after ``marker`` in the replay's commands, in Drake's z-up frame."""
    for text in re.findall(r'base64,([A-Za-z0-9+/=]+)"', html):
        data = base64.b64decode(text)
        if marker in data:
            at = data.index(b"\x93", data.index(marker))  # a msgpack array of three
            x, y, z = (struct.unpack(">d", data[at + 2 + 9 * k:at + 10 + 9 * k])[0]
                       for k in range(3))
            return np.array([x, -z, y])  # three.js is y-up
    raise AssertionError(f"no {marker!r} in the replay")


@pytest.mark.parametrize("name", ["pick_demo.yaml", "floating_gripper.yaml"])
def test_the_replays_camera_frames_the_bin_and_the_arm(name):
    scenario = resolve_scenario(name)
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    frame_the_work(meshcat, scenario)
    html = meshcat.StaticHtml()
    camera = _replay_vector(html, b"/Cameras/default/rotated/<object>")
    target = _replay_vector(html, b"set_target")
    np.testing.assert_allclose(np.vstack([camera, target]), np.vstack(work_view(scenario)),
                               atol=1e-9)
    assert frame_share(camera, target, scenario.bin) >= MIN_SHARE
    assert (np.abs(frame_coordinates(camera, target, bin_corners(scenario.bin))) < 1).all()
    if name == "pick_demo.yaml":  # the Nextage's torso and the air above the bin in frame
        arm = frame_coordinates(camera, target, np.array([[0.0, 0.0, 1.1], [0.3, 0.2, 1.2]]))
        assert (np.abs(arm) < 1).all()
    # A far, side-on view like the one Meshcat opens on fills far less.
    assert frame_share(np.array([-3.0, 0.0, 1.5]), np.zeros(3), scenario.bin) < MIN_SHARE / 4
