"""``tangle-drake graspability`` end to end, through the real command line."""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from tangle_drake.cli import main
from tangle_drake.graspability import GraspabilityParams, compute_candidates
from tangle_drake.graspability.synthetic import pile_field
from tangle_drake.perception.camera import (
    CameraIntrinsics,
    CameraModel,
    save_camera_json,
    top_view_pose,
)

FLOOR = 0.5
K = CameraIntrinsics.from_fov_y(320, 240, 45.0)
FIELDS = {"u", "v", "angle_deg", "width_m", "depth_m", "score"}


@pytest.fixture(scope="module")
def pile():
    field = pile_field(np.random.default_rng(5), K, n_parts=12, floor_depth_m=FLOOR)
    return field, field.render(K, FLOOR)


def run(capsys, *argv):
    code = main(["graspability", *map(str, argv)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_metric_depth_with_camera_json_next_to_it(tmp_path, pile, capsys):
    _, depth = pile
    np.save(tmp_path / "pile.npy", depth)
    cv2.imwrite(str(tmp_path / "pile.tiff"), depth)
    save_camera_json(tmp_path / "camera.json", CameraModel(K, top_view_pose(np.zeros(3), FLOOR)))
    out_json, overlays = tmp_path / "out" / "grasps.json", tmp_path / "overlays"
    code, out, err = run(capsys, tmp_path / "pile.npy", tmp_path / "pile.tiff", "--top-k", 3,
                         "--json", out_json, "--overlay", overlays)
    assert code == 0, err
    assert "pile.npy: 3 candidate(s)" in out
    results = json.loads(out_json.read_text())
    assert [r["image"] for r in results] == [str(tmp_path / "pile.npy"),
                                             str(tmp_path / "pile.tiff")]
    for result in results:
        assert result["compute_ms"] > 0
        assert len(result["candidates"]) == 3
        for c in result["candidates"]:
            assert set(c) == FIELDS | {"pose"}
            pose = np.array(c["pose"])
            assert pose.shape == (4, 4) and pose[3] == pytest.approx([0, 0, 0, 1])
            assert pose[:3, 2] == pytest.approx([0, 0, -1])  # approach = camera +z = down
            assert 0 <= c["angle_deg"] < 180 and 0 < c["score"] <= 1
            assert c["width_m"] == 0.045 and 0.4 < c["depth_m"] < FLOOR
    assert results[0]["candidates"] == results[1]["candidates"]
    pictures = sorted(p.name for p in overlays.iterdir())
    assert pictures == ["pile_grasps.png", "pile_grasps_2.png"]
    assert cv2.imread(str(overlays / "pile_grasps.png")).shape == (240, 320, 3)


def test_height_map_png(tmp_path, pile, capsys):
    field, _ = pile
    heights = cv2.resize(field.heights, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
    png = tmp_path / "heights.png"
    cv2.imwrite(str(png), np.rint(heights / 1e-4).astype(np.uint16))  # 0.1 mm, 1 mm pixels
    out_json = tmp_path / "out.json"
    code, out, err = run(capsys, png, "--height-per-level", 1e-4, "--pixel-size", 1e-3,
                         "--json", out_json, "--overlay", tmp_path)
    assert code == 0, err
    assert "heights.png: 5 candidate(s)" in out and "m high" in out
    (result,) = json.loads(out_json.read_text())
    assert len(result["candidates"]) == 5
    for c in result["candidates"]:
        assert set(c) == FIELDS | {"height_m"}  # no camera pose: no pose
        assert 0 < c["height_m"] < 0.08
    assert (tmp_path / "heights_grasps.png").is_file()
    code, _, err = run(capsys, png)
    assert code == 1 and "--height-per-level and --pixel-size" in err


def test_bad_files_are_reported_and_the_rest_still_run(tmp_path, pile, capsys):
    _, depth = pile
    good = tmp_path / "good.npy"
    np.save(good, depth)
    save_camera_json(tmp_path / "camera.json", CameraModel(K))
    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 40)
    eight_bit_tiff = tmp_path / "eight.tif"
    cv2.imwrite(str(eight_bit_tiff), np.zeros((240, 320), np.uint8))
    bool_npy = tmp_path / "mask.npy"
    np.save(bool_npy, depth > 0.45)
    broken_npy = tmp_path / "broken.npy"
    broken_npy.write_bytes(b"not numpy")
    wrong_size = tmp_path / "small.npy"
    np.save(wrong_size, depth[:100])
    out_json = tmp_path / "out.json"
    images = [corrupt, tmp_path / "missing.npy", good, eight_bit_tiff, bool_npy, broken_npy,
              wrong_size, tmp_path / "notes.txt"]
    code, out, err = run(capsys, *images, "--height-per-level", 1e-4, "--pixel-size", 1e-3,
                         "--json", out_json)
    assert code == 1
    assert "7 of 8 images failed" in err
    results = json.loads(out_json.read_text())
    assert [r["image"] for r in results] == [str(p) for p in images]
    errors = [r.get("error", "") for r in results]
    assert "cannot decode" in errors[0]
    assert "no such file" in errors[1]
    assert errors[2] == "" and len(results[2]["candidates"]) == 5
    assert "float metres" in errors[3]
    assert "numeric" in errors[4]
    assert "not a readable .npy" in errors[5]
    assert "intrinsics" in errors[6]
    assert "unsupported image type" in errors[7]
    assert "good.npy: 5 candidate(s)" in out


def test_metric_depth_without_a_camera(tmp_path, pile, capsys):
    _, depth = pile
    np.save(tmp_path / "pile.npy", depth)
    code, _, err = run(capsys, tmp_path / "pile.npy")
    assert code == 1 and "needs the camera intrinsics" in err
    (tmp_path / "broken.json").write_text("{")
    code, _, err = run(capsys, tmp_path / "pile.npy", "--camera", tmp_path / "broken.json")
    assert code == 1 and "not a valid camera" in err
    code, _, err = run(capsys, tmp_path / "pile.npy", "--top-k", 0)
    assert code == 2 and "--top-k" in err
    code, _, err = run(capsys, tmp_path / "pile.npy", "--grip-span", -0.01)
    assert code == 2 and "--grip-span" in err


def test_grip_span_option_runs_the_grip_test(tmp_path, pile, capsys):
    _, depth = pile
    np.save(tmp_path / "pile.npy", depth)
    camera = CameraModel(K, top_view_pose(np.zeros(3), FLOOR))
    save_camera_json(tmp_path / "camera.json", camera)
    found = {}
    for span in (None, 0.014):
        extra = () if span is None else ("--grip-span", span)
        code, _, err = run(capsys, tmp_path / "pile.npy", "--top-k", 10, "--json",
                           tmp_path / f"{span}.json", *extra)
        assert code == 0, err
        found[span] = json.loads((tmp_path / f"{span}.json").read_text())[0]["candidates"]
        params = GraspabilityParams(top_k=10, max_grip_span_m=span)
        expected = [c.to_dict() for c in compute_candidates(depth, camera, params=params)]
        assert found[span] == expected
    assert found[None] != found[0.014]


def test_the_scenes_own_depth_png_is_read_as_millimetres_and_colour_is_refused(
        tmp_path, pile, capsys):
    _, depth = pile
    save_camera_json(tmp_path / "camera.json", CameraModel(K, top_view_pose(np.zeros(3), FLOOR)))
    np.save(tmp_path / "depth.npy", depth)
    millimetres = np.nan_to_num(depth * 1000.0, nan=0.0, posinf=0.0)
    cv2.imwrite(str(tmp_path / "depth.png"), np.clip(millimetres, 0, 65535).astype(np.uint16))
    colour = np.dstack([np.full(depth.shape, v, np.uint8) for v in (10, 120, 240)])
    cv2.imwrite(str(tmp_path / "rgb.png"), colour)
    out = tmp_path / "grasps.json"
    code, _, err = run(capsys, tmp_path / "rgb.png", tmp_path / "depth.png",
                       tmp_path / "depth.npy", "--json", out)
    assert code == 1 and "colour image, not a height map" in err
    rgb, png, npy = json.loads(out.read_text())
    assert "error" in rgb
    # The same pile, read in millimetres: fingertips at the pile's depths, not 65 m deep.
    assert png["candidates"] and abs(len(png["candidates"]) - len(npy["candidates"])) <= 1
    assert max(c["depth_m"] for c in png["candidates"]) < FLOOR + 0.01
    best = png["candidates"][0]
    assert any(abs(best["u"] - c["u"]) < 3 and abs(best["v"] - c["v"]) < 3
               and abs(best["depth_m"] - c["depth_m"]) < 0.003 for c in npy["candidates"])


def test_a_bad_image_in_a_batch_is_reported_and_the_good_ones_still_written(
        tmp_path, pile, capsys):
    _, depth = pile
    save_camera_json(tmp_path / "camera.json", CameraModel(K, top_view_pose(np.zeros(3), FLOOR)))
    np.save(tmp_path / "far.npy", np.full(depth.shape, 1e9, np.float32))
    np.save(tmp_path / "good.npy", depth)
    out, overlays = tmp_path / "grasps.json", tmp_path / "overlays"
    code, _, err = run(capsys, tmp_path / "far.npy", tmp_path / "good.npy", "--json", out,
                       "--overlay", overlays)
    assert code == 1 and "coarser than the fingers" in err and "Traceback" not in err
    far, good = json.loads(out.read_text())
    assert "error" in far and good["candidates"]
    assert (overlays / "good_grasps.png").is_file()


def test_a_height_map_deeper_than_any_bin_is_warned_about(tmp_path, capsys):
    levels = np.zeros((120, 160), np.uint16)
    levels[40:80, 50:110] = 60000
    cv2.imwrite(str(tmp_path / "deep.png"), levels)
    _, _, err = run(capsys, tmp_path / "deep.png", "--height-per-level", 0.001,
                    "--pixel-size", 0.001)
    assert "span 60.00 m of height" in err


def test_emap_adds_each_candidates_entanglement_and_the_map_under_the_overlay(
        tmp_path, pile, capsys):
    _, depth = pile
    np.save(tmp_path / "pile.npy", depth)
    save_camera_json(tmp_path / "camera.json", CameraModel(K, top_view_pose(np.zeros(3), FLOOR)))
    heights = np.clip(255 * (FLOOR - depth) / 0.05, 0, 255).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "heights.png"), heights)  # brighter = higher, 8-bit
    out_json, overlays = tmp_path / "grasps.json", tmp_path / "overlays"
    args = ["--top-k", 3, "--json", out_json, "--overlay", overlays]
    assert run(capsys, tmp_path / "pile.npy", *args)[0] == 0
    plain = cv2.imread(str(overlays / "pile_grasps.png"))
    code, out, err = run(capsys, tmp_path / "pile.npy", tmp_path / "heights.png", "--emap",
                         "--height-per-level", 0.05 / 255, "--pixel-size", 0.001, *args)
    assert code == 0, err
    assert "entanglement map in" in out and "entanglement=" in out
    for result in json.loads(out_json.read_text()):
        assert result["emap_ms"] > 0
        assert all(0.0 <= c["entanglement"] <= 1.0 for c in result["candidates"])
    mapped = cv2.imread(str(overlays / "pile_grasps.png"))
    assert plain is not None and mapped is not None and mapped.shape == plain.shape
    assert (mapped != plain).any(axis=2).mean() > 0.3  # the map lies under the hands
    assert (overlays / "heights_grasps.png").is_file()


