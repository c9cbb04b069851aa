"""IK, trajectories and whole-pick plans for the Nextage's left arm, on the planning plant."""

import dataclasses
import itertools

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.failures import FailureKind
from tangle_drake.planning.arm_motion import ArmMotion
from tangle_drake.planning.grasp_poses import ApproachSettings, pick_poses, symmetric_grasps
from tangle_drake.planning.motion import PlanningError
from tangle_drake.planning.motions import motion_for
from tangle_drake.planning.trajectory import (
    chain,
    first_violation,
    hold,
    rest_to_rest,
    through_waypoints,
)
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import HOME, LEFT_ARM
from tangle_drake.scenario.files import resolve_scenario

BIN = resolve_scenario(None).bin  # the demo's
RIM = BIN.floor_height + BIN.wall_height
MEASURED_HOME = np.concatenate([HOME, np.zeros_like(HOME)])


def top_down(x: float, y: float, z: float, yaw_deg: float = 0.0) -> RigidTransform:
    """A tool pose pointing straight down, closing along world -y turned by ``yaw_deg``."""
    R = RotationMatrix.MakeZRotation(np.radians(yaw_deg)) @ RotationMatrix.MakeXRotation(np.pi)
    return RigidTransform(R, [x, y, z])


def angle_between(a: RotationMatrix, b: RotationMatrix) -> float:
    return abs(a.inverse().multiply(b).ToAngleAxis().angle())


IN_BIN = top_down(BIN.center[0], BIN.center[1] + 0.03, BIN.floor_height + 0.022, 120.0)


@pytest.fixture(scope="module")
def motion() -> ArmMotion:
    return ArmMotion(BIN)


def test_ik_reaches_a_pose_in_the_bin_within_limits(motion):
    q = motion.ik.solve(IN_BIN, motion.q_home)
    assert q is not None
    X = motion.model.tcp_pose(q)
    assert np.linalg.norm(X.translation() - IN_BIN.translation()) < 1e-3
    assert angle_between(X.rotation(), IN_BIN.rotation()) < 0.02
    arm = motion.model.arm_indices
    assert np.all(q[arm] >= motion.model.lower[arm]) and np.all(q[arm] <= motion.model.upper[arm])
    # Only the arm moved: chest, head, right arm and fingers kept the seed's values.
    others = np.setdiff1d(np.arange(len(q)), arm)
    assert np.allclose(q[others], motion.q_home[others])


def test_ik_reports_a_pose_out_of_reach(motion):
    assert motion.ik.solve(top_down(1.2, 0.2, 1.0), motion.q_home) is None
    # Within reach of nothing: pointing up under the bin.
    assert motion.ik.solve(RigidTransform([0.34, 0.22, 0.3]), motion.q_home) is None


def test_the_symmetric_twin_nearer_the_current_wrist_comes_first():
    current = RotationMatrix.MakeXRotation(np.pi)  # closing along -y
    along_y = top_down(0, 0, 1, 0.0)  # closing along -y (X rotation by pi flips y)
    flipped = top_down(0, 0, 1, 180.0)
    first, second = symmetric_grasps(flipped, current)
    assert angle_between(first.rotation(), along_y.rotation()) < 1e-9
    assert angle_between(second.rotation(), flipped.rotation()) < 1e-9


TIPS_BELOW_TCP = 0.01


def test_pick_poses_press_in_clear_the_rim_and_lift_out_of_the_bin():
    settings = ApproachSettings()
    poses = pick_poses(IN_BIN, BIN, settings)
    grasp = IN_BIN.translation() - [0.0, 0.0, settings.press_depth]
    assert np.allclose(poses.grasp.translation(), grasp)
    assert poses.pregrasp.translation()[2] - TIPS_BELOW_TCP >= RIM + settings.rim_clearance - 1e-9
    assert np.isclose(poses.slow_start.translation()[2], grasp[2] + settings.slow_distance)
    assert np.isclose(poses.lift.translation()[2], RIM + settings.lift_height)
    assert np.allclose(poses.lift.translation()[:2], grasp[:2])


