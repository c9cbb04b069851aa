"""Stirring the bin: what the camera sees left in it, the sweep through it, and the moves that
carry the sweep out (the gantry's, the Nextage's)."""

import numpy as np
import pytest

from tangle_drake.graspability.synthetic import HeightField
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose
from tangle_drake.pick.bin_contents import BinContents, bin_contents
from tangle_drake.pick.stir import StirSettings, looks_empty, stir_line, stir_poses
from tangle_drake.planning.trajectory import chain
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.scenario import BinConfig

BIN = BinConfig(center=[0.34, 0.22], floor_height=0.93, inner_size=[0.20, 0.28],
                wall_height=0.08)
CAMERA = CameraModel(CameraIntrinsics.from_fov_y(640, 480, 45.0),
                     top_view_pose(np.array([0.34, 0.22, 0.93]), 0.5))
SETTINGS = StirSettings()
ALONG = DEFAULT_GRIPPER.palm_size[0] / 2 + SETTINGS.wall_clearance
ACROSS = DEFAULT_GRIPPER.palm_size[1] / 2 + SETTINGS.wall_clearance


def _camera_xy(x: float, y: float) -> tuple[float, float]:
    """World (x, y) to the top camera's x-y plane (its x is the world's -y, its y the -x)."""
    return -(y - BIN.center[1]), -(x - BIN.center[0])


def scene(boxes=(), walls=True, holes=False) -> np.ndarray:
    """The top camera's depth image of the bin with boxes ``(x0, y0, x1, y1, height)`` (world
    m, heights above the floor) on its floor."""
    field = HeightField((0.5, 0.5), 0.001)
    hx, hy = np.asarray(BIN.inner_size) / 2
    if walls:
        for x0, y0, x1, y1 in ((-hx - 0.01, -hy - 0.01, -hx, hy + 0.01),
                               (hx, -hy - 0.01, hx + 0.01, hy + 0.01),
                               (-hx, -hy - 0.01, hx, -hy), (-hx, hy, hx, hy + 0.01)):
            boxes = (*boxes, (BIN.center[0] + x0, BIN.center[1] + y0, BIN.center[0] + x1,
                              BIN.center[1] + y1, BIN.wall_height))
    for x0, y0, x1, y1, height in boxes:
        (a0, b0), (a1, b1) = _camera_xy(x0, y0), _camera_xy(x1, y1)
        field.add_box(min(a0, a1), min(b0, b1), max(a0, a1), max(b0, b1), height)
    depth = field.render(CAMERA.intrinsics, 0.5)
    if holes:
        depth[::7, ::5] = np.nan
        depth[1::9, ::4] = 0.0
    return depth


def test_an_empty_bin_looks_empty_whatever_its_walls_and_missing_pixels():
    contents = bin_contents(scene(holes=True), CAMERA, BIN)
    assert looks_empty(contents, SETTINGS)
    assert contents.area(SETTINGS.min_height) == 0.0
    assert stir_line(contents, SETTINGS) is None


def test_a_part_on_the_floor_is_seen_where_it_lies():
    part = (0.40, 0.15, 0.43, 0.16, 0.006)  # 30 x 10 mm, 6 mm high
    contents = bin_contents(scene([part]), CAMERA, BIN)
    assert not looks_empty(contents, SETTINGS)
    assert contents.area(SETTINGS.min_height) == pytest.approx(3e-4, rel=0.5)
    assert contents.top_within(np.array([0.415, 0.155]), 0.005) == pytest.approx(0.006,
                                                                                abs=0.001)
    assert contents.top_within(np.array([0.30, 0.30]), 0.01) < 0.001


def test_the_sweep_starts_at_the_wall_nearest_what_is_left_and_goes_away_from_it():
    hx = BIN.inner_size[0] / 2
    wall_x = BIN.center[0] + hx
    part = (wall_x - 0.012, 0.20, wall_x - 0.003, 0.24, 0.006)  # along the +x wall
    line = stir_line(bin_contents(scene([part]), CAMERA, BIN), SETTINGS)
    assert line is not None
    np.testing.assert_allclose(line.direction, [-1.0, 0.0])
    assert line.start[0] == pytest.approx(wall_x - ALONG)  # as near the wall as the palm lets
    assert line.start[1] == pytest.approx(0.22, abs=0.005)  # level with what is left
    assert line.end[0] == pytest.approx(line.start[0] - SETTINGS.length)
    assert line.start[2] == pytest.approx(BIN.floor_height + SETTINGS.tip_height)
    assert line.end[2] == line.start[2]


