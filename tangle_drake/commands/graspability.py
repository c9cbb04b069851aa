"""``tangle-drake graspability``: ranked grasp candidates for depth images and height maps.

One call takes many images; a bad image is reported by name and skipped, the summary lists
the failed ones, and the exit status is 1 if any failed. Metric depth (``.npy``, float
``.tif``) needs the camera (``--camera``, else a ``camera.json`` next to the image); a
height-map ``.png`` needs its two scales. Scales that contradict the image's camera, and grasps
farther than any camera works, are warned about (stderr, and ``warnings`` in the JSON).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.entanglement.emap import entanglement_map
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
    FAR_CAMERA_M,
    ImageFile,
    check_scale,
    height_map_to_depth,
    height_span,
    is_grey,
    millimetre_depth_scale,
    millimetres_to_depth,
    pixel_size_at,
    read_image_file,
    sizes_disagree,
)
from tangle_drake.graspability.overlay import depth_preview, draw_candidates, emap_underlay
from tangle_drake.graspability.workmap import View
from tangle_drake.perception.camera import CameraModel, load_camera_json
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER


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
                        help="size of one pixel of a height-map PNG, metres (default for a "
                             "16-bit PNG with its camera: the camera's pixel at the bin's "
                             "depth, reading the PNG as depth in millimetres)")
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
        warnings: list[str] = []
        try:
            entry, picture, view = _process(path, args, hand, params, roi, cameras, warnings)
            if args.overlay is not None:
                _write_overlay(args.overlay, path, picture, entry["candidates"], hand, view,
                               overlay_names)
        except TangleDrakeError as error:
            message = _naming(path, str(error))
            warnings = _print_warnings(path, warnings)
            print(f"error: {message}", file=sys.stderr)
            results.append({"image": str(path), "error": message}
                           | ({"warnings": warnings} if warnings else {}))
            continue
        warnings = _print_warnings(path, warnings)
        _print_summary(path, entry)
        entanglement = entry.pop("entanglement", [None] * len(entry["candidates"]))
        entry["candidates"] = [candidate.to_dict() | ({} if e is None else {"entanglement": e})
                               for candidate, e in zip(entry["candidates"], entanglement,
                                                       strict=True)]
        if warnings:
            entry["warnings"] = warnings
        results.append(entry)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=2))
    failed = [entry["image"] for entry in results if "error" in entry]
    if failed:
        print(f"{len(failed)} of {len(results)} images failed: {', '.join(failed)}",
              file=sys.stderr)
    return 1 if failed else 0


def _naming(path: Path, message: str) -> str:
    """``message`` led by the image's path as the user gave it (unless it already is): in a
    batch, an error or warning that names no image leaves the user guessing which one."""
    return message if message.startswith(f"{path}:") else f"{path}: {message}"


def _print_warnings(path: Path, warnings: list[str]) -> list[str]:
    """Print an image's warnings to stderr, each naming the image; returns them so named."""
    named = [_naming(path, warning) for warning in warnings]
    for warning in named:
        print(f"warning: {warning}", file=sys.stderr)
    return named


