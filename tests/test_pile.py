"""Piles: every built-in part settles inside the bin, the camera sees it in metres, seeds repeat."""

import numpy as np
import pytest

from tangle_drake.common.paths import diagrams_dir
from tangle_drake.parts import BUILTIN_PARTS
from tangle_drake.scenario import PartCount, load_scenario
from tangle_drake.station import part_bodies
from tangle_drake.station.bin_model import inside_bin
from tangle_drake.station.scene import make_scene


def _scenario(part: str, count: int = 15, seed: int = 0):
    scenario = load_scenario(diagrams_dir() / "pile_only.yaml")
    scenario.pile.parts = [PartCount(part=part, count=count)]
    scenario.pile.seed = seed
    return scenario


@pytest.mark.parametrize("part", BUILTIN_PARTS)
def test_pile_of_15_settles_inside_the_bin_and_shows_in_depth(part):
    scenario = _scenario(part)
    scene = make_scene(scenario)
    report = scene.report
    assert report.settled
    assert report.parked == []
    assert report.num_in_bin == 15
    poses = scene.part_poses()
    assert len(poses) == 15
    centres = np.array([np.array(X)[:3, 3] for X in poses.values()])
    assert inside_bin(scenario.bin, centres).all()
    assert report.max_penetration <= scenario.pile.max_penetration

    depth = scene.depth
    assert depth.dtype == np.float32 and depth.shape == (480, 640)
    # Metres: the floor reads the camera's height above it, parts read less.
    centre = depth[200:280, 280:360]
    assert np.nanmax(depth) == pytest.approx(scene.floor_depth, abs=0.002)
    above = np.isfinite(depth) & (depth < scene.floor_depth - 0.003)
    assert above.sum() > 5000
    assert np.isfinite(centre).all()
    # The renderer labels each pixel with its body's index: the parts are what is above the floor.
    labels = scene.label_image()
    plant = scene.station.plant
    visible = [b for b in part_bodies(plant) if (labels == int(b.index())).sum() > 50]
    assert len(visible) >= 12
    for body in visible:
        assert np.nanmedian(depth[labels == int(body.index())]) < scene.floor_depth - 0.003


def test_same_seed_gives_the_same_pile_and_another_seed_does_not():
    first = make_scene(_scenario("c_ring", count=6, seed=3)).part_poses()
    again = make_scene(_scenario("c_ring", count=6, seed=3)).part_poses()
    other = make_scene(_scenario("c_ring", count=6, seed=4)).part_poses()
    for name in first:
        np.testing.assert_allclose(first[name], again[name], atol=1e-9)
    assert any(not np.allclose(first[name], other[name], atol=1e-3) for name in first)


def test_a_pile_that_cannot_be_made_or_picked_is_refused_before_any_simulation():
    from dataclasses import replace

    from tangle_drake.common.errors import TangleDrakeError
    from tangle_drake.robot_model.gripper import GripperSpec
    from tangle_drake.scenario import PartCount
    from tangle_drake.scenario.files import resolve_scenario
    from tangle_drake.station.pile import check_pile

    scenario = resolve_scenario("pick_demo.yaml")

    def with_pile(part="u_hook", count=15, scale=1.0):
        return replace(scenario, pile=replace(scenario.pile, parts=[PartCount(part, count,
                                                                              scale)]))

    assert check_pile(with_pile()) == []
    with pytest.raises(TangleDrakeError, match=r"too large for the bin.*--mesh-scale"):
        check_pile(with_pile(scale=6.0))
    with pytest.raises(TangleDrakeError, match=r"more than the gripper's 0\.1 N fingers"):
        check_pile(with_pile(), GripperSpec(grip_force=0.1))
    with pytest.raises(TangleDrakeError, match=r"1200 parts would fill .* times its 8 cm walls"):
        check_pile(with_pile(count=1200))
    # tools/bin_fill.py: 100 U-hooks top out at 7.6 cm in this bin, 40 J-hooks at 9.0 cm
    assert check_pile(with_pile(count=100)) == []
    (warning,) = check_pile(with_pile("j_hook", count=40))
    assert "above the bin's 8 cm walls" in warning



def test_bench_refuses_a_part_too_large_for_the_bin_up_front(tmp_path):
    from tangle_drake.bench.runner import BenchOptions, plan
    from tangle_drake.common.errors import TangleDrakeError
    from tangle_drake.common.paths import diagrams_dir

    text = (diagrams_dir() / "floating_gripper.yaml").read_text().replace(
        "  - part: u_hook\n    count: 15", "  - part: u_hook\n    count: 15\n    mesh_scale: 6")
    big = tmp_path / "big.yaml"
    big.write_text(text)
    with pytest.raises(TangleDrakeError, match="too large for the bin"):
        plan(BenchOptions(scenario=str(big), workers=1, methods=["graspability"]))


def test_parts_dropped_above_the_rim_of_a_full_bin_keep_inside_its_walls():
    """``pile.drop_inside_walls``: a part placed higher than the rim keeps its bounding radius
    inside the walls (none lands hanging on the rim); lower ones use the whole floor from the
    same draws, so a pile that never rises above the rim does not change."""
    from dataclasses import replace

    from pydrake.systems.analysis import Simulator

    from tangle_drake.station import build_station
    from tangle_drake.station.pile import _Placer

    radius = 0.04

    def placements(wall: float, margin: float) -> tuple[np.ndarray, object]:
        scenario = load_scenario(diagrams_dir() / "pile_only.yaml")
        scenario = replace(scenario, bin=replace(scenario.bin, wall_height=wall))
        station = build_station(scenario)
        body = station.pile_bodies[0]
        root = Simulator(station).get_mutable_context()
        placer = _Placer(station.plant, root, scenario.bin, station.pile_bodies, margin)
        placer.stage(station.pile_bodies)
        rng = np.random.default_rng(3)
        found = []
        for _ in range(60):
            placer.place(body, rng)
            found.append(station.plant.GetFreeBodyPose(placer.context, body).translation())
        return np.array(found), scenario.bin

    inside, bin_config = placements(0.02, radius)  # a low rim: many land above it
    offset = np.abs(inside[:, :2] - bin_config.center)
    high = inside[:, 2] > bin_config.floor_height + bin_config.wall_height
    assert high.any()
    assert np.all(offset[high] <= np.asarray(bin_config.inner_size) / 2 - radius + 1e-9)
    assert offset[~high].max() > offset[high].max()  # below it, the whole floor
    deep, _ = placements(0.5, radius)  # nothing above the rim: the same as without
    np.testing.assert_array_equal(deep, placements(0.5, 0.0)[0])
