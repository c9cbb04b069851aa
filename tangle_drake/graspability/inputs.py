"""Checking and reading the index's inputs: metric depth images and height-map images.

Bad input is the user's to fix, so every problem here is a :class:`TangleDrakeError` that says
what was wrong; nothing downstream has to guard against odd arrays again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics

DEPTH_SUFFIXES = (".npy", ".tif", ".tiff")
HEIGHT_MAP_SUFFIXES = (".png",)


def _as_image_array(image: object, what: str) -> np.ndarray:
    """``image`` as a non-empty numeric (not bool) numpy array, or a clear error."""
    array = np.asarray(image)
    if array.dtype == bool or array.dtype.kind not in "iuf":
        raise TangleDrakeError(f"{what} must be a numeric image, got dtype {array.dtype}")
    if array.size == 0:
        raise TangleDrakeError(f"{what} is empty (shape {array.shape})")
    return array


def check_depth(depth: object, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Metric depth as float32 with +inf where the sensor saw nothing (NaN, inf or <= 0).

    +inf is never the highest point, so missing pixels drop out of every later minimum.
    """
    array = _as_image_array(depth, "depth image")
    if array.ndim != 2:
        raise TangleDrakeError(f"depth image must be 2-D (rows, columns), got shape {array.shape}")
    if array.dtype.kind != "f":
        raise TangleDrakeError(f"depth image must hold floating-point metres, got {array.dtype} "
                               "(convert integer millimetres to metres first)")
    if array.shape != (intrinsics.height, intrinsics.width):
        raise TangleDrakeError(f"depth image is {array.shape[1]}x{array.shape[0]} but the camera "
                               f"intrinsics are {intrinsics.width}x{intrinsics.height}")
    out = array.astype(np.float32)  # a copy: the caller's image is left alone
    with np.errstate(invalid="ignore"):
        out[~(out > 0)] = np.inf  # NaN and <= 0; +inf stays
    if np.isinf(out).all():
        raise TangleDrakeError("depth image has no valid pixel (all NaN, inf or 0)")
    return out


def height_map_to_depth(height_map: object, height_per_level_m: float) -> np.ndarray:
    """A height map (8/16-bit grey or colour, brighter = higher) as metric depth, float32.

    The depth is measured down from the height of the brightest possible grey level (255 or
    65535), as if an orthographic camera looked down from there; colour images use the mean of
    their colour channels.
    """
    array = _as_image_array(height_map, "height map")
    if array.dtype not in (np.uint8, np.uint16):
        raise TangleDrakeError(f"height map must be 8- or 16-bit unsigned, got {array.dtype}")
    if array.ndim == 3 and array.shape[2] in (3, 4) and is_grey(array):
        levels = array[..., 0].astype(np.float64)
    elif array.ndim == 2:
        levels = array.astype(np.float64)
    elif array.ndim == 3 and array.shape[2] in (3, 4):
        raise TangleDrakeError("this is a colour image, not a height map (a height map is "
                               "one grey level per pixel, brighter = higher)")
    else:
        raise TangleDrakeError(f"height map must be grey (rows, columns), got shape "
                               f"{array.shape}")
    check_scale(height_per_level_m, "height per grey level")
    top = np.iinfo(array.dtype).max
    return ((top - levels) * height_per_level_m).astype(np.float32)


def is_grey(array: np.ndarray) -> bool:
    """A 3/4-channel image whose colour channels are all equal (a grey PNG saved as RGB)."""
    return bool((array[..., 0] == array[..., 1]).all() and (array[..., 1] == array[..., 2]).all())


DEEP_HEIGHT_MAP_M = 0.5
"""A height map whose levels span more than this is suspicious: deeper than any bin."""


def height_span(height_map: np.ndarray, height_per_level_m: float) -> float:
    """The height between the map's lowest and highest pixels, m (for a warning)."""
    levels = height_map if height_map.ndim == 2 else height_map[..., 0]
    return float((int(levels.max()) - int(levels.min())) * height_per_level_m)


NEAR_CAMERA_M = 0.05
FAR_CAMERA_M = 10.0
"""Bin-picking cameras see their bins from between these depths (m). Grasps farther away come
from a wrong unit or scale, and an image that reads as depth outside them is no depth image."""

