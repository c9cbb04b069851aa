"""Benchmark: IK and trajectories for one whole pick (``ArmMotion.plan_pick``) on one core.

Draws random top-down grasps in the scenario's bin (tool centre 11-40 mm above the floor, as
for parts lying on the floor or on one another; the palm clear of the walls; any closing
direction), plans each from ``HOME`` and prints the median and 95th percentile over the ones
that could be planned, and, apart, the time spent on the ones rejected (unreachable or
colliding), which the pick planner also pays.

    python tools/bench_planning.py [--scenario diagrams/pick_demo.yaml] [--samples 200]
                                   [--seed 0] [--core 0]
"""

from __future__ import annotations

import argparse
import os
import time
from collections import Counter

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix

from tangle_drake.planning.arm_motion import ArmMotion
from tangle_drake.planning.motion import PlanningError
from tangle_drake.robot_model.nextage import HOME
from tangle_drake.scenario import BinConfig
from tangle_drake.scenario.files import resolve_scenario

_PALM_MARGIN = 0.03
"""Grasp centres stay this far from the walls, m (the palm's half-width, about)."""


def random_grasps(bin_config: BinConfig, count: int, seed: int) -> list[np.ndarray]:
    """``count`` top-down tool poses X_WT (4x4) over the bin's floor, seeded."""
    rng = np.random.default_rng(seed)
    half = np.asarray(bin_config.inner_size) / 2 - _PALM_MARGIN
    poses = []
    for _ in range(count):
        xy = np.asarray(bin_config.center) + rng.uniform(-half, half)
        z = bin_config.floor_height + rng.uniform(0.011, 0.04)
        R = RotationMatrix.MakeZRotation(rng.uniform(0, np.pi)) @ RotationMatrix.MakeXRotation(
            np.pi)
        poses.append(RigidTransform(R, [xy[0], xy[1], z]).GetAsMatrix4())
    return poses


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=None,
                        help="scenario whose bin to use (default: the shipped pick_demo.yaml)")
    parser.add_argument("--samples", type=int, default=200, help="random grasps to plan")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random grasps")
    parser.add_argument("--core", type=int, default=0,
                        help="CPU core to pin the process to (-1: do not pin)")
    args = parser.parse_args()
    if args.core >= 0 and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.core})

    bin_config = resolve_scenario(args.scenario).bin
    start = time.perf_counter()
    motion = ArmMotion(bin_config)
    print(f"planning model and IK set up in {time.perf_counter() - start:.2f} s")
    measured = np.concatenate([HOME, np.zeros_like(HOME)])
    planned, rejected = [], []
    reasons: Counter[str] = Counter()
    durations = []
    for X_WT in random_grasps(bin_config, args.samples, args.seed):
        start = time.perf_counter()
        try:
            plan = motion.plan_pick(X_WT, measured)
        except PlanningError as error:
            rejected.append(time.perf_counter() - start)
            reasons[error.kind] += 1
            continue
        planned.append(time.perf_counter() - start)
        durations.append(sum(getattr(plan, name).end_time() for name in
                             ("approach", "descend", "lift", "transfer", "home")))
    ms = np.array(planned) * 1e3
    print(f"planned {len(planned)} of {args.samples} grasps: median {np.median(ms):.0f} ms, "
          f"p95 {np.percentile(ms, 95):.0f} ms, max {ms.max():.0f} ms per pick "
          f"(motion lasts {np.median(durations):.1f} s median)")
    if rejected:
        ms = np.array(rejected) * 1e3
        print(f"rejected {len(rejected)} ({', '.join(f'{n} {k}' for k, n in reasons.items())}): "
              f"median {np.median(ms):.0f} ms, p95 {np.percentile(ms, 95):.0f} ms each")


if __name__ == "__main__":
    main()