def test_an_image_with_no_valid_pixel_is_named(tmp_path, capsys):
    save_camera_json(tmp_path / "camera.json", CameraModel(K))
    blank = tmp_path / "blank.npy"
    np.save(blank, np.full((K.height, K.width), np.nan, np.float32))
    code, _, err = run(capsys, blank, "--json", tmp_path / "out.json")
    assert code == 1
    assert f"error: {blank}: depth image has no valid pixel" in err
    (result,) = json.loads((tmp_path / "out.json").read_text())
    assert result["error"].startswith(f"{blank}: ")


def test_a_size_mismatch_names_the_image_and_its_camera(tmp_path, pile, capsys):
    _, depth = pile
    camera_json = tmp_path / "camera.json"
    save_camera_json(camera_json, CameraModel(K))
    cropped = tmp_path / "cropped.npy"
    np.save(cropped, depth[:100])
    code, _, err = run(capsys, cropped)
    assert code == 1
    (line,) = [line for line in err.splitlines() if line.startswith("error:")]
    assert line.startswith(f"error: {cropped}: ")
    assert str(camera_json) in line
    assert f"{K.width}x100" in line and f"{K.width}x{K.height}" in line


def test_the_batch_summary_says_which_images_failed(tmp_path, pile, capsys):
    _, depth = pile
    save_camera_json(tmp_path / "camera.json", CameraModel(K))
    good, bad, blank = tmp_path / "good.npy", tmp_path / "bad.npy", tmp_path / "blank.npy"
    np.save(good, depth)
    bad.write_bytes(b"not numpy")
    np.save(blank, np.zeros_like(depth))
    code, out, err = run(capsys, bad, good, blank, "--top-k", 1)
    assert code == 1 and "good.npy: 1 candidate(s)" in out
    assert f"error: {bad}: " in err and f"error: {blank}: " in err
    (summary,) = [line for line in err.splitlines() if "images failed" in line]
    assert summary == f"2 of 3 images failed: {bad}, {blank}"