def test_the_lift_ends_in_from_the_walls():
    settings = ApproachSettings()
    wall_x = BIN.center[0] + BIN.inner_size[0] / 2
    near = top_down(wall_x - 0.02, BIN.center[1] - 0.05, BIN.floor_height + 0.02, 30.0)
    poses = pick_poses(near, BIN, settings)
    lift = poses.lift.translation()
    assert np.isclose(lift[0], wall_x - settings.lift_margin)  # moved in from the +x wall...
    assert np.isclose(lift[1], BIN.center[1] - 0.05)  # ...not along it (9 cm from the -y wall)
    assert np.isclose(lift[2], RIM + settings.lift_height)
    assert np.array_equal(poses.lift.rotation().matrix(), near.rotation().matrix())
    narrow = dataclasses.replace(BIN, inner_size=[0.1, BIN.inner_size[1]])
    lift = pick_poses(near, narrow, settings).lift.translation()
    assert np.isclose(lift[0], narrow.center[0])  # narrower than twice the margin: the middle
    with pytest.raises(ValueError, match="lift_margin"):
        ApproachSettings(lift_margin=-0.01)


def test_the_lift_rises_until_a_hanging_chain_clears_the_pile():
    settings = ApproachSettings()
    plain = pick_poses(IN_BIN, BIN, settings).lift.translation()
    high = pick_poses(IN_BIN, BIN, settings, tips_above=RIM + 0.3).lift.translation()
    assert np.isclose(high[2] - TIPS_BELOW_TCP, RIM + 0.3)
    assert np.allclose(high[:2], plain[:2])
    low = pick_poses(IN_BIN, BIN, settings, tips_above=RIM).lift.translation()
    assert np.allclose(low, plain)  # never lower than the settings' lift


def test_the_gantry_lifts_a_chain_clear_within_its_travel():
    from tangle_drake.drivers.limits import station_limits
    from tangle_drake.planning.gantry_motion import GantryMotion
    from tangle_drake.scenario.files import resolve_scenario

    scenario = resolve_scenario("floating_gripper.yaml")
    motion = GantryMotion(scenario.bin, station_limits(scenario))
    X = top_down(*scenario.bin.center, scenario.bin.floor_height + 0.02).GetAsMatrix4()
    rim = scenario.bin.floor_height + scenario.bin.wall_height

    def lift_top(tips_above):
        lift = motion.plan_pick(X, np.zeros(8), tips_above).lift
        return lift.value(lift.end_time()).ravel()

    plain, high = lift_top(None), lift_top(rim + 0.25)
    assert np.isclose(high[2] - DEFAULT_GRIPPER.tcp_offset - TIPS_BELOW_TCP, rim + 0.25)
    assert high[2] > plain[2] and np.allclose(high[[0, 1, 3]], plain[[0, 1, 3]])
    assert np.isclose(lift_top(rim + 5.0)[2], motion.upper[2])  # as high as it goes


def test_the_gantry_backs_out_the_way_it_came():
    from tangle_drake.drivers.limits import station_limits
    from tangle_drake.planning.gantry_motion import GantryMotion
    from tangle_drake.scenario.files import resolve_scenario

    scenario = resolve_scenario("floating_gripper.yaml")
    motion = GantryMotion(scenario.bin, station_limits(scenario))
    start = motion.home
    plan = motion.plan_pick(top_down(*scenario.bin.center, scenario.bin.floor_height + 0.02)
                            .GetAsMatrix4(), np.concatenate([start, np.zeros(4)]))
    slow = plan.lift.get_segment_times()[2]  # the lift's first leg is a trapezoid
    for t in np.linspace(0.0, slow, 7):
        assert np.allclose(value(plan.back_out, t), value(plan.lift, t), atol=1e-12)
    assert np.allclose(value(plan.back_out, plan.back_out.end_time()), start)
    top = value(plan.back_out, plan.back_out.end_time() / 2)
    assert top[2] < value(plan.lift, plan.lift.end_time())[2]  # not up to the lift's top