def _process(path: Path, args: argparse.Namespace, hand: HandModel,
             params: GraspabilityParams, roi: tuple[int, int, int, int] | None,
             cameras: dict[Path, CameraModel],
             warnings: list[str]) -> tuple[dict, np.ndarray, View]:
    """Candidates for one image: the JSON entry (candidates still objects), a picture of the
    image for the overlay, and the view to draw in. What looks wrong but still runs (scales
    that contradict the camera, grasps no camera could see) goes to ``warnings``."""
    image = read_image_file(path)
    millimetres = _depth_png(image, path, args)  # 16-bit mm with its camera: `scene`'s depth.png
    if image.is_depth or millimetres:
        source, camera = _camera_for(path, args.camera, cameras)
        _check_camera_size(image.array, path, source, camera, millimetres)
        if millimetres and args.pixel_size is not None:
            warnings.append(_unused_pixel_size(image.array, args.pixel_size, source, camera))
        depth = millimetres_to_depth(image.array) if millimetres else image.array
        start = time.perf_counter()
        candidates = compute_candidates(depth, camera, hand, params, roi)
        elapsed = time.perf_counter() - start
        picture, view = depth_preview(depth), View.of_camera(camera.intrinsics)
        far = max((c.depth_m for c in candidates), default=0.0)
        if far > FAR_CAMERA_M:
            warnings.append(f"grasps {far:.1f} m from the camera, farther than any bin-picking "
                            f"camera works (up to {FAR_CAMERA_M:g} m): is the depth in metres, "
                            f"and {source} the camera that took it?")
    else:
        if image.array.ndim == 3 and not is_grey(image.array):
            raise TangleDrakeError(f"{path}: this is a colour image, not a height map (a "
                                   "height map is one grey level per pixel, brighter = higher)")
        if args.height_per_level is None:
            raise TangleDrakeError(_needs_scales(image, path, args))
        check_scale(args.height_per_level, "--height-per-level")
        if args.pixel_size is not None:  # before it is compared with the camera's
            check_scale(args.pixel_size, "--pixel-size")
        pixel_size = _height_map_pixel_size(image, path, args, cameras, warnings)
        span = height_span(image.array, args.height_per_level)
        if span > DEEP_HEIGHT_MAP_M:
            warnings.append(f"its grey levels span {span:.2f} m of height at "
                            f"--height-per-level {args.height_per_level:g}, deeper than any "
                            "bin: is that the height of one grey level, in metres?")
        start = time.perf_counter()
        candidates = compute_candidates_from_height_map(
            image.array, args.height_per_level, pixel_size, hand, params, roi)
        elapsed = time.perf_counter() - start
        depth = height_map_to_depth(image.array, args.height_per_level)
        picture = depth_preview(depth)
        view = View.of_height_map(image.array.shape[:2], pixel_size)
        far = max((c.depth_m for c in candidates), default=0.0)
        if far > FAR_CAMERA_M:
            warnings.append(_deep_height_map(image.array, args.height_per_level, far))
    entry = {"image": str(path), "compute_ms": round(elapsed * 1e3, 3),
             "candidates": candidates}
    if args.emap:
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


def _needs_scales(image: ImageFile, path: Path, args: argparse.Namespace) -> str:
    """The refusal of a height map without its scales, naming the one(s) missing; a 16-bit
    one may be depth in millimetres whose camera is missing, so say how that one is read."""
    missing = " and ".join(name for name, value in (("--height-per-level", args.height_per_level),
                                                    ("--pixel-size", args.pixel_size))
                           if value is None)
    message = f"{path}: a height-map PNG needs {missing} (metres)"
    if _may_be_millimetres(image):
        message += ("; for depth in millimetres instead, give its camera (--camera JSON, or a "
                    "camera.json next to the image)")
    return message


def _may_be_millimetres(image: ImageFile) -> bool:
    """Whether a PNG could hold depth in millimetres (16-bit grey)."""
    return image.array.dtype == np.uint16 and image.array.ndim == 2


def _camera_for(path: Path, given: Path | None, cameras: dict[Path, CameraModel],
                required: bool = True) -> tuple[Path, CameraModel] | None:
    """The camera of an image and the file it came from: ``--camera``, else ``camera.json``
    beside it; ``None`` where there is none and none is ``required``."""
    source = given if given is not None else path.parent / "camera.json"
    if given is None and not source.is_file():
        if not required:
            return None
        raise TangleDrakeError(f"{path}: metric depth needs the camera intrinsics; pass "
                               "--camera camera.json or put a camera.json next to the image")
    if source not in cameras:
        camera = load_camera_json(source)
        k = camera.intrinsics
        try:
            usable = k.width > 0 and k.height > 0 and pixel_size_at(k, 1.0) is not None
        except TypeError:
            usable = False
        if not usable:  # a focal length of 0 would divide by zero further down
            raise TangleDrakeError(f"camera file {source}: its intrinsics need a positive "
                                   f"width, height, fx and fy, got {k}")
        cameras[source] = camera
    return source, cameras[source]


