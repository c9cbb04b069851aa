"""Benchmark: CPU seconds per simulated second of a pick run, and where they go.

Settles the scenario's pile, then runs the pick diagram open loop for ``--sim`` simulated
seconds (grasp after grasp, as a clearing does), and prints the picks made and the CPU seconds
per simulated second; with ``--profile``, the functions that took the most CPU (``cProfile``,
by own time; it slows Python code down, so the CPU figure is then higher).
Overlays (``--scenario-text``) try other settings on the same pile, e.g. the ``simulation``
speed-ups. Run it on a quiet core: CPU time shared with other processes reads high.

    python tools/bench_sim_speed.py --scenario pick_demo.yaml --sim 40 --profile 12
    python tools/bench_sim_speed.py --scenario floating_gripper.yaml --scenario-text \\
        "simulation: {pick_time_step: 0.003, freeze_beyond_radii: 2}"
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.episode.episode import Episode
from tangle_drake.scenario.files import scenario_source
from tangle_drake.selection.methods import Method, MethodRun


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="pick_demo.yaml")
    parser.add_argument("--scenario-text", action="append", default=[], metavar="YAML")
    parser.add_argument("--sim", type=float, default=40.0, help="simulated seconds to run")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="list the N functions that took the most CPU")
    args = parser.parse_args()
    try:
        scenario = scenario_source(args.scenario, args.scenario_text).load()
        part = scenario.pile.parts[0].part
        episode = Episode.clearing(scenario, [Method("graspability", "graspability")], part,
                                   open_loop=True)
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    cpu = time.process_time()
    settled = episode.settle(scenario.pile.seed)
    settle_cpu = time.process_time() - cpu
    episode.start(settled.state, MethodRun("graspability", scenario.random_seed))
    profile = cProfile.Profile(time.process_time)
    cpu = time.process_time()
    if args.profile:
        profile.enable()
    run = episode.run(args.sim)
    profile.disable()
    cpu = time.process_time() - cpu
    print(f"{args.scenario} {args.scenario_text}: pile settled in {settle_cpu:.1f} CPU s; "
          f"{len(run.records)} grasp(s) in {run.time:.1f} simulated s, {cpu:.1f} CPU s: "
          f"{cpu / run.time:.2f} CPU s per simulated s")
    for record in run.records:
        print(f"  {record.describe()}")
    if args.profile:
        pstats.Stats(profile).sort_stats("tottime").print_stats(args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
