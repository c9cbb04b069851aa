"""Which parts lie in the gripper's closing region: from the parts' geometry, not the image.

The closing region is the box between the open fingers, in the grasp (tool) frame T of
:mod:`tangle_drake.robot_model.gripper`: ``opening`` long along the closing direction (y), one
finger ``width`` across it (x), and from the fingertips (``+pad_length/2`` along the approach, z)
up to the palm. A part is in it when a point of its surface lies inside the box shrunk by
``margin`` on every side but the top.

Why geometry and not the label image: the camera sees only the top surface, so a part lying
under the target, between the fingers and above the fingertips, is invisible in the label
image, yet the closing fingers would squeeze it too. The parts' surfaces are sampled once
(a seeded sample of the visual mesh plus its vertices) and posed from the plant's state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import PartModel
from tangle_drake.robot_model.gripper import GripperSpec

SURFACE_SAMPLES = 3000
"""Random surface points per part, on top of the mesh's vertices (spacing ~1-2 mm)."""


@dataclass(frozen=True)
class RegionBox:
    """The closing region as lower and upper corners in the tool frame T (metres)."""

    lower: np.ndarray
    upper: np.ndarray

    @staticmethod
    def of_gripper(gripper: GripperSpec, margin: float) -> RegionBox:
        half_x = gripper.finger_width / 2 - margin
        half_y = gripper.max_opening / 2 - margin
        tips = gripper.pad_length / 2  # fingertips, below T along the approach (+z)
        top = tips - gripper.finger_length  # the palm's face
        if half_x <= 0 or half_y <= 0:
            raise TangleDrakeError(f"region margin {margin} m leaves no closing region for "
                                   "this gripper")
        return RegionBox(np.array([-half_x, -half_y, top]),
                         np.array([half_x, half_y, tips - margin]))


def surface_points(part: PartModel, seed: int = 0) -> np.ndarray:
    """(M, 3) points on the part's visual surface in its body frame, the same every call."""
    try:
        mesh = trimesh.load(part.visual_mesh_path, force="mesh", process=False)
    except (OSError, ValueError) as error:
        raise TangleDrakeError(f"cannot read the part's mesh {part.visual_mesh_path}: "
                               f"{error}") from error
    sampled, _ = trimesh.sample.sample_surface(mesh, SURFACE_SAMPLES, seed=seed)
    return np.vstack([np.asarray(mesh.vertices, float), np.asarray(sampled, float)])


def parts_in_region(X_WT: np.ndarray, poses: np.ndarray, points_B: np.ndarray,
                    box: RegionBox) -> list[int]:
    """Indices of the parts whose surface enters the region of a grasp at ``X_WT`` (4x4).

    ``poses``: (N, 4, 4) world poses of the N parts; ``points_B``: their shared surface
    points in the body frame (all parts of a pile are the same part type).
    """
    X_TW = np.linalg.inv(X_WT)
    # p_T = R_TW (R_WB p_B + p_WB) + p_TW, for all parts at once.
    R_TB = np.einsum("ij,njk->nik", X_TW[:3, :3], poses[:, :3, :3])
    p_TB = poses[:, :3, 3] @ X_TW[:3, :3].T + X_TW[:3, 3]
    inside = []
    for n in range(len(poses)):
        p_T = points_B @ R_TB[n].T + p_TB[n]
        if np.any(np.all((p_T >= box.lower) & (p_T <= box.upper), axis=1)):
            inside.append(n)
    return inside
