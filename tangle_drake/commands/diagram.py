"""``tangle-drake diagram``: draw a scenario's station diagram with Graphviz."""

from __future__ import annotations

import argparse
import shutil
import subprocess
from pathlib import Path

from tangle_drake.commands.scene import add_scenario_argument
from tangle_drake.errors import TangleDrakeError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "diagram", help="draw the station's Drake diagram (Graphviz)",
        description="Write the station's system diagram as Graphviz: .dot as text, or .svg/.png "
                    "rendered with Graphviz's `dot` (apt-get install graphviz).")
    add_scenario_argument(parser)
    parser.add_argument("--out", type=Path, default=Path("station.svg"),
                        help="output file: .dot, .svg or .png (default: station.svg)")
    parser.add_argument("--depth", type=int, default=1,
                        help="how many levels of subdiagrams to expand (default: 1)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.scenario_files import resolve_scenario
    from tangle_drake.station import build_station

    station = build_station(resolve_scenario(args.scenario))
    write_graphviz(station.GetGraphvizString(max_depth=args.depth), args.out)
    print(f"wrote {args.out}")
    return 0


def write_graphviz(dot_source: str, out: Path) -> None:
    """Write Graphviz source as ``out``: text for .dot, rendered by ``dot`` otherwise."""
    suffix = out.suffix.lower().lstrip(".")
    if suffix not in ("dot", "svg", "png"):
        raise TangleDrakeError(f"--out must end in .dot, .svg or .png, not {out.name!r}")
    out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == "dot":
        out.write_text(dot_source)
        return
    dot = shutil.which("dot")
    if dot is None:
        raise TangleDrakeError("Graphviz's `dot` is not installed, so only .dot output is "
                               "possible; install it (apt-get install graphviz) or use --out "
                               f"{out.with_suffix('.dot')}")
    result = subprocess.run([dot, f"-T{suffix}", "-o", str(out)], input=dot_source.encode(),
                            capture_output=True, check=False)
    if result.returncode != 0:
        raise TangleDrakeError(f"dot failed: {result.stderr.decode(errors='replace').strip()}")