def _scene_depth_png(tmp_path, depth) -> tuple:
    """``tangle-drake scene``'s pair: depth.png (16-bit millimetres) and camera.json beside."""
    save_camera_json(tmp_path / "camera.json", CameraModel(K, top_view_pose(np.zeros(3), FLOOR)))
    png = tmp_path / "depth.png"
    cv2.imwrite(str(png), np.rint(np.nan_to_num(depth * 1000.0, nan=0.0)).astype(np.uint16))
    return png, FLOOR / K.fx  # the camera's pixel at the bin's floor


def test_a_depth_png_read_as_a_height_map_is_checked_against_its_camera(
        tmp_path, pile, capsys):
    _, depth = pile
    png, camera_pixel = _scene_depth_png(tmp_path, depth)
    out_json = tmp_path / "out.json"
    code, _, err = run(capsys, png, "--height-per-level", 0.0005, "--pixel-size", 0.0005,
                       "--json", out_json)
    assert code == 0, err  # a warning, not a refusal: it may be a height map after all
    (warning,) = [line for line in err.splitlines() if "contradicts its camera" in line]
    assert warning.startswith(f"warning: {png}: --pixel-size 0.0005")
    assert f"--pixel-size {camera_pixel:.4g} is consistent" in warning
    assert "drop --height-per-level and --pixel-size" in warning
    (result,) = json.loads(out_json.read_text())
    assert any("contradicts its camera" in w for w in result["warnings"])
    code, _, err = run(capsys, png, "--height-per-level", 0.0005, "--pixel-size",
                       round(camera_pixel, 6))
    assert code == 0 and "contradicts" not in err