def test_the_arm_lifts_a_chain_clear_where_it_reaches_and_as_before_where_not(motion):
    def lift_tcp(tips_above):
        lift = motion.plan_pick(IN_BIN.GetAsMatrix4(), MEASURED_HOME, tips_above).lift
        return motion.model.tcp_pose(motion.model.full_q(lift.value(lift.end_time()).ravel()))

    high = lift_tcp(RIM + 0.2).translation()
    assert np.isclose(high[2] - TIPS_BELOW_TCP, RIM + 0.2, atol=1e-3)
    out_of_reach = lift_tcp(RIM + 2.0).translation()
    assert np.isclose(out_of_reach[2], RIM + ApproachSettings().lift_height, atol=1e-3)


def test_pressing_in_stops_short_of_the_floor():
    settings = ApproachSettings()
    low = top_down(0.34, 0.22, BIN.floor_height + TIPS_BELOW_TCP + 0.002)
    tips = pick_poses(low, BIN, settings).grasp.translation()[2] - TIPS_BELOW_TCP
    assert np.isclose(tips, BIN.floor_height + settings.floor_clearance)
    on_floor = top_down(0.34, 0.22, BIN.floor_height + TIPS_BELOW_TCP)
    assert np.allclose(pick_poses(on_floor, BIN, settings).grasp.translation(),
                       on_floor.translation())


@pytest.mark.parametrize("delta", [[2.0, -0.5, 0.1], [0.05, 0.0, -0.02]])
def test_rest_to_rest_keeps_within_the_limits(delta):
    q0 = np.array([0.3, -0.2, 1.0])
    q1 = q0 + delta
    trajectory = rest_to_rest(q0, q1, 1.0, 1.5)
    times = np.linspace(0, trajectory.end_time(), 1001)
    velocity = np.array([trajectory.EvalDerivative(t, 1).ravel() for t in times])
    acceleration = np.array([trajectory.EvalDerivative(t, 2).ravel() for t in times])
    assert np.abs(velocity).max() <= 1.0 + 1e-9
    assert np.abs(acceleration).max() <= 1.5 + 1e-9
    assert np.allclose(trajectory.value(0).ravel(), q0)
    assert np.allclose(trajectory.value(trajectory.end_time()).ravel(), q1)
    assert np.allclose(velocity[[0, -1]], 0.0)


def test_a_path_speed_cap_slows_a_cartesian_leg():
    trajectory = rest_to_rest(np.zeros(2), np.array([0.02, 0.01]), 1.0, 1.5,
                              path_length=0.05, max_path_speed=0.01)
    assert trajectory.end_time() >= 5.0  # 5 cm at no more than 1 cm/s


def test_a_move_through_waypoints_keeps_within_the_limits_without_stopping():
    rng = np.random.default_rng(0)
    waypoints = [np.zeros(6)]
    for _ in range(5):  # nearly collinear, like a Cartesian line split for straightness
        waypoints.append(waypoints[-1] + [0.05, -0.03, 0.02, 0.0, 0.01, 0.0]
                         + rng.normal(0.0, 0.003, 6))
    trajectory = through_waypoints(waypoints, 1.0, 1.5)
    times = np.linspace(0, trajectory.end_time(), 2001)
    velocity = np.array([trajectory.EvalDerivative(t, 1).ravel() for t in times])
    acceleration = np.array([trajectory.EvalDerivative(t, 2).ravel() for t in times])
    assert np.abs(velocity).max() <= 1.0 + 1e-6
    assert np.abs(acceleration).max() <= 1.5 + 1e-6
    assert np.allclose(trajectory.value(0).ravel(), waypoints[0])
    assert np.allclose(trajectory.value(trajectory.end_time()).ravel(), waypoints[-1])
    speed = np.linalg.norm(velocity, axis=1)
    assert speed[[0, -1]].max() < 1e-9 and speed[200:-200].min() > 0.1  # no stop on the way
    for q in waypoints[1:-1]:  # passes (close to) every waypoint
        assert min(np.linalg.norm(trajectory.value(t).ravel() - q) for t in times) < 2e-3


