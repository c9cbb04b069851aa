"""Measure how full a scenario's bin is: settle piles of each part count and report the
pile's top against the rim, the parts that stayed in, and the share of its bounding sphere a
part takes up in the pile (what ``check_pile`` assumes as ``PACKING``).

Heights are the top camera's (``BinContents``: the highest point seen per 4 mm cell), so they
are what the picker sees: the top (the two highest cells left out), the surface's 90th and
99th percentiles, the mean (the pile's volume over the floor). A part that lands leaning on a
wall can stand up to the rim while the pile lies far below it, so a bin holds its pile when,
in every pile, no part was taken out, no part's centre lies above the rim, and the surface's
99th percentile stays below it.

    python tools/bin_fill.py --scenario diagrams/factory_bin.yaml --parts u_hook s_hook \\
        --counts 40 60 80 --piles 3 --out docs/results/factory_bin/fill.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.drivers.camera import camera_model
from tangle_drake.parts.library import load_part
from tangle_drake.pick.bin_contents import bin_contents
from tangle_drake.scenario.files import scenario_source
from tangle_drake.station import build_station
from tangle_drake.station.pile import PileSettler


def fill(scenario_files: list[str], part: str, count: int, piles: int) -> dict:
    """Settle ``piles`` piles of ``count`` ``part`` in the scenario's bin; what they fill."""
    scenario = scenario_source(scenario_files, [
        f"pile: {{parts: [{{part: {part}, count: {count}}}]}}"]).load()
    station = build_station(scenario)
    settler = PileSettler(station, scenario)
    camera = camera_model(scenario)
    sphere = 4 / 3 * np.pi * load_part(part).bounding_radius ** 3
    floor = float(np.prod(scenario.bin.inner_size))
    rim = scenario.bin.floor_height + scenario.bin.wall_height
    rows = []
    for k in range(piles):
        cpu = time.process_time()
        settled = settler.settle(scenario.pile.seed + k)
        depth = station.GetOutputPort("camera.depth_image").Eval(
            settler.simulator.get_context()).data
        contents = bin_contents(depth, camera, scenario.bin)
        heights = np.nan_to_num(contents.heights, nan=0.0)
        volume = float(heights.mean()) * floor
        centres = station.part_poses(settler.simulator.get_context())[:, :3, 3]
        report = settled.report
        rows.append({"seed": report.seed, "in_bin": report.num_in_bin,
                     "parked": len(report.parked), "redrawn": len(report.redrawn),
                     "settled": report.settled, "top_m": round(contents.top(), 4),
                     "p90_m": round(float(np.percentile(heights, 90)), 4),
                     "p99_m": round(float(np.percentile(heights, 99)), 4),
                     "centres_above_rim": int((centres[:, 2] > rim).sum()),
                     "mean_height_m": round(volume / floor, 4),
                     "packing": round(volume / (max(report.num_in_bin, 1) * sphere), 3),
                     "cpu_s": round(time.process_time() - cpu, 1)})
    return {"part": part, "count": count, "wall_m": scenario.bin.wall_height,
            "inner_size_m": list(scenario.bin.inner_size), "piles": rows,
            "holds": all(r["p99_m"] < scenario.bin.wall_height and not r["parked"]
                         and not r["centres_above_rim"] for r in rows)}


def line(result: dict) -> str:
    rows = result["piles"]
    def span(key: str) -> str:
        values = [100 * r[key] for r in rows]
        return f"{min(values):.1f}" if len(values) == 1 else \
            f"{min(values):.1f}-{max(values):.1f}"

    return (f"{result['part']} x {result['count']}: "
            f"{sum(r['in_bin'] for r in rows)}/{result['count'] * len(rows)} in the bin "
            f"({sum(r['parked'] for r in rows)} parked, {sum(r['redrawn'] for r in rows)} "
            f"redrawn) over {len(rows)} piles; of a {100 * result['wall_m']:.1f} cm wall: "
            f"top {span('top_m')} cm, surface 99 % {span('p99_m')}, 90 % {span('p90_m')}, "
            f"mean {span('mean_height_m')} cm; "
            f"{sum(r['centres_above_rim'] for r in rows)} centres above the rim; a part takes up "
            f"{np.mean([r['packing'] for r in rows]):.2f} of its bounding sphere; "
            f"{np.mean([r['cpu_s'] for r in rows]):.0f} CPU s a pile; "
            + ("holds it" if result["holds"] else "does NOT hold it"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", nargs="+", default=["floating_gripper.yaml"],
                        metavar="YAML", help="scenario file, then overlay files")
    parser.add_argument("--parts", nargs="+", default=["u_hook"])
    parser.add_argument("--counts", nargs="+", type=int, default=[15])
    parser.add_argument("--piles", type=int, default=3, help="piles per count (seeds from "
                        "the scenario's pile.seed)")
    parser.add_argument("--out", type=Path, help="append one JSON line per part and count; "
                        "those already there are not run again")
    args = parser.parse_args()
    done: set[tuple[str, int]] = set()
    if args.out is not None and args.out.exists():
        for text in args.out.read_text().splitlines():
            result = json.loads(text)
            if len(result["piles"]) >= args.piles:
                done.add((result["part"], result["count"]))
                print(line(result))
    try:
        for part in args.parts:
            for count in args.counts:
                if (part, count) in done:
                    continue
                result = fill(args.scenario, part, count, args.piles)
                print(line(result), flush=True)
                if args.out is not None:
                    args.out.parent.mkdir(parents=True, exist_ok=True)
                    with args.out.open("a") as handle:
                        handle.write(json.dumps(result) + "\n")
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