def test_the_sweep_keeps_the_palm_off_the_side_walls_and_short_of_the_far_one():
    low_x, low_y = np.asarray(BIN.center) - np.asarray(BIN.inner_size) / 2
    corner = (low_x + 0.01, low_y, low_x + 0.04, low_y + 0.012, 0.006)  # by the -y wall
    line = stir_line(bin_contents(scene([corner]), CAMERA, BIN), SETTINGS)
    np.testing.assert_allclose(line.direction, [0.0, 1.0])
    assert line.start[1] == pytest.approx(low_y + ALONG)
    assert line.start[0] == pytest.approx(low_x + ACROSS)  # the palm's long side off the wall
    narrow = BinConfig(center=BIN.center, floor_height=BIN.floor_height,
                       inner_size=[0.045, 0.28], wall_height=BIN.wall_height)
    part = (0.33, 0.20, 0.35, 0.24, 0.006)
    line = stir_line(bin_contents(scene([part], walls=False), CAMERA, narrow), SETTINGS)
    assert line is None  # the palm (40 x 90 mm) cannot go down into a 45 mm wide bin


def test_the_fingers_come_down_beside_a_part_or_above_it_never_on_it():
    wall_x = BIN.center[0] + BIN.inner_size[0] / 2
    under = (wall_x - 0.04, 0.21, wall_x - 0.015, 0.23, 0.012)  # where the sweep would start
    line = stir_line(bin_contents(scene([under]), CAMERA, BIN), SETTINGS)
    assert line.start[2] == pytest.approx(BIN.floor_height + SETTINGS.tip_height)
    reach = np.hypot(DEFAULT_GRIPPER.finger_width / 2, DEFAULT_GRIPPER.finger_thickness)
    assert abs(line.start[1] - 0.22) > 0.01 + reach  # beside it, on free floor...
    assert abs(line.start[1] - 0.22) < 0.01 + reach + 0.01  # ...as near level as there is
    low_y, high_y = BIN.center[1] - BIN.inner_size[1] / 2, BIN.center[1] + BIN.inner_size[1] / 2
    along_wall = (wall_x - 0.04, low_y, wall_x - 0.015, high_y, 0.012)  # no free floor there
    line = stir_line(bin_contents(scene([along_wall]), CAMERA, BIN), SETTINGS)
    assert line.start[2] == pytest.approx(BIN.floor_height + 0.012 + SETTINGS.above_parts,
                                          abs=0.0015)


def test_stir_poses_point_down_with_the_palm_s_short_side_along_the_sweep():
    wall_x = BIN.center[0] + BIN.inner_size[0] / 2
    line = stir_line(bin_contents(scene([(wall_x - 0.01, 0.2, wall_x, 0.22, 0.006)]),
                                  CAMERA, BIN), SETTINGS)
    rim = BIN.floor_height + BIN.wall_height
    poses = stir_poses(line, rim)
    tips = DEFAULT_GRIPPER.reach - DEFAULT_GRIPPER.tcp_offset
    assert len(poses) == 4
    for X in poses:
        np.testing.assert_allclose(X[:3, 2], [0, 0, -1])
        np.testing.assert_allclose(X[:2, 0], line.direction)
        np.testing.assert_allclose(X[:3, :3].T @ X[:3, :3], np.eye(3), atol=1e-12)
        assert np.linalg.det(X[:3, :3]) == pytest.approx(1.0)
    assert poses[1][2, 3] - tips == pytest.approx(line.start[2])
    assert poses[2][2, 3] - tips == pytest.approx(line.end[2])
    assert poses[0][2, 3] - tips > rim and poses[3][2, 3] - tips > rim


def test_settings_are_checked():
    with pytest.raises(ValueError, match="length"):
        StirSettings(length=0.0)
    with pytest.raises(ValueError, match="tip_height"):
        StirSettings(tip_height=-0.001)


def _sweep_by_the_far_wall(bin_config: BinConfig) -> list[np.ndarray]:
    """The stir poses for a part lying along the bin's +x wall."""
    wall_x = bin_config.center[0] + bin_config.inner_size[0] / 2
    heights = np.zeros((50, 70))
    heights[-3:, 30:40] = 0.006
    low = np.asarray(bin_config.center) - np.asarray(bin_config.inner_size) / 2
    contents = BinContents(heights, tuple(low + 0.002), 0.004, bin_config)
    line = stir_line(contents, SETTINGS)
    assert line.start[0] == pytest.approx(wall_x - ALONG)
    return stir_poses(line, bin_config.floor_height + bin_config.wall_height)


