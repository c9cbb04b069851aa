"""Options that several subcommands share, each defined once with its check."""

from __future__ import annotations

import argparse

from tangle_drake.errors import TangleDrakeError, check_seed

DEFAULT_SCENARIO = "diagrams/pick_demo.yaml"


def add_scenario_argument(parser: argparse.ArgumentParser,
                          default: str = f"the shipped {DEFAULT_SCENARIO}") -> None:
    """The ``--scenario`` option every station command shares."""
    parser.add_argument("--scenario", default=None, help=f"scenario YAML (default: {default})")


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
