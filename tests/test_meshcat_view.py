"""Meshcat opens on the work: the replay's initial camera frames the bin, with the arm."""

import base64
import re
import shutil
import struct
import subprocess
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from pydrake.geometry import Meshcat, MeshcatParams

from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.pick.meshcat_view import (
    CHOSEN_RGBA,
    ROOT,
    CandidateMarkers,
    bin_corners,
    frame_coordinates,
    frame_share,
    frame_the_work,
    work_view,
)
from tangle_drake.pick.outcome import PickRecord, PickView
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.rules import ScoredCandidate
from tangle_drake.station import build_station
from tangle_drake.station.pile import settle_pile

MIN_SHARE = 0.04
"""The bin's corners must span at least this share of a 3:2 frame (a far side view from
(-3, 0, 1.5) m at the world origin: 0.1 %)."""
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


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


class SpyMeshcat:
    """Records what ``CandidateMarkers`` asks Meshcat to do."""

    def __init__(self) -> None:
        self.objects: dict[str, object] = {}
        self.visible: dict[str, list[tuple[float | None, bool]]] = {}

    def SetObject(self, path, shape, rgba) -> None:
        self.objects[path] = rgba

    def SetTransform(self, path, X) -> None:
        assert path in self.objects

    def SetProperty(self, path, name, value, time_in_recording=None) -> None:
        assert name == "visible"
        self.visible.setdefault(path, []).append((time_in_recording, value))

    def shown_at(self, path: str, t: float) -> bool:
        """The replay's visibility of ``path`` at ``t``: its last key at or before ``t``."""
        keys = [(when, value) for when, value in self.visible[path] if when <= t]
        return max(keys, key=lambda key: key[0])[1] if keys else True


def _record(index: int, n: int) -> PickRecord:
    candidates = [SimpleNamespace(u=10.0 * k, v=0.0, score=1.0 - 0.1 * k,
                                  pose=np.eye(4) + np.pad([[0, 0, 0, 0.1 * k]], ((0, 3), (0, 0))))
                  for k in range(n)]
    view = PickView(np.zeros((4, 4)), [ScoredCandidate(c, 0.5, 0.5) for c in candidates])
    return PickRecord(index=index, candidate=candidates[1], view=view)


def test_each_picks_candidates_show_during_that_pick_only():
    meshcat = SpyMeshcat()
    markers = CandidateMarkers(meshcat)
    first, second = _record(1, 3), _record(2, 5)
    markers.update(first, 1.0, recording=True)
    markers.update(first, 2.0, recording=True)  # the same pick: nothing new
    markers.update(None, 12.0, recording=True)  # between picks: nothing shown
    markers.update(second, 13.0, recording=True)
    assert len([p for p in meshcat.objects if p.startswith(f"{ROOT}/pick_1/")]) == 3 * 3
    assert len([p for p in meshcat.objects if p.startswith(f"{ROOT}/pick_2/")]) == 5 * 3
    assert meshcat.objects[f"{ROOT}/pick_1/1/closing"] == CHOSEN_RGBA  # the chosen one
    assert meshcat.objects[f"{ROOT}/pick_1/0/closing"] != CHOSEN_RGBA
    for t, shown in ((0.5, []), (5.0, [1]), (12.5, []), (14.0, [2])):
        assert [i for i in (1, 2) if meshcat.shown_at(f"{ROOT}/pick_{i}", t)] == shown, t


def test_the_demos_replay_draws_the_candidates(tmp_path):
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    CandidateMarkers(meshcat).update(_record(1, 2), 1.0, recording=False)
    html = meshcat.StaticHtml()
    assert any(b"/candidates/pick_1/1/closing" in base64.b64decode(text)
               for text in re.findall(r'base64,([A-Za-z0-9+/=]+)"', html))


@pytest.mark.skipif(CHROMIUM is None, reason="no browser: apt-get install chromium (Debian's "
                                             "package; .ci/run installs it)")