def _check_camera_size(array: np.ndarray, path: Path, source: Path, camera: CameraModel,
                       millimetres: bool) -> None:
    """Refuse an image whose size is not its camera's, naming both files (the camera file is
    often a shared one, or the one beside the image, and may belong to other images)."""
    k = camera.intrinsics
    if array.ndim < 2 or array.shape[:2] == (k.height, k.width):
        return  # not an image at all: check_depth says so
    hint = ("; a 16-bit PNG with a camera is read as depth in millimetres, a height map needs "
            "--height-per-level and --pixel-size") if millimetres else ""
    raise TangleDrakeError(f"{path}: the image is {array.shape[1]}x{array.shape[0]} pixels but "
                           f"the camera intrinsics in {source} are {k.width}x{k.height}: is "
                           f"that this image's camera?{hint}")


def _unused_pixel_size(levels: np.ndarray, pixel_size: float, source: Path,
                       camera: CameraModel) -> str:
    """The warning that --pixel-size is not used for a depth PNG read with its camera."""
    scale = millimetre_depth_scale(levels, camera.intrinsics)
    actual = "" if scale is None else (f" (a pixel of it is {scale[1]:.4g} m at the bin's "
                                       f"depth, {scale[0]:.3g} m)")
    return (f"--pixel-size {pixel_size:g} is not used: with its camera {source} the image is "
            f"read as depth in millimetres{actual}; to read it as a height map, give "
            "--height-per-level too")


def _height_map_pixel_size(image: ImageFile, path: Path, args: argparse.Namespace,
                           cameras: dict[Path, CameraModel], warnings: list[str]) -> float:
    """A height map's pixel size: --pixel-size, checked against the image's camera (--camera,
    or camera.json beside it) where that camera can tell, else the camera's own value.

    Only a 16-bit image of the camera's size that reads as a plausible depth in millimetres
    tells: a pixel size that contradicts it scales every grasp wrongly without a sign.
    """
    found = None
    try:
        if args.camera is not None or _may_be_millimetres(image):
            found = _camera_for(path, args.camera, cameras, required=False)
    except TangleDrakeError as error:
        if args.camera is not None:
            raise
        warnings.append(f"not checked against the camera beside it: {error}")
    consistent = None
    if found is not None:
        source, k = found[0], found[1].intrinsics
        consistent = millimetre_depth_scale(image.array, k)
        if args.camera is not None and image.array.shape[:2] != (k.height, k.width):
            warnings.append(f"--camera {source} is {k.width}x{k.height}, the image "
                            f"{image.array.shape[1]}x{image.array.shape[0]}: not its camera, "
                            "so not checked against it")
    if consistent is None:  # no camera, or none this image can be checked against
        if args.pixel_size is None:
            raise TangleDrakeError(_needs_scales(image, path, args))
        return args.pixel_size
    depth_m, size = consistent
    depth_reading = (f"the image is {source}'s size ({k.width}x{k.height}) and, read as that "
                     f"camera's depth in millimetres, shows the bin {depth_m:.3g} m away, "
                     f"where a pixel is {size:.4g} m")
    if args.pixel_size is None:
        warnings.append(f"no --pixel-size: using {size:.4g} m, from {source}: {depth_reading}")
        return size
    if sizes_disagree(args.pixel_size, size):
        warnings.append(f"--pixel-size {args.pixel_size:g} contradicts its camera: "
                        f"{depth_reading}. If it is that camera's depth image, drop "
                        "--height-per-level and --pixel-size (depth is darker = nearer, the "
                        "other way up from a height map); if it is a height map of that view, "
                        f"--pixel-size {size:.4g} is consistent")
    return args.pixel_size


def _deep_height_map(levels: np.ndarray, height_per_level: float, far: float) -> str:
    """The warning for a height map whose grasps come out tens of metres deep: its scale is
    then (nearly always) wrong, or it is depth in millimetres read as heights."""
    top_level = int(np.iinfo(levels.dtype).max)
    return (f"grasps {far:.1f} m deep: a height map's depth is measured down from its "
            f"brightest possible grey level, {top_level} x {height_per_level:g} m = "
            f"{top_level * height_per_level:.1f} m up, and no camera sees a bin from tens of "
            f"metres. Is {height_per_level:g} m the height of one grey level? Depth in "
            "millimetres is read as such with its camera (a camera.json beside it or --camera, "
            "and no --height-per-level or --pixel-size)")


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
