"""The ``tangle-drake`` command line: one subcommand per module in ``tangle_drake.commands``."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from tangle_drake import __version__
from tangle_drake.commands import COMMAND_MODULES
from tangle_drake.errors import TangleDrakeError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tangle-drake",
        description="Bin picking of tangle-prone parts with Drake: one and only one part per pick.",
    )
    parser.add_argument("--version", action="version", version=f"tangle-drake {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(f"tangle_drake.commands.{name}").register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