def test_a_browser_opens_the_replay_on_the_bins_contents(tmp_path):
    scenario = resolve_scenario("pick_demo.yaml")
    scenario.view_cameras = []
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    station = build_station(scenario, meshcat)
    frame_the_work(meshcat, scenario)
    settle_pile(station, scenario, 0)
    picture = _screenshot(meshcat.StaticHtml(), None, tmp_path / "shot.png")
    camera, target = work_view(scenario)
    (x, y), = frame_coordinates(camera, target, np.array([[*scenario.bin.center,
                                                           scenario.bin.floor_height]]))
    u, v = int((x + 1) / 2 * 1200), int((1 - y) / 2 * 800)
    assert 0 <= u < 1200 and 0 <= v < 800
    around = picture[max(v - 60, 0):v + 60, max(u - 60, 0):u + 60]
    blue, green, red = around[..., 0], around[..., 1], around[..., 2]
    parts = (red > blue + 60) & (green > blue + 20)  # the parts' orange, not the grey scene
    assert parts.mean() > 0.05, parts.mean()
    corner = picture[:80, :80]
    assert (np.abs(around.mean(axis=(0, 1)) - corner.mean(axis=(0, 1))) > 10).any()


_REPLAY_COMMAND = re.compile(
    r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)\s*'
    r'\.then\(res => res\.arrayBuffer\(\)\)\s*'
    r'\.then\(buffer => viewer\.handle_command_bytearray\(new Uint8Array\(buffer\)\)\);')


def _screenshot(html: str, seek: float | None, out) -> np.ndarray:
    """The replay in headless Chromium at 1200 x 800, paused at ``seek`` s (if given).

    The replay hands its commands to the viewer in fetch() promises, which end after the page
    loads; waiting for them with --virtual-time-budget hung Chromium 150 in 4 of 10 runs. So
    the commands are handed over as the page is read, and the page is whole when it loads.
    """
    html, count = _REPLAY_COMMAND.subn(
        lambda found: "viewer.handle_command_bytearray(Uint8Array.from(atob("
                      f'"{found.group(1)}"), c => c.charCodeAt(0)));', html)
    assert count > 0, "the replay's commands are no longer in fetch() calls"
    if seek is not None:  # pause the replay there, so nothing moves when the shot is taken
        html = html.replace("</body>", "<script>viewer.animator.pause(); "
                            f"viewer.animator.seek({seek}); viewer.set_dirty();</script></body>")
    page = out.with_suffix(".html")
    page.write_text(html)
    subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu",
                    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                    "--window-size=1200,800", f"--screenshot={out}", page.as_uri()],
                   check=True, capture_output=True, timeout=120)
    return cv2.imread(str(out)).astype(int)


@pytest.mark.skipif(CHROMIUM is None, reason="no browser: apt-get install chromium (Debian's "
                                             "package; .ci/run installs it)")
def test_the_replay_shows_pick_2s_candidates_not_pick_1s_at_pick_2s_time(tmp_path):
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario.view_cameras = []
    scenario.pile.parts[0].count = 5
    records = run_demo(DemoOptions(picks=2, scenario=scenario, seed=2,
                                   record=tmp_path / "demo.html"), lambda _: None)
    first, second = records[:2]
    html = (tmp_path / "demo.html").read_text()
    camera, target = work_view(scenario)

    def green_near(picture: np.ndarray, record: PickRecord) -> float:
        (x, y), = frame_coordinates(camera, target, record.candidate.pose[None, :3, 3])
        u, v = int((x + 1) / 2 * 1200), int((1 - y) / 2 * 800)
        around = picture[max(v - 25, 0):v + 25, max(u - 25, 0):u + 25]
        blue, green, red = around[..., 0], around[..., 1], around[..., 2]
        chosen = (green > 190) & (green > red + 40) & (green > blue + 80)  # its green
        return float(chosen.mean())

    for now, other in ((first, second), (second, first)):
        picture = _screenshot(html, now.timing.started_at + 0.1,
                              tmp_path / f"pick_{now.index}.png")
        assert green_near(picture, now) > 0.005, now.index
        assert green_near(picture, other) == 0.0, now.index
