"""Content-addressed cache of generated part files: ``cache_dir()/parts/<key>/``.

The key hashes everything a part's files depend on plus `FORMAT_VERSION`, so a changed input
gets a new entry and an unchanged one is never rebuilt. Entries are built in a temporary
directory and renamed into place, so a killed run leaves no half-written entry, and two
processes building the same part at once both end up using one complete entry.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tangle_drake.common.paths import cache_dir

# Bump whenever generated files or their metadata change meaning: old entries are then ignored.
FORMAT_VERSION = 3
META_FILE = "meta.json"
_STALE_TEMP_SECONDS = 3600.0


def entry_key(definition: dict[str, Any]) -> str:
    """A short hash of `definition` (JSON-serialisable) and the format version."""
    payload = json.dumps({"format": FORMAT_VERSION, **definition}, sort_keys=True)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()[:24]


def _root() -> Path:
    root = cache_dir() / "parts"
    root.mkdir(parents=True, exist_ok=True)
    return root


def _read_meta(entry: Path) -> dict[str, Any] | None:
    try:
        return json.loads((entry / META_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _remove_stale_temps(root: Path) -> None:
    """Delete temporary directories left by runs killed more than an hour ago."""
    now = time.time()
    for temp in root.glob(".tmp-*"):
        try:
            if now - temp.stat().st_mtime > _STALE_TEMP_SECONDS:
                shutil.rmtree(temp, ignore_errors=True)
        except OSError:
            continue


def get_or_build(
    key: str, build: Callable[[Path], dict[str, Any]]
) -> tuple[Path, dict[str, Any]]:
    """The entry directory for `key` and its metadata, calling `build(directory)` on a miss.

    `build` writes the part's files into the directory it is given and returns the metadata
    (JSON-serialisable) that is stored next to them for fast loading.
    """
    root = _root()
    entry = root / key
    meta = _read_meta(entry)
    if meta is not None:
        return entry, meta
    _remove_stale_temps(root)
    temp = Path(tempfile.mkdtemp(prefix=f".tmp-{key}-", dir=root))
    temp.chmod(0o755)  # mkdtemp makes it private; entries are plain shared files
    try:
        meta = build(temp)
        (temp / META_FILE).write_text(json.dumps(meta, sort_keys=True, indent=1), "utf-8")
        _publish(temp, entry)
    finally:
        shutil.rmtree(temp, ignore_errors=True)
    return entry, _read_meta(entry) or meta


def _publish(temp: Path, entry: Path) -> None:
    """Rename `temp` to `entry`; keep a complete entry another process published first."""
    try:
        os.rename(temp, entry)
        return
    except OSError:
        if _read_meta(entry) is not None:
            return
    # `entry` exists but is incomplete (damaged by hand): move it aside and replace it.
    trash = entry.with_name(f".tmp-trash-{uuid.uuid4().hex}")
    os.rename(entry, trash)
    os.rename(temp, entry)
    shutil.rmtree(trash, ignore_errors=True)
