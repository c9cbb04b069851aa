"""``tangle-drake diagram``: draw a scenario's station diagram with Graphviz."""

from __future__ import annotations

import argparse
from pathlib import Path

from tangle_drake.commands.arguments import add_scenario_argument, scenario_from
from tangle_drake.common.errors import TangleDrakeError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "diagram", help="draw the station's Drake diagram (Graphviz)",
        description="Write the station's system diagram as Graphviz: .dot as text, or .svg/.png "
                    "rendered with Graphviz's `dot` (apt-get install graphviz).")
    add_scenario_argument(parser)
    parser.add_argument("--out", type=Path, default=None,
                        help="output file: .dot, .svg or .png (default: station.svg, or "
                             "station.dot where Graphviz is not installed)")
    parser.add_argument("--depth", type=int, default=1,
                        help="how many levels of subdiagrams to expand (default: 1)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.common.graphviz import graphviz_installed, write_graphviz
    from tangle_drake.station import build_station

    if args.depth < 0:
        raise TangleDrakeError(f"--depth must be 0 or more, got {args.depth}")
    out = args.out
    if out is None:
        out = Path("station.svg" if graphviz_installed() else "station.dot")
        if out.suffix == ".dot":
            print("Graphviz's `dot` is not installed, so the diagram is written as .dot text; "
                  "install it (apt-get install graphviz) for station.svg")
    station = build_station(scenario_from(args).load())
    write_graphviz(station.GetGraphvizString(max_depth=args.depth), out)
    print(f"wrote {out}")
    return 0