PIXEL_SIZE_TOLERANCE = 0.25
"""A pixel size more than this fraction off the camera's contradicts the camera."""


def pixel_size_at(intrinsics: CameraIntrinsics, depth_m: float) -> float | None:
    """The side of one of the camera's pixels at ``depth_m`` (the geometric mean of its width
    and height), m; ``None`` for intrinsics that have no pixel size (a focal length <= 0)."""
    focal = intrinsics.fx * intrinsics.fy
    if not (intrinsics.fx > 0 and intrinsics.fy > 0 and math.isfinite(focal)):
        return None
    return depth_m / math.sqrt(focal)


def millimetre_depth_scale(levels: np.ndarray,
                           intrinsics: CameraIntrinsics) -> tuple[float, float] | None:
    """``(the bin's depth, a pixel's size there)`` in metres, reading a 16-bit grey image as the
    camera's depth in millimetres (0 = missing; as ``tangle-drake scene`` and most depth-camera
    drivers write it), or ``None`` where it cannot be that: not 16-bit grey, not the camera's
    size, or no valid pixel at a depth a bin-picking camera works at.

    The bin's depth is its far end (the 99th percentile of the valid depths: the floor). A
    height-map reading of such an image must agree with the camera on the pixel size there.
    """
    if (levels.dtype != np.uint16 or levels.ndim != 2
            or levels.shape != (intrinsics.height, intrinsics.width)):
        return None
    valid = levels[levels > 0]
    if valid.size == 0:
        return None
    depth_m = float(np.percentile(valid, 99)) / 1000.0
    size = pixel_size_at(intrinsics, depth_m)
    if size is None or not NEAR_CAMERA_M <= depth_m <= FAR_CAMERA_M:
        return None
    return depth_m, size


def sizes_disagree(given_m: float, expected_m: float,
                   tolerance: float = PIXEL_SIZE_TOLERANCE) -> bool:
    """Whether two pixel sizes differ by more than ``tolerance`` (of the smaller one)."""
    return max(given_m, expected_m) > (1 + tolerance) * min(given_m, expected_m)


def millimetres_to_depth(millimetres: np.ndarray) -> np.ndarray:
    """A 16-bit depth image in millimetres (0: nothing seen, as ``tangle-drake scene``'s
    ``depth.png`` and most depth-camera drivers write it) as metric depth, float32."""
    depth = millimetres.astype(np.float32) / 1000.0
    depth[millimetres == 0] = np.nan
    return depth


def check_scale(value: float, what: str) -> float:
    """A positive, finite scale in metres, or a clear error."""
    if (isinstance(value, bool) or not isinstance(value, (int, float, np.floating))
            or not (np.isfinite(value) and value > 0)):
        raise TangleDrakeError(f"{what} must be a positive number of metres, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ImageFile:
    """An image read from disk: metric depth (``is_depth``) or a raw height map."""

    path: Path
    array: np.ndarray
    is_depth: bool


def read_image_file(path: str | Path) -> ImageFile:
    """Read a metric depth (``.npy``, float ``.tif``) or a height map (8/16-bit ``.png``)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in DEPTH_SUFFIXES + HEIGHT_MAP_SUFFIXES:
        raise TangleDrakeError(f"{path}: unsupported image type {suffix!r}; use .npy or float "
                               ".tif/.tiff for metric depth, .png for a height map")
    if not path.is_file():
        raise TangleDrakeError(f"{path}: no such file")
    if suffix == ".npy":
        try:
            array = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as error:
            # numpy's message for a file that is no .npy advises unpickling it: never.
            raise TangleDrakeError(f"{path}: not a readable .npy array (no .npy header, "
                                   "truncated, or holding Python objects)") from error
    else:
        array = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if array is None:
            raise TangleDrakeError(f"{path}: cannot decode the image (corrupt or not a "
                                   f"{suffix[1:].upper()})")
    if suffix in (".tif", ".tiff") and array.dtype.kind != "f":
        raise TangleDrakeError(f"{path}: a .tif depth image must hold float metres, got "
                               f"{array.dtype}")
    if suffix == ".png" and array.dtype not in (np.uint8, np.uint16):
        raise TangleDrakeError(f"{path}: a height-map PNG must be 8- or 16-bit, got "
                               f"{array.dtype}")
    return ImageFile(path, array, is_depth=suffix in DEPTH_SUFFIXES)
