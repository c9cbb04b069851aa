"""Where can the left gripper reach straight down? Picks the bin's place in front of the Nextage.

For each test point, Drake's ``InverseKinematics`` looks for left-arm joints (chest, head and
right arm held at ``init_rtm``, joint limits shrunk by a margin) that put the gripper TCP on
the point with the gripper's +z pointing straight down, any rotation about the vertical. That
rotation is free: the wrist roll LARM_JOINT5 turns about the tool axis and spans more than
180°, so where down is reachable every closing direction is. A solution that makes the robot
collide with itself does not count.

    python tools/nextage_reach.py --evaluate 0.34 0.22 0.93   # one bin placement
    python tools/nextage_reach.py --search                    # rank placements (minutes)

The bin with its inner-floor centre at world (0.34, 0.22) and its floor top at z = 0.93 was
chosen with it: there the gripper reaches every point of the floor, while lower or higher
floors lose points, as pointing straight down the short arm's workspace is a narrow band
around its waist height (WAIST at 0.97). The figures are in ``docs/results/history.md``
(Clearing whole bins with the Nextage arm).
"""

from __future__ import annotations

import argparse
import itertools
import time
from dataclasses import dataclass

import numpy as np
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.solvers import Solve
from pydrake.systems.framework import DiagramBuilder

from tangle_drake.robot_model.nextage import INIT_RTM, add_nextage_with_gripper

BIN_INNER = (0.20, 0.28)
"""Inner size of the bin along world (x, y), m."""
Z_RANGE = (0.01, 0.15)
"""TCP heights above the bin's inner floor that must be reachable, m."""


@dataclass(frozen=True)
class Margins:
    """Slack a recommended placement keeps beyond the bare requirement."""

    xy: float = 0.02
    """Band added around the bin's inner area, m."""
    z: float = 0.02
    """Height added above the top of Z_RANGE, m (the bottom stays 1 cm above the floor)."""
    joint: float = 0.05
    """Joint limits shrunk by this much at each end, rad."""


