"""The benchmark's failure gallery (``bench --gallery``): a tile per failed pick, by method and
failure kind, so a reader sees why a method fails on a part.

A tile is the top camera's depth view at pick time around the chosen grasp, its hand drawn
(the whole view at half size where none was chosen), captioned with the method, part, trial
and what happened. Workers draw the tiles (they have the image) and return them with the
trial's result; the driver writes them under ``gallery/<method>/<kind>/<part>_<trial>.png``
and ``gallery/index.md`` lists every failed pick of the run (a pick run before ``--gallery``
was asked for has no tile and says so).
"""

from __future__ import annotations

import re
import time
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.graspability.overlay import top_view
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.pick.outcome import PickRecord

GALLERY = "gallery"
INDEX = "index.md"
TILE_KEY = "tile_png"
"""The pick row's field that carries its tile from the worker to the driver (never stored)."""
_CAPTION_PX = 24
_WINDOW = (320, 240)
"""Pixels of the top view kept around the chosen grasp."""


def failure_kind(row: dict) -> str | None:
    """What a failed pick's tile is filed under (``None`` for a success)."""
    if row["result"] == "success":
        return None
    return row["failure"] if row["result"] == "failure" else row["result"]


def tile(depth: np.ndarray, record: PickRecord | None, intrinsics: CameraIntrinsics,
         caption: str) -> bytes:
    """A failed pick's tile as PNG bytes."""
    chosen = None if record is None else record.candidate
    picture = top_view(depth, [] if chosen is None else [chosen], intrinsics)
    if chosen is None:  # nothing chosen: the whole view, at half size
        small = cv2.resize(picture, (picture.shape[1] // 2, picture.shape[0] // 2),
                           interpolation=cv2.INTER_AREA)
    else:  # the chosen grasp's surroundings, at full size
        rows, cols = picture.shape[:2]
        u0 = int(np.clip(chosen.u - _WINDOW[0] / 2, 0, max(cols - _WINDOW[0], 0)))
        v0 = int(np.clip(chosen.v - _WINDOW[1] / 2, 0, max(rows - _WINDOW[1], 0)))
        small = picture[v0:v0 + _WINDOW[1], u0:u0 + _WINDOW[0]]
    band = np.zeros((_CAPTION_PX, small.shape[1], 3), np.uint8)
    cv2.putText(band, caption, (6, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1,
                cv2.LINE_AA)
    ok, data = cv2.imencode(".png", np.vstack([band, small]))
    assert ok, "PNG encoding of a uint8 image cannot fail"
    return data.tobytes()


def caption(method: str, part: str, trial: int, row: dict) -> str:
    return f"{method} | {part} trial {trial} | {failure_kind(row)}"


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "_"


def tile_path(directory: Path, part: str, trial: int, row: dict) -> Path:
    return (Path(directory) / GALLERY / _safe(row["method"]) / _safe(failure_kind(row))
            / f"{_safe(part)}_{trial:03d}.png")


def save_tiles(directory: Path, result: dict) -> None:
    """Write the tiles a trial's result carries (and take them out of it)."""
    for row in result["picks"]:
        data = row.pop(TILE_KEY, None)
        if data is not None:
            path = tile_path(directory, result["part"], result["trial"], row)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)


def write_index(directory: Path, trials: Sequence[dict], methods: Sequence[str]) -> Path:
    """``gallery/index.md``: every failed pick of ``trials``, by method and failure kind."""
    directory = Path(directory)
    lines = ["# Failure gallery", "",
             "Each tile: the top view at pick time with the chosen grasp (none drawn where no "
             "grasp was chosen), the method, the part and trial, and what happened.", ""]
    for method in methods:
        failed = [(trial, row) for trial in trials for row in trial["picks"]
                  if row["method"] == method and failure_kind(row) is not None]
        lines += [f"## {method}: {len(failed)} failed pick(s)", ""]
        for kind in sorted({failure_kind(row) for _, row in failed}):
            of_kind = [(t, r) for t, r in failed if failure_kind(r) == kind]
            lines += [f"### {kind} ({len(of_kind)})", ""]
            for trial, row in of_kind:
                path = tile_path(directory, trial["part"], trial["trial"], row)
                name = f"{trial['part']} trial {trial['trial']}"
                lines.append(f"![{name}]({path.relative_to(directory / GALLERY).as_posix()})"
                             if path.is_file() else f"- {name}: no tile (run before --gallery)")
            lines.append("")
    index = directory / GALLERY / INDEX
    index.parent.mkdir(parents=True, exist_ok=True)
    index.write_text("\n".join(lines))
    return index


def timed_tile(depth: np.ndarray, record: PickRecord | None, intrinsics: CameraIntrinsics,
               text: str) -> tuple[bytes, float]:
    """:func:`tile` and the seconds it took (the report says what the gallery costs)."""
    start = time.perf_counter()
    data = tile(depth, record, intrinsics, text)
    return data, time.perf_counter() - start
