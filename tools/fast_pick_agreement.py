"""Does the physical-pick data's fast pick reproduce the benchmark's full pick?

For each pile (the collection's pile seeds, not the benchmark's) and each of graspability's
first ``--top-k`` candidates, picks three times from the same settled pile under the model's
physics: the full pick (the benchmark's), the same pick with the grasp moved 0.1 mm (the
simulator's own re-run agreement: chaotic contact makes a pick's outcome a draw), and the fast
pick of ``collect --label pick`` (:meth:`~tangle_drake.episode.episode.Episode.single_pick`,
``fast``). Prints per-pick agreement of each with the full pick, the outcome rates of both with
95 % intervals, and picks per minute of each (wall). One JSON line per pile in ``--out``: run
the same command again to resume.

    python tools/fast_pick_agreement.py --part u_hook --piles 20 --out results/agree_u_hook.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.failures import FailureKind
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.common.stats import wilson
from tangle_drake.episode.episode import Episode
from tangle_drake.planning.motions import scenario_mode
from tangle_drake.selection.methods import Method, MethodRun
from tangle_drake.tangle_data.physical import PICK_SCENARIO, PickDataSettings, pick_data_scenario
from tangle_drake.tangle_data.seeds import pile_seed

RERUN_OFFSET = (1e-4, 0.0, 0.0)
"""The re-run's grasp error (x, y in m, degrees): 0.1 mm, far below anything a robot holds."""
PICKS = ("full", "rerun", "fast")


def run_pile(rigs: dict[str, Episode], settings: PickDataSettings, task: int) -> dict:
    """One pile's picks: per rank, each kind's outcome and wall seconds."""
    seed = pile_seed(settings.seed, task)
    settled = rigs["full"].settle(seed)
    ranks = []
    for rank in range(settings.top_k):
        row = {"rank": rank}
        for kind in PICKS:
            run = MethodRun("graspability", 0, only=rank,
                            offset=RERUN_OFFSET if kind == "rerun" else None)
            wall = time.perf_counter()
            record = rigs["fast" if kind == "fast" else "full"].pick(settled.state, run).record
            row[kind] = "timeout" if record is None else (
                record.failure.value if record.failure else record.outcome.value)
            row[f"{kind}_s"] = round(time.perf_counter() - wall, 3)
            if record is not None and record.failure is FailureKind.NO_CANDIDATE:
                return {"task": task, "pile_seed": seed, "ranks": ranks}
        ranks.append(row)
    return {"task": task, "pile_seed": seed, "ranks": ranks}


def report(piles: list[dict]) -> None:
    rows = [r for pile in piles for r in pile["ranks"]]
    n = len(rows)
    print(f"{len(piles)} piles, {n} candidates")
    for kind in ("rerun", "fast"):
        agree = sum(r[kind] == r["full"] for r in rows)
        low, high = wilson(agree, n)
        print(f"  {kind} agrees with the full pick: {agree}/{n} = {100 * agree / n:.1f} % "
              f"[{100 * low:.1f}, {100 * high:.1f}]")
    for kind in PICKS:
        counts = Counter(r[kind] for r in rows)
        rates = ", ".join(f"{name} {100 * c / n:.1f} % [{100 * wilson(c, n)[0]:.1f}, "
                          f"{100 * wilson(c, n)[1]:.1f}]" for name, c in sorted(counts.items()))
        seconds = sum(r[f"{kind}_s"] for r in rows)
        print(f"  {kind}: {rates}; {60 * n / seconds:.1f} picks/min (wall)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="u_hook")
    parser.add_argument("--piles", type=int, default=20)
    parser.add_argument("--top-k", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0, help="collection seed of the piles")
    parser.add_argument("--out", type=Path, required=True, help="JSON lines, one per pile")
    args = parser.parse_args()
    try:
        settings = PickDataSettings(args.part, top_k=args.top_k, seed=args.seed, physics=None)
        scenario = pick_data_scenario((diagrams_dir() / PICK_SCENARIO).read_text(), settings)
        floating = scenario_mode(scenario, "the pick-data scenario") == "floating"
        methods = [Method("graspability", "graspability")]
        rigs = {"full": Episode.single_pick(scenario, methods, args.part, floating),
                "fast": Episode.single_pick(scenario, methods, args.part, floating, fast=True)}
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    done = [json.loads(line) for line in args.out.read_text().splitlines()] \
        if args.out.exists() else []
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("a") as out:
        for task in range(len(done), args.piles):
            done.append(run_pile(rigs, settings, task))
            out.write(json.dumps(done[-1]) + "\n")
            out.flush()
            print(f"pile {task + 1}/{args.piles}", file=sys.stderr, flush=True)
    report(done)
    return 0


if __name__ == "__main__":
    sys.exit(main())
