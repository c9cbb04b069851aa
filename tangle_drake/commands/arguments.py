"""Options that several subcommands share, each defined once with its check."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from tangle_drake.common.errors import TangleDrakeError, check_seed

if TYPE_CHECKING:
    from tangle_drake.scenario.files import ScenarioSource

DEFAULT_SCENARIO = "diagrams/pick_demo.yaml"


def add_scenario_argument(parser: argparse.ArgumentParser,
                          default: str = f"the shipped {DEFAULT_SCENARIO}") -> None:
    """The scenario options every station command shares: a base file with overlay files
    merged onto it in order, and overlay texts merged last (Drake's ``--scenario_text``)."""
    parser.add_argument("--scenario", nargs="+", default=None, metavar="YAML",
                        help=f"scenario file (default: {default}), then overlay files, each "
                             "changing only the fields it names")
    parser.add_argument("--scenario-text", action="append", default=[], metavar="YAML",
                        help="an overlay as text, merged after the files (may be repeated), "
                             "e.g. \"pile: {seed: 3}\"")


def scenario_from(args: argparse.Namespace) -> ScenarioSource:
    """The scenario the options name (no file: the command's default base)."""
    from tangle_drake.scenario.files import scenario_source  # imports Drake

    return scenario_source(args.scenario, args.scenario_text)


def seed(text: str) -> int:
    """An argparse type: a seed, refused with its value when it is none (argparse then names
    the option)."""
    try:
        return check_seed(int(text), "a seed")
    except (TangleDrakeError, ValueError) as error:
        raise argparse.ArgumentTypeError(
            f"must be a non-negative 63-bit integer, got {text!r}") from error


def add_seed_argument(parser: argparse.ArgumentParser, default: int | None,
                      help: str) -> None:
    """The ``--seed`` option, checked as :func:`seed` checks it."""
    parser.add_argument("--seed", type=seed, default=default, help=help)
