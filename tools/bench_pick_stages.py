"""Benchmark: where a pick's computation goes inside the pick diagram, first pick included.

Runs the demo (closed loop) for ``--picks`` picks and prints, per grasp, the wall time of
perception (render + graspability), of the tangle CNN stage (crops, target mask, network and
the rule, for the diagram's graspability top-k candidates) and of planning, and how many times
the graspability and CNN systems computed during the run (once per look is the goal: their
outputs are cached on their inputs and read only when the planner looks), and where the
robot's (simulated) time went, by the planner's mode: the cycle a parts-per-hour figure is
made of.

    python tools/bench_pick_stages.py [--scenario pick_demo.yaml] [--picks 3] [--seed 0]
"""

from __future__ import annotations

import argparse
import collections
import itertools
import time

from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.graspability.system import GraspabilitySystem
from tangle_drake.pick.planner import PickPlanner
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.cnn_system import TangleCnnSystem


def _count_calls(calls: collections.Counter, cls: type, name: str) -> None:
    method = getattr(cls, name)

    def counted(self, *args, **kwargs):
        calls[cls.__name__] += 1
        return method(self, *args, **kwargs)

    setattr(cls, name, counted)


def _log_modes(entered: list) -> None:
    """Record (time, mode) each time the planner enters a mode."""
    enter = PickPlanner._enter

    def logged(self, mode, s, t):
        entered.append((t, mode))
        return enter(self, mode, s, t)

    PickPlanner._enter = logged


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="pick_demo.yaml")
    parser.add_argument("--picks", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    calls: collections.Counter = collections.Counter()
    _count_calls(calls, GraspabilitySystem, "_calc_candidates")
    _count_calls(calls, TangleCnnSystem, "_calc_result")
    entered: list = []
    _log_modes(entered)
    scenario = resolve_scenario(args.scenario)
    scenario.view_cameras = []
    start = time.perf_counter()
    records = run_demo(DemoOptions(picks=args.picks, scenario=scenario, seed=args.seed),
                       lambda _: None)
    print(f"{args.scenario}, seed {args.seed}: {len(records)} grasps in "
          f"{time.perf_counter() - start:.0f} s wall")
    for r in records:
        t = r.timing
        print(f"grasp {r.index}: perception {1e3 * t.perception_s:6.1f} ms, CNN "
              f"{1e3 * t.cnn_s:5.1f} ms, planning {1e3 * t.planning_s:6.1f} ms")
    print(f"computations per grasp: graspability {calls['GraspabilitySystem'] / len(records):.1f}"
          f", CNN {calls['TangleCnnSystem'] / len(records):.1f}")
    # A mode lasts until the next is entered; the look (PERCEIVE) is not entered through
    # _enter, so "settle" is the wait, the look and the planning up to the next approach.
    spent: collections.Counter = collections.Counter()
    for (t, mode), (t_next, _) in itertools.pairwise(entered):
        spent[mode.value] += t_next - t
    total = sum(spent.values())
    delivered = sum(r.disposition is not None and r.disposition.name == "DELIVERED"
                    for r in records) or len(records)
    print(f"simulated time by mode ({total:.1f} s over {delivered} delivered):")
    for mode, seconds in spent.most_common():
        print(f"  {mode:12s} {seconds:6.2f} s  {100 * seconds / total:5.1f} %  "
              f"{seconds / delivered:5.2f} s per delivered part")


if __name__ == "__main__":
    main()
