"""Benchmark the tangle-data collector: speed, memory, class balance, pile depth, label quality.

    python tools/bench_collect.py                       # every built-in part, 2 workers
    python tools/bench_collect.py --parts u_hook --piles 12 --workers 1
    python tools/bench_collect.py --reference slow      # also compare with a slow lift
    python tools/bench_collect.py --repeat 3            # label agreement under perturbation

Runs tasks 0..piles-1 of a collection (seed --seed) through the same worker backend as
``tangle-drake collect`` and prints, per part:

- samples/min/core from CPU time (the sum of the workers' CPU seconds spent in tasks: robust
  to other jobs sharing the machine) and from wall time (whole run, start-up included,
  divided by the workers);
- the peak resident memory of any worker;
- the tangled fraction, the share labelled without a lift, the empty-region skips;
- the pile depth in layers (``tangle_data.pile_stats``) and the pile's height;
- with ``--reference slow``: the agreement of each lift's label with a slow lift of the same
  candidate on the same pile (0.1 m/s, 0.5 s hold, no early exit, no part locked); with
  ``--reference unfrozen``, with the default lift locking no part;
- with ``--repeat K``: the share of lifts whose K perturbed re-runs all agree, and the mean
  agreement with the majority.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import wait
from dataclasses import replace

import numpy as np

from tangle_drake.common.workers import start_workers
from tangle_drake.dataset.store import TaskResult
from tangle_drake.parts import BUILTIN_PARTS, load_part
from tangle_drake.tangle_data.collect import default_scenario_text
from tangle_drake.tangle_data.defaults import default_parts_per_pile
from tangle_drake.tangle_data.settings import CollectSettings, LiftSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator, data_scenario

REFERENCE_LIFTS = {
    "slow": LiftSettings(speed_m_s=0.1, accel_m_s2=1.0, hold_s=0.5, freeze_beyond_radii=0.0,
                         early_exit=False),
    "unfrozen": LiftSettings(freeze_beyond_radii=0.0),
}
"""``--reference``: a slow lift with every shortcut off, or the default lift with no part
locked (to tell the freezing's effect from the speed's)."""


def run_tasks(settings: CollectSettings, scenario_text: str, piles: int,
              workers: int) -> tuple[list[TaskResult], float]:
    """Tasks 0..piles-1 on ``workers`` workers: results in task order, and the wall time."""
    start = time.perf_counter()
    backend = start_workers(TangleDataSimulator, (scenario_text, settings), workers, None)
    try:
        futures = []
        queue = list(range(piles))
        pending = set()
        while queue or pending:
            while queue and len(pending) < backend.capacity:
                future = backend.submit(queue.pop(0))
                futures.append(future)
                pending.add(future)
            pending = wait(pending, return_when="FIRST_COMPLETED").not_done
        results = sorted((f.result() for f in futures), key=lambda r: r.task)
    finally:
        backend.close()
    return results, time.perf_counter() - start


def bench_part(part: str, args: argparse.Namespace, scenario_text: str) -> dict:
    settings = CollectSettings(part=part, seed=args.seed, repeat=args.repeat)
    if args.lifts_per_pile is not None:
        settings = replace(settings, lifts_per_pile=args.lifts_per_pile)
    count = args.parts_per_pile or default_parts_per_pile(
        part, load_part(part), data_scenario(scenario_text, settings).bin)
    settings = replace(settings, parts_per_pile=count)
    results, wall = run_tasks(settings, scenario_text, args.piles, args.workers)
    stats = [r.stats for r in results]
    samples = sum(s["samples"] for s in stats)
    cpu = sum(s["cpu_s"] for s in stats)
    labels = np.concatenate([r.samples["label"] for r in results])
    row = {
        "part": part, "parts_per_pile": count, "piles": len(results), "samples": samples,
        "per_min_core_cpu": 60 * samples / cpu if cpu else 0.0,
        "per_min_core_wall": 60 * samples / wall / args.workers,
        "peak_rss_mb": max(s["max_rss_mb"] for s in stats),
        "tangled": float(labels.mean()) if samples else float("nan"),
        "immediate": sum(s["immediate"] for s in stats) / max(samples, 1),
        "skipped": sum(s["empty_region"] for s in stats),
        "lift_errors": sum(s["lift_errors"] for s in stats),
        "layers": [s["pile"]["layers"] for s in stats],
        "max_layers": [s["pile"]["max_layers"] for s in stats],
        "height_mm": [1000 * s["pile"]["height_m"] for s in stats],
    }
    lifts = sum(s["repeat_lifts"] for s in stats)
    if lifts:
        row["repeat_all_agree"] = sum(s["repeat_all_agree"] for s in stats) / lifts
        row["repeat_majority"] = sum(s["repeat_majority"] for s in stats) / lifts
        row["repeat_lifts"] = lifts
    if args.reference:
        reference, _ = run_tasks(replace(settings, lift=REFERENCE_LIFTS[args.reference],
                                         repeat=1), scenario_text, args.piles, args.workers)
        row.update(_agreement(results, reference))
    return row


def _agreement(default: list[TaskResult], reference: list[TaskResult]) -> dict:
    """Label agreement of the lifted samples, matched by (task, candidate rank), and the
    disagreements by direction."""
    pairs = []
    for a, b in zip(default, reference, strict=True):
        labels_b = dict(zip(b.samples["rank"].tolist(), b.samples["label"].tolist(),
                            strict=True))
        for rank, label, lifted in zip(a.samples["rank"].tolist(), a.samples["label"].tolist(),
                                       (a.samples["num_lifted"] >= 0).tolist(), strict=True):
            if lifted and rank in labels_b:
                pairs.append((label, labels_b[rank]))
    total = len(pairs)
    return {"reference_agreement": sum(a == b for a, b in pairs) / total if total else np.nan,
            "reference_lifts": total,
            "only_default_tangled": sum(a > b for a, b in pairs),
            "only_reference_tangled": sum(a < b for a, b in pairs)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", nargs="+", default=list(BUILTIN_PARTS))
    parser.add_argument("--piles", type=int, default=8, help="tasks per part (default 8)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parts-per-pile", type=int, default=None)
    parser.add_argument("--lifts-per-pile", type=int, default=None)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--reference", choices=sorted(REFERENCE_LIFTS), default=None,
                        help="compare every lift's label with this reference lift's")
    args = parser.parse_args()
    scenario_text = default_scenario_text()
    rows = []
    for part in args.parts:
        row = bench_part(part, args, scenario_text)
        rows.append(row)
        print(_format(row), flush=True)
    total = sum(r["samples"] for r in rows)
    cpu_rate = total / sum(r["samples"] / r["per_min_core_cpu"] for r in rows if r["samples"])
    print(f"all parts: {total} samples, {cpu_rate:.1f} samples/min/core (CPU time), "
          f"peak RSS per worker {max(r['peak_rss_mb'] for r in rows):.0f} MB")


def _format(row: dict) -> str:
    line = (f"{row['part']:8s} N={row['parts_per_pile']:2d} piles={row['piles']} "
            f"samples={row['samples']:3d}  {row['per_min_core_cpu']:5.1f}/min/core (CPU)  "
            f"{row['per_min_core_wall']:5.1f}/min/core (wall)  RSS {row['peak_rss_mb']:.0f} MB  "
            f"tangled {100 * row['tangled']:4.1f} %  no-lift {100 * row['immediate']:4.1f} %  "
            f"skipped {row['skipped']}  errors {row['lift_errors']}  "
            f"layers {np.mean(row['layers']):.1f} (max {max(row['max_layers'])})  "
            f"height {np.mean(row['height_mm']):.0f} mm")
    if "repeat_lifts" in row:
        line += (f"  repeat: all agree {100 * row['repeat_all_agree']:.1f} %, majority "
                 f"{100 * row['repeat_majority']:.1f} % ({row['repeat_lifts']} lifts)")
    if "reference_lifts" in row:
        line += (f"  vs reference lift: {100 * row['reference_agreement']:.1f} % agree "
                 f"({row['reference_lifts']} lifts; tangled only with the default lift "
                 f"{row['only_default_tangled']}, only with the reference "
                 f"{row['only_reference_tangled']})")
    return line


if __name__ == "__main__":
    main()