def test_chain_and_hold_run_legs_back_to_back():
    a = rest_to_rest(np.zeros(2), np.ones(2), 1.0, 1.5)
    trajectory = chain([a, hold(np.ones(2), 0.5), rest_to_rest(np.ones(2), np.zeros(2), 1.0, 1.5)])
    assert np.isclose(trajectory.end_time(), 2 * a.end_time() + 0.5)
    assert np.allclose(trajectory.value(a.end_time() + 0.25).ravel(), 1.0)


def test_first_violation_finds_the_blocked_sample():
    blocked = first_violation([np.zeros(1), np.ones(1)], 0.1, lambda q: q[0] < 0.55)
    assert blocked is not None and 0.55 <= blocked[0] <= 0.65


@pytest.fixture(scope="module")
def plan(motion):
    return motion.plan_pick(IN_BIN.GetAsMatrix4(), MEASURED_HOME)


PHASES = ("approach", "descend", "lift", "transfer", "home")
MOVES = (*PHASES, "retreat", "back_out")


def samples(trajectory, step=0.004):
    return np.arange(0.0, trajectory.end_time() + 1e-9, step)


@pytest.mark.parametrize("phase", MOVES)
def test_planned_phases_keep_within_the_planning_limits(plan, phase):
    trajectory = getattr(plan, phase)
    for t in samples(trajectory):
        assert np.abs(trajectory.EvalDerivative(t, 1)).max() <= 1.0 + 1e-6
        assert np.abs(trajectory.EvalDerivative(t, 2)).max() <= 1.5 + 1e-6


def test_phases_join_up_and_only_the_left_arm_moves(plan):
    ends = [getattr(plan, phase) for phase in PHASES]
    for before, after in itertools.pairwise(ends):
        assert np.allclose(before.value(before.end_time()), after.value(0.0), atol=1e-9)
    assert np.allclose(plan.approach.value(0).ravel(), HOME)
    assert np.allclose(plan.home.value(plan.home.end_time()).ravel(), HOME)
    for phase in PHASES:
        trajectory = getattr(plan, phase)
        moved = trajectory.value(trajectory.end_time()).ravel() - trajectory.value(0).ravel()
        moved[LEFT_ARM] = 0.0
        assert np.allclose(moved, 0.0)


@pytest.mark.parametrize("phase", MOVES)
def test_planned_phases_keep_clear_of_the_bin_and_the_robot(motion, plan, phase):
    trajectory = getattr(plan, phase)
    near_pile = phase in ("descend", "lift", "back_out")
    for t in samples(trajectory, 0.02):
        clearance = motion.model.clearance(motion.model.full_q(trajectory.value(t).ravel()))
        # The collision checks sample the joint-space lines; between samples the margin may
        # shrink by about what the wrist moves in one step.
        assert clearance.to_bin >= (-0.001 if near_pile else 0.005), t
        assert clearance.to_self >= 0.0


def value(trajectory, t: float) -> np.ndarray:
    return trajectory.value(t).ravel()


def test_the_back_out_begins_as_the_lift_and_goes_back_the_way_the_pick_came(plan):
    back_out, lift = plan.back_out, plan.lift
    shared = [t for t in samples(lift, 0.01) if np.allclose(value(back_out, t), value(lift, t),
                                                               rtol=0.0, atol=1e-9)]
    assert 0.3 < shared[-1] < lift.end_time()  # the slow stretch up from the grasp, then apart
    assert np.allclose(value(back_out, 0.0), value(plan.descend, plan.descend.end_time()))
    passes = [np.abs(value(back_out, t) - value(plan.approach, plan.approach.end_time())).max()
              for t in samples(back_out, 0.01)]
    assert min(passes) < 1e-3  # through the pre-grasp
    assert np.allclose(value(back_out, back_out.end_time()), HOME)  # to where it began


