"""Benchmark the graspability index on synthetic piles, one CPU core.

Synthetic piles: wires 6-10 mm thick and 40-110 mm long dropped into a 360 x 260 mm bin with
80 mm walls, seen by a camera 0.5 m above the bin floor (vertical field of view 45 degrees).
Each image is timed ``--repeats`` times through ``compute_candidates`` (input checks included,
file I/O excluded); the table gives the median and 95th percentile of all those runs, in wall
time and in CPU time of this thread (less sensitive to other processes than wall time,
though a busy machine slows both).

    python tools/bench_graspability.py [--sizes 320x240 640x480 1280x960] [--images 20]
        [--repeats 5] [--parts 30] [--orientations 16] [--cell-size 0.0025] [--grip-span 0.014]

(with the package installed, or from the repository root with ``PYTHONPATH=.``). Target: a
median of at most 20 ms per 640x480 image.
"""

from __future__ import annotations

import argparse
import os
import time

import cv2
import numpy as np

from tangle_drake.graspability import GraspabilityParams, compute_candidates
from tangle_drake.graspability.synthetic import synthetic_pile


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", nargs="+", default=["320x240", "640x480", "1280x960"])
    parser.add_argument("--images", type=int, default=20, help="piles per size")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per pile")
    parser.add_argument("--parts", type=int, default=30, help="parts per pile")
    parser.add_argument("--orientations", type=int, default=16)
    parser.add_argument("--cell-size", type=float, default=GraspabilityParams.cell_size_m,
                        help="work-map cell, metres")
    parser.add_argument("--grip-span", type=float, metavar="M",
                        help="with the grip test (off by default, as in the paper)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    try:
        params = GraspabilityParams(n_orientations=args.orientations, cell_size_m=args.cell_size,
                                    max_grip_span_m=args.grip_span)
    except ValueError as error:
        parser.error(str(error))
    grip = "off" if args.grip_span is None else f"{args.grip_span * 1e3:g} mm"
    print(f"one core (cv2.setNumThreads(1)), {args.orientations} orientations, "
          f"{args.cell_size * 1e3:g} mm cells, grip test {grip}, "
          f"{args.parts} parts per pile, {args.images} piles x {args.repeats} runs per size, "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    print(f"{'size':>10} {'wall median':>12} {'wall p95':>9} {'cpu median':>11} {'cpu p95':>8}"
          f" {'candidates':>11}")
    for size in args.sizes:
        width, height = (int(n) for n in size.lower().split("x"))
        rng = np.random.default_rng(args.seed)
        piles = [synthetic_pile(rng, (width, height), n_parts=args.parts)
                 for _ in range(args.images)]
        compute_candidates(*piles[0], params=params)  # warm-up: first-call allocations
        wall, cpu, found = [], [], []
        for depth, camera in piles:
            for _ in range(args.repeats):
                start_wall, start_cpu = time.perf_counter(), time.thread_time()
                candidates = compute_candidates(depth, camera, params=params)
                cpu.append(time.thread_time() - start_cpu)
                wall.append(time.perf_counter() - start_wall)
            found.append(len(candidates))
        wall_ms, cpu_ms = np.array(wall) * 1e3, np.array(cpu) * 1e3
        print(f"{size:>10} {np.median(wall_ms):9.1f} ms {np.percentile(wall_ms, 95):6.1f} ms "
              f"{np.median(cpu_ms):8.1f} ms {np.percentile(cpu_ms, 95):5.1f} ms "
              f"{np.mean(found):11.1f}")


if __name__ == "__main__":
    main()
