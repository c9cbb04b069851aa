"""Does the lift clear of the pile matter in a deep bin? The same closed-loop clearings of the
dense bin (40 parts, several layers) with the lift the hanging-chain rule sets (the default,
two part lengths over the pile's top) and with the fixed lift over the rim (0 part lengths).

    python tools/deep_bin_lift.py --parts j_hook u_hook --trials 2 --hanging-parts 0 --out DIR
    python tools/deep_bin_lift.py --parts j_hook u_hook --trials 2 --hanging-parts 2 --out DIR
    python tools/deep_bin_lift.py --out DIR --report

Each bin's clearing is one JSON line of ``DIR/hanging_<N>.jsonl`` (the benchmark's record of a
bin; its piles are the benchmark's, ``--seed`` as ``bench --seed``), so two variants can run at
once, one per core, and the same command resumes. ``--report`` prints, per variant and over the
bins both variants cleared, what a weighing too low would show: first weighings that came
while a held part still rested on the pile, several parts read as one, deliveries of several,
and the parts per hour.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tangle_drake.bench.clear_report import figures
from tangle_drake.bench.clearing import ClearWorker
from tangle_drake.bench.runner import BenchOptions, plan
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.scenario.files import scenario_source

SCENARIO = "diagrams/dense_bin.yaml"


def run(args: argparse.Namespace) -> None:
    variant = f"pick: {{hanging_parts: {args.hanging_parts:g}}}"  # an overlay on the scenario
    config, trials, notices = plan(BenchOptions(
        methods=[args.method], parts=args.parts, trials=args.trials, seed=args.seed,
        scenario=scenario_source(args.scenario, [variant]), clear=True))
    for notice in notices:
        print(notice, file=sys.stderr)
    out = args.out / f"hanging_{args.hanging_parts:g}.jsonl"
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {(r["part"], r["trial"]) for r in _read(out)}
    worker = ClearWorker(config)
    todo = [(i, t) for i, spec in enumerate(config.parts) for t in range(trials)
            if (spec.name, t) not in done]
    print(f"{len(done)} bin(s) done before, {len(todo)} to clear into {out}", flush=True)
    for n, (part_index, trial) in enumerate(todo, 1):
        record = worker.run_task((part_index, trial))
        with out.open("a") as file:
            file.write(json.dumps({**record, "hanging_parts": args.hanging_parts}) + "\n")
        run_ = record["runs"][0]
        print(f"[{n}/{len(todo)}] {record['part']} bin {trial}: {run_['delivered']} delivered "
              f"in {len(run_['grasps'])} grasps, {record['wall_s']:.0f} s", flush=True)


def _read(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def report(directory: Path) -> None:
    variants = {path.stem: _read(path) for path in sorted(directory.glob("hanging_*.jsonl"))}
    if not variants:
        raise TangleDrakeError(f"no hanging_*.jsonl in {directory}")
    shared = set.intersection(*({(r["part"], r["trial"]) for r in v} for v in variants.values()))
    print(f"{len(shared)} bin(s) cleared by all of {', '.join(variants)}")
    for name, records in variants.items():
        runs = [r["runs"][0] for r in records if (r["part"], r["trial"]) in shared]
        f = figures(runs)
        print(f"{name}: {f['delivered']}/{f['parts']} delivered in {f['grasps']} grasps; "
              f"{f['deliveries']} deliveries, {f['several']} with several, "
              f"{f['several_read_as_one']} several read as one; {f['weighed_resting']} first "
              f"weighings with a part resting on the pile; {f['shakes']} shakes, "
              f"{f['put_backs']} put-backs; {f['lost']} lost; "
              f"{f['parts_per_hour']:.0f} parts per hour")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--parts", nargs="+", default=["j_hook", "u_hook"])
    parser.add_argument("--trials", type=int, default=2)
    parser.add_argument("--hanging-parts", type=float, default=2.0,
                        help="part lengths the lift clears the pile's top by (0: fixed lift)")
    parser.add_argument("--method", default="harmonic")
    parser.add_argument("--seed", type=int, default=0, help="the benchmark's run seed")
    parser.add_argument("--scenario", default=SCENARIO)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--report", action="store_true",
                        help="print the figures of the variants in --out and stop")
    args = parser.parse_args()
    try:
        report(args.out) if args.report else run(args)
    except TangleDrakeError as error:
        sys.exit(f"error: {error}")


if __name__ == "__main__":
    main()