def test_descent_is_straight_and_slow_near_the_part(motion, plan):
    grasp = plan.X_WT[:3, 3]
    assert np.allclose(grasp[:2], IN_BIN.translation()[:2])
    trajectory = plan.descend
    times = samples(trajectory, 0.01)
    tcp = np.array([motion.model.tcp_pose(motion.model.full_q(trajectory.value(t).ravel()))
                    .translation() for t in times])
    assert np.allclose(tcp[-1], grasp, atol=1e-3)
    assert np.abs(tcp[:, :2] - grasp[:2]).max() < 0.003  # straight down within 3 mm
    speed = np.linalg.norm(np.diff(tcp, axis=0), axis=1) / np.diff(times)
    slow = tcp[1:, 2] < grasp[2] + motion.settings.approach.slow_distance - 0.002
    assert speed[slow].max() <= motion.settings.slow_speed * 1.1


def test_an_unreachable_grasp_is_reported(motion):
    with pytest.raises(PlanningError) as error:
        motion.plan_pick(top_down(0.75, -0.3, 0.95).GetAsMatrix4(), MEASURED_HOME)
    assert error.value.kind is FailureKind.UNREACHABLE


def test_a_grasp_whose_palm_hits_the_wall_is_reported(motion):
    # Fingers closing along y, 2.5 cm from the left wall: the 9 cm palm reaches into it.
    wall_y = BIN.center[1] + BIN.inner_size[1] / 2
    X = top_down(BIN.center[0], wall_y - 0.025, BIN.floor_height + 0.015, 0.0)
    with pytest.raises(PlanningError) as error:
        motion.plan_pick(X.GetAsMatrix4(), MEASURED_HOME)
    assert error.value.kind is FailureKind.COLLISION


def _with_arm_limits(velocity: float, acceleration: float = 1.5, slow_speed: float = 0.03):
    scenario = resolve_scenario(None)
    drivers = dict(scenario.model_drivers)
    drivers["nextage"] = dataclasses.replace(drivers["nextage"],
                                             planning_velocity_limit=velocity,
                                             planning_acceleration_limit=acceleration,
                                             planning_slow_speed=slow_speed)
    return dataclasses.replace(scenario, model_drivers=drivers)


def test_the_scenario_sets_the_arms_planning_limits():
    default, brisk = motion_for(resolve_scenario(None)), motion_for(_with_arm_limits(1.9, 3.0))
    assert (default.settings.velocity_limit, default.settings.acceleration_limit) == (1.0, 1.5)
    assert (brisk.settings.velocity_limit, brisk.settings.acceleration_limit) == (1.9, 3.0)
    end = HOME.copy()
    end[LEFT_ARM] += 0.8
    slow, fast = default.plan_line(HOME, end), brisk.plan_line(HOME, end)
    assert fast.end_time() < 0.75 * slow.end_time()  # 1.03 s against 1.47 s
    for t in samples(fast):
        assert np.abs(fast.EvalDerivative(t, 1)).max() <= 1.9 + 1e-6
        assert np.abs(fast.EvalDerivative(t, 2)).max() <= 3.0 + 1e-6


def test_the_scenario_sets_the_speed_next_to_the_pile():
    slow, brisk = (motion_for(_with_arm_limits(1.9, 3.0, speed)) for speed in (0.03, 0.06))
    picks = [m.plan_pick(IN_BIN.GetAsMatrix4(), MEASURED_HOME) for m in (slow, brisk)]
    for m, pick in zip((slow, brisk), picks, strict=True):
        # The last centimetre of the descent lies within the slow stretch: its tool speed.
        end = pick.descend.end_time()
        times = np.linspace(0.0, end, 400)
        z = np.array([m.model.tcp_pose(m.model.full_q(pick.descend.value(t).ravel()))
                      .translation()[2] for t in times])
        last = z < z[-1] + 0.01
        speed = np.abs(np.gradient(z, times))[last].max()
        assert speed <= m.settings.slow_speed * 1.05
    assert brisk.settings.slow_speed == 0.06
    # the slow stretch (3 cm each way) takes about half as long
    assert picks[1].descend.end_time() < picks[0].descend.end_time() - 0.3
    assert picks[1].lift.end_time() < picks[0].lift.end_time() - 0.3


def test_an_arm_planned_faster_than_its_joints_are_rated_is_refused():
    with pytest.raises(TangleDrakeError, match=r"planning_velocity_limit.*rated speed, 1\.920"):
        motion_for(_with_arm_limits(2.5))