def test_the_gantry_sweeps_along_the_floor_and_comes_home():
    from tangle_drake.drivers.limits import station_limits
    from tangle_drake.planning.gantry_motion import GantryMotion
    from tangle_drake.scenario.files import resolve_scenario

    scenario = resolve_scenario("floating_gripper.yaml")
    motion = GantryMotion(scenario.bin, station_limits(scenario))
    poses = _sweep_by_the_far_wall(scenario.bin)
    stir = motion.plan_stir(motion.home, poses, SETTINGS.speed)
    trajectory = chain([stir.approach, stir.sweep, stir.home])
    times = np.linspace(0, trajectory.end_time(), 400)
    q = np.array([trajectory.value(t).ravel() for t in times])
    np.testing.assert_allclose(q[0], motion.home)
    np.testing.assert_allclose(q[-1], motion.home)
    tcp = DEFAULT_GRIPPER.tcp_offset
    deepest = q[:, 2].min() - tcp  # the tool centre at the bottom of the sweep
    rim = scenario.bin.floor_height + scenario.bin.wall_height + DEFAULT_GRIPPER.reach - tcp
    np.testing.assert_allclose(stir.sweep.value(0).ravel()[:3] - [0, 0, tcp], poses[0][:3, 3])
    np.testing.assert_allclose(stir.home.value(0).ravel()[:3] - [0, 0, tcp], poses[3][:3, 3])
    assert poses[0][2, 3] > rim and poses[3][2, 3] > rim  # only the sweep goes into the bin
    assert deepest == pytest.approx(poses[1][2, 3], abs=1e-6)
    low = q[np.abs(q[:, 2] - tcp - deepest) < 1e-4]
    assert low[:, 0].min() == pytest.approx(poses[2][0, 3], abs=1e-3)  # along the floor...
    assert low[:, 0].max() == pytest.approx(poses[1][0, 3], abs=1e-3)  # ...start to end
    assert np.all(q >= motion.lower - 1e-9) and np.all(q <= motion.upper + 1e-9)


def test_the_arm_sweeps_clear_of_the_bin_within_its_limits():
    from tangle_drake.planning.arm_motion import ArmMotion
    from tangle_drake.robot_model.nextage import HOME
    from tangle_drake.scenario.files import resolve_scenario

    bin_config = resolve_scenario(None).bin
    motion = ArmMotion(bin_config)
    poses = _sweep_by_the_far_wall(bin_config)
    stir = motion.plan_stir(HOME, poses, SETTINGS.speed)
    trajectory = chain([stir.approach, stir.sweep, stir.home])
    times = np.linspace(0, trajectory.end_time(), 300)
    q = np.array([trajectory.value(t).ravel() for t in times])
    np.testing.assert_allclose(q[0], HOME, atol=1e-9)
    np.testing.assert_allclose(q[-1], HOME, atol=1e-9)
    tips = [motion.model.tcp_pose(motion.model.full_q(x)).translation() for x in q]
    for X in poses[1:3]:  # it passes the start and the end of the sweep
        assert min(np.linalg.norm(p - X[:3, 3]) for p in tips) < 0.003
    assert all(motion.model.clearance(motion.model.full_q(x)).to_bin >= -1e-4 for x in q)


def test_a_stir_in_the_simulation_moves_parts_and_keeps_them_in_the_bin():
    """The sweep, played on the simulated floating gripper over a small pile: the closed
    fingers go down to the planned depth, push parts along, and no part leaves the bin or
    is pressed into its floor."""
    from dataclasses import replace

    from pydrake.systems.analysis import Simulator

    from tangle_drake.drivers.limits import station_limits
    from tangle_drake.planning.gantry_motion import GantryMotion
    from tangle_drake.scenario import PartCount
    from tangle_drake.scenario.files import resolve_scenario
    from tangle_drake.station import build_station, camera_model
    from tangle_drake.station.bin_model import inside_bin
    from tangle_drake.station.pile import settle_pile

    scenario = resolve_scenario("floating_gripper.yaml")
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[PartCount("u_hook", 5)]))
    station = build_station(scenario)
    pile = settle_pile(station, scenario, seed=3)
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    station.hold_still(context)
    station.set_plant_state(context, pile.state)
    station.GetInputPort("gripper.position").FixValue(context, [0.0])
    simulator.Initialize()
    depth = np.asarray(station.GetOutputPort("camera.depth_image").Eval(context).data)[:, :, 0]
    line = stir_line(bin_contents(depth, camera_model(scenario), scenario.bin), SETTINGS)
    assert line is not None
    motion = GantryMotion(scenario.bin, station_limits(scenario))
    hold = station.GetOutputPort("gantry.position_measured").Eval(context).copy()
    rim = scenario.bin.floor_height + scenario.bin.wall_height
    stir = motion.plan_stir(hold, stir_poses(line, rim), SETTINGS.speed)
    sweep = chain([stir.approach, stir.sweep, stir.home])
    before = station.part_poses(context)[:, :3, 3]
    start, lowest = context.get_time(), np.inf
    while context.get_time() < start + sweep.end_time() + 0.5:
        t = min(context.get_time() - start, sweep.end_time())
        station.GetInputPort("gantry.position").FixValue(context, sweep.value(t).ravel())
        simulator.AdvanceTo(context.get_time() + 0.02)
        lowest = min(lowest, station.GetOutputPort("gantry.position_measured").Eval(context)[2])
        assert station.part_poses(context)[:, 2, 3].min() > scenario.bin.floor_height - 0.001
    after = station.part_poses(context)[:, :3, 3]
    tips = lowest - DEFAULT_GRIPPER.reach  # the gantry's z is the flange's
    assert tips == pytest.approx(line.start[2], abs=0.002)
    assert np.linalg.norm(after - before, axis=1).max() > 0.01  # it moved something
    assert inside_bin(scenario.bin, after).all()