def test_a_height_map_without_pixel_size_takes_its_cameras(tmp_path, pile, capsys):
    _, depth = pile
    png, camera_pixel = _scene_depth_png(tmp_path, depth)
    out_json = tmp_path / "out.json"
    code, _, err = run(capsys, png, "--height-per-level", 0.001, "--json", out_json)
    assert code == 0, err
    used = re.search(r"no --pixel-size: using ([0-9.e-]+) m, from (\S+):", err)
    assert used and float(used[1]) == pytest.approx(camera_pixel, rel=0.01)
    assert used[2] == str(tmp_path / "camera.json")
    assert json.loads(out_json.read_text())[0]["candidates"]
    (tmp_path / "camera.json").unlink()  # nothing to take it from: still refused
    code, _, err = run(capsys, png, "--height-per-level", 0.001)
    assert code == 1 and f"{png}: a height-map PNG needs --pixel-size" in err


def test_grasps_tens_of_metres_away_are_warned_about(tmp_path, pile, capsys):
    field, depth = pile
    png = tmp_path / "heights.png"
    cv2.imwrite(str(png), np.rint(field.heights / 0.0005).astype(np.uint16))
    code, out, err = run(capsys, png, "--height-per-level", 0.0005, "--pixel-size", 0.001)
    assert code == 0 and "candidate(s)" in out
    deepest = max(float(d) for d in re.findall(r"depth=([0-9.]+) m", out))
    assert deepest > 10
    assert f"warning: {png}: grasps {deepest:.1f} m deep" in err
    assert f"65535 x 0.0005 m = {65535 * 0.0005:.1f} m up" in err
    code, _, err = run(capsys, png, "--height-per-level", 0.0001, "--pixel-size", 0.001)
    assert code == 0 and "warning" not in err  # 6.6 m down from the top level: no alarm
    # Metric depth seen from 15 m (a camera that could resolve the fingers from there).
    far = CameraIntrinsics(K.width, K.height, K.fx * 30, K.fy * 30, K.cx, K.cy)
    save_camera_json(tmp_path / "camera.json", CameraModel(far))
    np.save(tmp_path / "far.npy", depth * 30)
    code, _, err = run(capsys, tmp_path / "far.npy")
    assert code == 0 and f"warning: {tmp_path / 'far.npy'}: grasps 1" in err
    assert "m from the camera" in err
