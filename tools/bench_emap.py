"""Benchmark: the entanglement map of one 640x480 depth image, on one core (target <= 50 ms).

Renders a settled pile of the floating-gripper scenario (or reads ``--depth FILE.npy``) and
times ``entanglement_map`` over the bin's region, and over the whole image.

    python tools/bench_emap.py [--depth depth.npy] [--runs 50]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from tangle_drake.entanglement.emap import entanglement_map
from tangle_drake.graspability.roi import bin_roi
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.station import camera_model
from tangle_drake.station.bin_model import inner_corners


def _pile_depth(scenario) -> np.ndarray:
    from tangle_drake.station.scene import make_scene  # simulates the pile: only without --depth

    scenario.view_cameras = []
    return make_scene(scenario, seed=0).depth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--depth", help="a metric depth image (.npy) of the scenario's camera")
    parser.add_argument("--runs", type=int, default=50)
    args = parser.parse_args()
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    scenario = resolve_scenario("floating_gripper.yaml")
    depth = np.load(args.depth) if args.depth else _pile_depth(scenario)
    roi = bin_roi(camera_model(scenario), inner_corners(scenario.bin))
    for name, region in (("bin region", roi), ("whole image", None)):
        entanglement_map(depth, region)  # first call: OpenCV's set-up
        times = []
        for _ in range(args.runs):
            start = time.perf_counter()
            emap = entanglement_map(depth, region)
            times.append(time.perf_counter() - start)
        print(f"{depth.shape[1]}x{depth.shape[0]}, {name}: {len(emap.segments)} segments, "
              f"median {1e3 * np.median(times):.1f} ms, p95 "
              f"{1e3 * np.percentile(times, 95):.1f} ms over {args.runs} runs on one core "
              "(target <= 50 ms)")


if __name__ == "__main__":
    main()