class ReachChecker:
    """The straight-down IK for the left arm: one program, its target moved for each point."""

    def __init__(self, joint_margin: float, position_tolerance: float = 5e-4,
                 angle_tolerance_deg: float = 1.0, seed: int = 0) -> None:
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
        nextage, gripper = add_nextage_with_gripper(plant)
        plant.Finalize()
        self._diagram = builder.Build()
        context = self._diagram.CreateDefaultContext()
        self._context = context
        self._plant = plant
        self._plant_context = plant.GetMyContextFromRoot(context)
        self._scene_graph = scene_graph
        self._sg_context = scene_graph.GetMyContextFromRoot(context)
        self._tol = position_tolerance
        self._rng = np.random.default_rng(seed)

        plant.SetPositions(self._plant_context, nextage, INIT_RTM)
        self._q_init = plant.GetPositions(self._plant_context)
        self._arm = [plant.GetJointByName(f"LARM_JOINT{i}").position_start() for i in range(6)]
        self._lower = self._q_init.copy()
        self._upper = self._q_init.copy()
        self._lower[self._arm] = plant.GetPositionLowerLimits()[self._arm] + joint_margin
        self._upper[self._arm] = plant.GetPositionUpperLimits()[self._arm] - joint_margin

        self._ik = InverseKinematics(plant, self._plant_context, with_joint_limits=False)
        q = self._ik.q()
        self._prog = self._ik.get_mutable_prog()
        self._prog.AddBoundingBoxConstraint(self._lower, self._upper, q)
        self._position = self._ik.AddPositionConstraint(
            frameB=plant.GetFrameByName("gripper_tcp", gripper), p_BQ=np.zeros(3),
            frameA=plant.world_frame(), p_AQ_lower=np.zeros(3), p_AQ_upper=np.zeros(3))
        self._ik.AddAngleBetweenVectorsConstraint(
            frameA=plant.world_frame(), na_A=np.array([0.0, 0.0, -1.0]),
            frameB=plant.GetFrameByName("gripper_base", gripper), nb_B=np.array([0.0, 0.0, 1.0]),
            angle_lower=0.0, angle_upper=np.radians(angle_tolerance_deg))
        # Prefer arm poses near init_rtm, so neighbouring points get similar, natural solutions.
        self._prog.AddQuadraticErrorCost(np.eye(6), self._q_init[self._arm], q[self._arm])

    def solve(self, p_W: np.ndarray, seeds: list[np.ndarray],
              random_seeds: int = 0) -> np.ndarray | None:
        """A collision-free q putting the TCP at ``p_W`` pointing down, or None.

        Tries ``seeds`` in order, then ``random_seeds`` uniform draws of the arm joints: one
        failed local solve says little about reachability.
        """
        self._position.evaluator().set_bounds(p_W - self._tol, p_W + self._tol)
        draws = (self._random_seed() for _ in range(random_seeds))
        for seed in itertools.chain(seeds, draws):
            result = Solve(self._prog, seed)
            if result.is_success():
                q = result.GetSolution(self._ik.q())
                if not self._in_self_collision(q):
                    return q
        return None

    def _random_seed(self) -> np.ndarray:
        q = self._q_init.copy()
        q[self._arm] = self._rng.uniform(self._lower[self._arm], self._upper[self._arm])
        return q

    def _in_self_collision(self, q: np.ndarray) -> bool:
        self._plant.SetPositions(self._plant_context, q)
        query = self._scene_graph.get_query_output_port().Eval(self._sg_context)
        return bool(query.ComputePointPairPenetration())

    def tcp_at_init_rtm(self) -> np.ndarray:
        self._plant.SetPositions(self._plant_context, self._q_init)
        return self._plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(
            self._plant_context).translation()

    def fixed_seeds(self) -> list[np.ndarray]:
        """init_rtm and two other elbow/shoulder poses, for points far from any solved one."""
        seeds = [self._q_init]
        for arm in ([0.3, -0.6, -1.6, 0.0, 0.6, 0.0], [-0.3, -0.3, -2.2, 0.0, 0.9, 0.0]):
            q = self._q_init.copy()
            q[self._arm] = arm
            seeds.append(q)
        return seeds


def solve_all(checker: ReachChecker, points: np.ndarray, random_seeds: int,
              retry_isolated: bool) -> np.ndarray:
    """Reachability of ``points`` (N, 3), listed so that consecutive points are neighbours.

    The sweep seeds each solve with the last solution; a second pass retries each failure
    from the solutions of solved points within 5 cm plus ``random_seeds`` random draws (for
    failures with no solved neighbour only if ``retry_isolated``).
    """
    fixed = checker.fixed_seeds()
    solutions: list[np.ndarray | None] = []
    last = None
    for p in points:
        q = checker.solve(p, ([last] if last is not None else []) + fixed)
        solutions.append(q)
        last = q if q is not None else last
    solved = np.array([q is not None for q in solutions])
    for i in np.flatnonzero(~solved):
        d = np.linalg.norm(points - points[i], axis=1)
        near = [solutions[n] for n in np.argsort(d)[:8] if solved[n] and d[n] < 0.05]
        if near or retry_isolated:
            solutions[i] = checker.solve(points[i], near, random_seeds)
    return np.array([q is not None for q in solutions])


def bin_test_points(center: tuple[float, float], floor_z: float, margins: Margins,
                    step: float) -> np.ndarray:
    """Points filling the required TCP volume over the bin, widened by the margins, (N, 3)."""
    half = np.array(BIN_INNER) / 2 + margins.xy
    xs, ys = (np.linspace(c - h, c + h, round(2 * h / step) + 1)
              for c, h in zip(center, half, strict=True))
    z_lo, z_hi = floor_z + Z_RANGE[0], floor_z + Z_RANGE[1] + margins.z
    zs = np.linspace(z_lo, z_hi, round((z_hi - z_lo) / step) + 1)
    # Serpentine order, so that consecutive points are neighbours.
    rows = []
    for k, z in enumerate(zs):
        for i, x in enumerate(xs[:: 1 if k % 2 == 0 else -1]):
            line = ys if i % 2 == 0 else ys[::-1]
            rows.extend((x, y, z) for y in line)
    return np.array(rows)


