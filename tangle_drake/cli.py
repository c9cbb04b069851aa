"""The ``tangle-drake`` command line: one subcommand per module in ``tangle_drake.commands``."""

from __future__ import annotations

import argparse
import importlib
import os
import select
import sys
from collections.abc import Sequence

from tangle_drake import __version__
from tangle_drake.commands import COMMAND_MODULES
from tangle_drake.common.errors import SafetyStop, TangleDrakeError


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
        code = int(args.func(args) or 0)
        sys.stdout.flush()  # a reader that has gone shows up here, not at interpreter exit
        return code
    except SafetyStop as error:
        print(f"error: {error}", file=sys.stderr)
        return SAFETY_STOP_EXIT
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        if not _stdout_gone():
            raise  # some other pipe broke: that is a real error
        return SIGPIPE_EXIT
    except OSError as error:
        if error.filename is None:
            raise  # not about a file the user named: a real error, with its traceback
        print(f"error: {error.filename}: {error.strerror or error}", file=sys.stderr)
        return 2


def console() -> None:
    """The ``tangle-drake`` console script. After a safety stop the process ends at once:
    nothing is left to clean up, and the interpreter's teardown (torch's above all)
    would keep a controller whose robot has stopped running past ``status_timeout`` + 1 s."""
    code = main()
    if code == SAFETY_STOP_EXIT:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


SAFETY_STOP_EXIT = 3
"""The exit status after the robot's safety stop (2 is any other refused input)."""

SIGPIPE_EXIT = 141
"""The shell's status for a tool stopped by SIGPIPE (128 + 13), e.g. under ``| head``."""


def _stdout_gone() -> bool:
    """Whether standard output's reader has gone (a pipe's write end reports POLLERR then);
    if so, point it at /dev/null so the flush at interpreter exit stays quiet too."""
    try:
        sys.stdout.flush()
        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        gone = any(event & select.POLLERR for _, event in poller.poll(0))
    except BrokenPipeError:
        gone = True
    except (AttributeError, OSError, ValueError):  # no poll() here, or stdout is no file
        return False
    if gone:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    return gone


if __name__ == "__main__":
    console()
