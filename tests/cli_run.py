"""Run a ``tangle-drake`` subcommand in-process, parsed by the real command line's parser, so
that a ``TangleDrakeError`` reaches the test (``tangle_drake.cli.main`` would turn it into
exit code 2)."""

from tangle_drake.cli import build_parser


def run_command(*argv: str) -> int | None:
    """``run_command("train", "--data", ...)``: the subcommand's return value."""
    args = build_parser().parse_args(list(argv))
    return args.func(args)