def evaluate(checker: ReachChecker, center: tuple[float, float], floor_z: float,
             margins: Margins, step: float) -> tuple[float, int]:
    """(fraction of the bin's test points reached pointing down, number of points)."""
    points = bin_test_points(center, floor_z, margins, step)
    reached = solve_all(checker, points, random_seeds=10, retry_isolated=True)
    return float(reached.mean()), len(points)


def search(checker: ReachChecker, margins: Margins, step: float) -> None:
    """Reachability on a lattice in front of the robot; print the placements that fit it."""
    xs = np.arange(0.12, 0.6001, step)
    ys = np.arange(-0.12, 0.4801, step)
    zs = np.arange(0.74, 1.2001, step)
    grid = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1)
    order = np.array([(i, j if i % 2 == 0 else len(ys) - 1 - j, k)
                      for k in range(len(zs)) for i in range(len(xs)) for j in range(len(ys))])
    start = time.time()
    reached = solve_all(checker, grid[tuple(order.T)], random_seeds=4, retry_isolated=False)
    reach = np.zeros(grid.shape[:3], bool)
    reach[tuple(order.T)] = reached
    print(f"lattice {reach.shape} in {time.time() - start:.0f} s: {reach.mean():.1%} reachable")

    half = np.array(BIN_INNER) / 2 + margins.xy
    nx, ny = (round(2 * h / step) + 1 for h in half)
    nz = round((Z_RANGE[1] + margins.z - Z_RANGE[0]) / step) + 1
    candidates = []
    for i, j, k in itertools.product(range(len(xs) - nx + 1), range(len(ys) - ny + 1),
                                     range(len(zs) - nz + 1)):
        fraction = reach[i:i + nx, j:j + ny, k:k + nz].mean()
        center = (xs[i] + xs[i + nx - 1]) / 2, (ys[j] + ys[j + ny - 1]) / 2
        candidates.append((fraction, center, zs[k] - Z_RANGE[0]))
    full = [c for c in candidates if c[0] == 1.0]
    print(f"{len(full)} of {len(candidates)} placements reach every lattice point; best:")
    # Fully reachable first; among those the bin furthest to the robot's left (+y).
    candidates.sort(key=lambda c: (-c[0], -round(c[1][1], 3), c[1][0]))
    for fraction, center, floor_z in candidates[:12]:
        print(f"  centre ({center[0]:.2f}, {center[1]:.2f}), floor z {floor_z:.2f}: "
              f"{fraction:.1%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--evaluate", nargs=3, type=float, metavar=("X", "Y", "FLOOR_Z"),
                      help="world (x, y) of the bin's inner-floor centre and z of its top, m")
    mode.add_argument("--search", action="store_true", help="scan placements and rank them")
    parser.add_argument("--step", type=float, default=0.02, help="test point spacing, m")
    defaults = Margins()
    parser.add_argument("--margin-xy", type=float, default=defaults.xy,
                        help="band around the bin's inner area that must be reachable too, m")
    parser.add_argument("--margin-z", type=float, default=defaults.z,
                        help="height above floor + 0.15 m that must be reachable too, m")
    parser.add_argument("--joint-margin", type=float, default=defaults.joint,
                        help="joint limits shrunk by this at each end, rad")
    args = parser.parse_args()
    margins = Margins(args.margin_xy, args.margin_z, args.joint_margin)
    checker = ReachChecker(margins.joint)
    print("TCP at init_rtm:", np.round(checker.tcp_at_init_rtm(), 3))
    if args.search:
        search(checker, margins, args.step)
    else:
        x, y, floor_z = args.evaluate
        start = time.time()
        fraction, count = evaluate(checker, (x, y), floor_z, margins, args.step)
        print(f"bin centre ({x}, {y}), floor z {floor_z}: {fraction:.1%} of {count} test "
              f"points reached ({time.time() - start:.0f} s)")


if __name__ == "__main__":
    main()
