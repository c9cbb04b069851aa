"""``tangle-drake graspability``: ranked grasp candidates for depth images and height maps.

One call takes many images; a bad image is reported and skipped, and the exit status is 1 if
any failed. Metric depth (``.npy``, float ``.tif``) needs the camera (``--camera``, else a
``camera.json`` next to the image); a height-map ``.png`` needs its two scales.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.camera import CameraModel, load_camera_json
from tangle_drake.entanglement.emap import entanglement_map
from tangle_drake.errors import TangleDrakeError
from tangle_drake.graspability import (
    FINGER_GRIP_SPAN_M,
    GraspabilityParams,
    GraspCandidate,
    HandModel,
    compute_candidates,
    compute_candidates_from_height_map,
)
from tangle_drake.graspability.inputs import (
    DEEP_HEIGHT_MAP_M,
    ImageFile,
    height_map_to_depth,
    height_span,
    is_grey,
    millimetres_to_depth,
    read_image_file,
)
from tangle_drake.graspability.overlay import depth_preview, draw_candidates, emap_underlay
from tangle_drake.graspability.workmap import View
from tangle_drake.gripper import DEFAULT_GRIPPER


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "graspability", help="rank parallel-jaw grasp candidates in depth images",
        description="Graspability index (Domae et al. 2014) for the project's gripper. Poses "
                    "are the tool frame T (between the finger pads, +z along the approach = "
                    "the camera's +z, +y along the closing direction) in the world frame.")
    parser.add_argument("images", nargs="+", type=Path, metavar="IMAGE",
                        help="metric depth (.npy or float .tif, metres along the camera's +z) "
                             "or a height-map .png (8/16-bit, brighter = higher)")
    parser.add_argument("--camera", type=Path, metavar="JSON",
                        help="camera.json for metric depth (default: camera.json next to the "
                             "image)")
    parser.add_argument("--height-per-level", type=float, metavar="M",
                        help="height of one grey level of a height-map PNG, metres")
    parser.add_argument("--pixel-size", type=float, metavar="M",
                        help="size of one pixel of a height-map PNG, metres")
    parser.add_argument("--top-k", type=int, default=5, metavar="K",
                        help="candidates per image (default 5)")
    parser.add_argument("--roi", type=int, nargs=4, metavar=("U0", "V0", "U1", "V1"),
                        help="keep the whole hand within pixels u0 <= u < u1, v0 <= v < v1 "
                             "(e.g. the bin's inside)")
    parser.add_argument("--roi-margin", type=int, default=0, metavar="PX",
                        help="keep the hand this many pixels inside the ROI's (or the "
                             "image's) edge")
    parser.add_argument("--grip-span", type=float, metavar="M",
                        help="grip test: drop grasps whose squeezed top layer stretches more "
                             "than M metres along the closing direction (off by default, as "
                             f"in the paper; the pick diagram uses {FINGER_GRIP_SPAN_M})")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the results here")
    parser.add_argument("--overlay", type=Path, metavar="DIR",
                        help="write a PNG per image with the candidates' hands drawn")
    parser.add_argument("--emap", action="store_true",
                        help="also compute the topological entanglement map (Zhang et al. "
                             "2021) over the --roi: each candidate's entanglement (0-1) in "
                             "the printout and JSON, and the map under the overlay's hands")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.top_k < 1 or args.roi_margin < 0:
        raise TangleDrakeError("--top-k must be at least 1 and --roi-margin at least 0")
    if args.grip_span is not None and not args.grip_span > 0:
        raise TangleDrakeError(f"--grip-span must be a positive length, got {args.grip_span}")
    params = GraspabilityParams(top_k=args.top_k, roi_margin_px=args.roi_margin,
                                max_grip_span_m=args.grip_span)
    roi = None if args.roi is None else tuple(args.roi)
    hand = HandModel.from_gripper(DEFAULT_GRIPPER)
    cameras: dict[Path, CameraModel] = {}
    overlay_names: set[str] = set()
    results = []
    for path in args.images:
        try:
            entry, picture, view = _process(path, args, hand, params, roi, cameras)
            if args.overlay is not None:
                _write_overlay(args.overlay, path, picture, entry["candidates"], hand, view,
                               overlay_names)
        except TangleDrakeError as error:
            print(f"error: {error}", file=sys.stderr)
            results.append({"image": str(path), "error": str(error)})
            continue
        _print_summary(path, entry)
        entanglement = entry.pop("entanglement", [None] * len(entry["candidates"]))
        entry["candidates"] = [candidate.to_dict() | ({} if e is None else {"entanglement": e})
                               for candidate, e in zip(entry["candidates"], entanglement,
                                                       strict=True)]
        results.append(entry)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=2))
    failed = sum("error" in entry for entry in results)
    if failed:
        print(f"{failed} of {len(results)} images failed", file=sys.stderr)
    return 1 if failed else 0


def _process(path: Path, args: argparse.Namespace, hand: HandModel,
             params: GraspabilityParams, roi: tuple[int, int, int, int] | None,
             cameras: dict[Path, CameraModel]) -> tuple[dict, np.ndarray, View]:
    """Candidates for one image: the JSON entry (candidates still objects), a picture of the
    image for the overlay, and the view to draw in."""
    image = read_image_file(path)
    if _depth_png(image, path, args):  # 16-bit millimetres with its camera: `scene`'s depth.png
        image = replace(image, array=millimetres_to_depth(image.array), is_depth=True)
    if image.is_depth:
        camera = _camera_for(path, args.camera, cameras)
        start = time.perf_counter()
        candidates = compute_candidates(image.array, camera, hand, params, roi)
        elapsed = time.perf_counter() - start
        picture, view = depth_preview(image.array), View.of_camera(camera.intrinsics)
    else:
        if image.array.ndim == 3 and not is_grey(image.array):
            raise TangleDrakeError(f"{path}: this is a colour image, not a height map (a "
                                   "height map is one grey level per pixel, brighter = higher)")
        if args.height_per_level is None or args.pixel_size is None:
            raise TangleDrakeError(f"{path}: a height-map PNG needs --height-per-level and "
                                   "--pixel-size (metres)")
        span = height_span(image.array, args.height_per_level)
        if span > DEEP_HEIGHT_MAP_M:
            print(f"warning: {path}: its grey levels span {span:.2f} m of height at "
                  f"--height-per-level {args.height_per_level:g}, deeper than any bin: is "
                  "that the height of one grey level, in metres?", file=sys.stderr)
        start = time.perf_counter()
        candidates = compute_candidates_from_height_map(
            image.array, args.height_per_level, args.pixel_size, hand, params, roi)
        elapsed = time.perf_counter() - start
        picture = depth_preview(height_map_to_depth(image.array, args.height_per_level))
        view = View.of_height_map(image.array.shape[:2], args.pixel_size)
    entry = {"image": str(path), "compute_ms": round(elapsed * 1e3, 3),
             "candidates": candidates}
    if args.emap:
        depth = image.array if image.is_depth else height_map_to_depth(image.array,
                                                                       args.height_per_level)
        start = time.perf_counter()
        emap = entanglement_map(depth, roi)
        entry["emap_ms"] = round((time.perf_counter() - start) * 1e3, 3)
        entry["entanglement"] = emap.at([c.u for c in candidates],
                                        [c.v for c in candidates]).round(4).tolist()
        picture = emap_underlay(picture, emap.image())
    return entry, picture, view


def _depth_png(image: ImageFile, path: Path, args: argparse.Namespace) -> bool:
    """Whether a PNG is a depth image in millimetres: 16-bit grey, with a camera model (given,
    or ``camera.json`` beside it, as ``tangle-drake scene`` writes them) and no height-map
    scale asked for."""
    return (not image.is_depth and image.array.dtype == np.uint16 and image.array.ndim == 2
            and args.height_per_level is None
            and (args.camera is not None or (path.parent / "camera.json").is_file()))


def _camera_for(path: Path, given: Path | None, cameras: dict[Path, CameraModel]) -> CameraModel:
    """The camera of a metric depth image: ``--camera``, else ``camera.json`` beside it."""
    source = given if given is not None else path.parent / "camera.json"
    if given is None and not source.is_file():
        raise TangleDrakeError(f"{path}: metric depth needs the camera intrinsics; pass "
                               "--camera camera.json or put a camera.json next to the image")
    if source not in cameras:
        cameras[source] = load_camera_json(source)
    return cameras[source]


def _print_summary(path: Path, entry: dict) -> None:
    candidates: list[GraspCandidate] = entry["candidates"]
    emap = f", entanglement map in {entry['emap_ms']:.1f} ms" if "emap_ms" in entry else ""
    print(f"{path}: {len(candidates)} candidate(s) in {entry['compute_ms']:.1f} ms{emap}")
    entanglement = entry.get("entanglement", [None] * len(candidates))
    for rank, (c, e) in enumerate(zip(candidates, entanglement, strict=True), 1):
        where = "" if c.pose is None else (
            "  T_W=({:+.3f}, {:+.3f}, {:+.3f}) m".format(*c.pose[:3, 3]))
        if c.height_m is not None:
            where = f"  tips {c.height_m:.4f} m high"
        tangle = "" if e is None else f"  entanglement={e:.2f}"
        print(f"  #{rank}  u={c.u:7.1f} v={c.v:7.1f}  angle={c.angle_deg:6.2f} deg  "
              f"depth={c.depth_m:.4f} m  score={c.score:.3f}{tangle}{where}")


def _write_overlay(directory: Path, path: Path, picture: np.ndarray,
                   candidates: list[GraspCandidate], hand: HandModel, view: View,
                   used: set[str]) -> None:
    name = f"{path.stem}_grasps.png"
    suffix = 2
    while name in used:
        name, suffix = f"{path.stem}_grasps_{suffix}.png", suffix + 1
    used.add(name)
    directory.mkdir(parents=True, exist_ok=True)
    target = directory / name
    if not cv2.imwrite(str(target), draw_candidates(picture, candidates, hand, view)):
        raise TangleDrakeError(f"cannot write the overlay {target}")
