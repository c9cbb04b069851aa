"""Pinhole camera conventions shared by the simulator, graspability and the CNN (numpy only).

Frames follow Drake's ``RgbdSensor``: the camera frame C has +x to the image's right, +y down
the image and +z along the optical axis. Depth images hold the distance along +z in metres
(Drake's 32-bit depth); NaN or 0 marks a missing pixel.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels (principal point in pixel coordinates, u right, v down)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @staticmethod
    def from_fov_y(width: int, height: int, fov_y_deg: float) -> CameraIntrinsics:
        """Square pixels with the principal point at the image centre (Drake's default)."""
        f = height / 2 / np.tan(np.radians(fov_y_deg) / 2)
        return CameraIntrinsics(width, height, f, f, width / 2 - 0.5, height / 2 - 0.5)


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics plus the camera's pose in the world, ``X_WC`` as a 4x4 homogeneous matrix."""

    intrinsics: CameraIntrinsics
    X_WC: np.ndarray = field(default_factory=lambda: np.eye(4))

    def pixel_to_camera(self, u: np.ndarray | float, v: np.ndarray | float,
                        depth: np.ndarray | float) -> np.ndarray:
        """Back-project pixel(s) at ``depth`` (m along +z) to camera-frame points, (..., 3)."""
        k = self.intrinsics
        u, v, depth = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float),
                                          np.asarray(depth, float))
        return np.stack([(u - k.cx) * depth / k.fx, (v - k.cy) * depth / k.fy, depth], axis=-1)

    def pixel_to_world(self, u: np.ndarray | float, v: np.ndarray | float,
                       depth: np.ndarray | float) -> np.ndarray:
        """Back-project pixel(s) at ``depth`` to points in the world frame, (..., 3)."""
        p_C = self.pixel_to_camera(u, v, depth)
        return p_C @ self.X_WC[:3, :3].T + self.X_WC[:3, 3]

    def world_to_pixel(self, p_W: np.ndarray) -> np.ndarray:
        """Project world point(s) (..., 3) to (u, v, depth) (..., 3)."""
        p_W = np.asarray(p_W, float)
        R, t = self.X_WC[:3, :3], self.X_WC[:3, 3]
        p_C = (p_W - t) @ R
        k = self.intrinsics
        z = p_C[..., 2]
        return np.stack([k.fx * p_C[..., 0] / z + k.cx, k.fy * p_C[..., 1] / z + k.cy, z], axis=-1)


def top_view_pose(target: np.ndarray, height: float) -> np.ndarray:
    """X_WC of a camera ``height`` m above ``target`` looking straight down.

    The image's right (+x_C) is the world's -y and the image's down (+y_C) is the world's -x,
    so a robot standing at -x, facing +x, appears at the bottom of the image.
    """
    X_WC = np.eye(4)
    X_WC[:3, :3] = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    X_WC[:3, 3] = np.asarray(target, float) + np.array([0.0, 0.0, height])
    return X_WC


def save_camera_json(path, model: CameraModel) -> None:
    """Write ``model`` as the JSON sidecar that ``tangle-drake scene`` puts next to its images."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    data = {"intrinsics": asdict(model.intrinsics), "X_WC": np.asarray(model.X_WC).tolist()}
    Path(path).write_text(json.dumps(data, indent=2))


def load_camera_json(path) -> CameraModel:
    """Read a camera sidecar written by :func:`save_camera_json`, with a clear error if broken."""
    import json
    from pathlib import Path

    from tangle_drake.common.errors import TangleDrakeError

    try:
        data = json.loads(Path(path).read_text())
        intrinsics = CameraIntrinsics(**data["intrinsics"])
        X_WC = np.asarray(data.get("X_WC", np.eye(4).tolist()), float)
    except FileNotFoundError as error:
        raise TangleDrakeError(f"camera file not found: {path}") from error
    except (ValueError, KeyError, TypeError) as error:
        raise TangleDrakeError(f"camera file {path} is not a valid camera description: "
                               f"{error}") from error
    if X_WC.shape != (4, 4) or not np.all(np.isfinite(X_WC)):
        raise TangleDrakeError(f"camera file {path}: X_WC must be a finite 4x4 matrix")
    return CameraModel(intrinsics, X_WC)
