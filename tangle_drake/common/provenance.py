"""Where a result came from: the code's version and commit and the kind of machine that ran it.

A committed result is only comparable with another made by the same code on the same kind of
machine (contact physics is chaotic, and parts per hour count wall time), so every report says
both. Neither may hold a path or a host name of the machine that made it.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tangle_drake import __version__

SOURCE = Path(__file__).resolve().parent.parent
"""The ``tangle_drake`` package."""


def code_commit(source: Path = SOURCE) -> str:
    """The checkout's short commit, ``+changes`` when its files differ from it; ``"not a git
    checkout"`` for an installed wheel (its version then says which code it is)."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(source), *args], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
    try:
        git("ls-files", "--error-unmatch", "common/provenance.py")  # not a wheel inside a checkout
        commit = git("rev-parse", "--short=7", "HEAD")
        changed = git("status", "--porcelain", "--untracked-files=no", "--", ".")
    except (OSError, subprocess.SubprocessError):
        return "not a git checkout"
    return commit + ("+changes" if changed else "")


def memory_gb() -> float | None:
    """Physical memory in GB (Linux), ``None`` where it cannot be read."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1e9
    except (ValueError, OSError, AttributeError):
        return None


def machine_kind() -> str:
    """The kind of machine, e.g. ``2 CPU cores, 24 GB, no GPU``: what sets a run's pace."""
    memory = memory_gb()
    parts = [f"{os.cpu_count() or 1} CPU cores"] + ([f"{memory:.0f} GB"] if memory else [])
    return ", ".join([*parts, gpu_name() or "no GPU"])


def gpu_name() -> str | None:
    """The first CUDA device's name when torch is already imported and sees one; the
    benchmark itself runs on CPUs, so torch is not imported for this alone."""
    torch = sys.modules.get("torch")
    if torch is None or not torch.cuda.is_available():
        return None
    return torch.cuda.get_device_name(0)


def made_by() -> dict[str, str]:
    """The fields a result's summary records: ``made_by``, ``commit`` and ``machine``."""
    return {"made_by": f"tangle_drake {__version__}", "commit": code_commit(),
            "machine": machine_kind()}


def describe(summary: dict) -> str:
    """``made_by``, ``commit`` and ``machine`` of a summary as a report's words; a summary
    written before the last two were recorded gives the version alone."""
    words = [summary["made_by"]]
    if "commit" in summary:
        words.append(f"commit {summary['commit']}")
    if "machine" in summary:
        words.append(f"on {summary['machine']}")
    return ", ".join(words)
