"""Writing Drake's Graphviz diagrams: as ``.dot`` text, or rendered by Graphviz's ``dot``."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError


def graphviz_installed() -> bool:
    """Whether Graphviz's ``dot`` is on the PATH (needed for .svg and .png)."""
    return shutil.which("dot") is not None


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
