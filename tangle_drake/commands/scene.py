"""``tangle-drake scene``: build the station, drop a pile, write the top camera's images."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from tangle_drake.commands.arguments import add_scenario_argument, add_seed_argument, scenario_from


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "scene", help="drop a random pile in the station and write the camera's images",
        description="Build the simulated station from a scenario, drop and settle a random "
                    "pile, and write the top camera's depth (metres: depth.npy and millimetres: "
                    "depth.png, 16-bit), colour image, camera.json, pile.json and the scenario's "
                    "view cameras' images to --out.")
    add_scenario_argument(parser)
    parser.add_argument("--out", type=Path, default=Path("out/scene"),
                        help="output directory (default: out/scene)")
    add_seed_argument(parser, None, help="pile seed (default: the scenario's pile.seed)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.common.paths import check_writable
    from tangle_drake.station.pile import check_pile
    from tangle_drake.station.scene import make_scene

    scenario = scenario_from(args).load()
    for warning in check_pile(scenario):
        print(warning)
    out: Path = args.out
    check_writable(out, "--out", directory=True)
    scene = make_scene(scenario, seed=args.seed, progress=print)
    out.mkdir(parents=True, exist_ok=True)  # only now: a refused scene leaves no folder
    start = time.perf_counter()
    scene.write(out)
    views = "".join(f", {name}.png" for name in scene.views)
    print(f"wrote {out}/depth.npy, depth.png, rgb.png{views}, camera.json, pile.json "
          f"({time.perf_counter() - start:.2f} s)")
    report = scene.report
    print(f"pile: {report.num_in_bin}/{report.num_parts} parts in the bin, "
          f"settled={report.settled} after {report.settle_time:.2f} s simulated "
          f"({report.wall_time:.1f} s wall), redrawn {len(report.redrawn)}, "
          f"parked {len(report.parked)}")
    above_floor = np.isfinite(scene.depth) & (scene.depth < scene.floor_depth - 0.002)
    print(f"depth: {int(above_floor.sum())} pixels above the bin floor; timings: "
          + ", ".join(f"{k} {v:.2f} s" for k, v in scene.timings.items()))
    (out / "timings.json").write_text(json.dumps(scene.timings, indent=2))
    return 0
