"""Ranked parallel-jaw grasp candidates from one depth image or height map (numpy/OpenCV only).

Candidate conventions:
  - ``u``, ``v``: the image pixel where the tool centre T projects (u right, v down);
  - ``angle_deg``: the closing direction, from the image's +u axis towards +v, in [0, 180)
    (measured in the camera's x-y plane: the image's own angle for square pixels);
  - ``width_m``: the opening the hand needs, the distance between the open fingers;
  - ``depth_m``: camera-frame depth (along +z) of the fingertips at the grasp; for a height
    map, the depth below the height of its brightest possible grey level;
  - ``score``: in [0, 1], see :mod:`.ranking`;
  - ``pose``: ``X_WT``, the tool frame T of :mod:`tangle_drake.robot_model.gripper` in the world,
    a 4x4 matrix: origin at T (between the finger pads, half a pad above the fingertips), +z along
    the approach (the camera's +z), +y along the closing direction. ``None`` where no camera
    pose is known (height maps, or bare intrinsics);
  - ``height_m``: height maps only, the fingertips' height above grey level 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.graspability.hand import HandModel, as_hand
from tangle_drake.graspability.index import GraspMaps, grasp_maps
from tangle_drake.graspability.inputs import check_depth, check_scale, height_map_to_depth
from tangle_drake.graspability.params import GraspabilityParams
from tangle_drake.graspability.ranking import Peak, best_grasps
from tangle_drake.graspability.roi import Rect, roi_mask
from tangle_drake.graspability.workmap import View, WorkMap, build_work_map
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec

MapsFunction = Callable[[WorkMap, HandModel, GraspabilityParams], GraspMaps]


@dataclass(frozen=True, eq=False)
class GraspCandidate:
    """One ranked grasp (conventions in the module docstring)."""

    u: float
    v: float
    angle_deg: float
    width_m: float
    depth_m: float
    score: float
    pose: np.ndarray | None = None
    height_m: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready fields; ``pose`` and ``height_m`` only where known."""
        out = {"u": round(self.u, 2), "v": round(self.v, 2),
               "angle_deg": round(self.angle_deg, 4), "width_m": round(self.width_m, 6),
               "depth_m": round(self.depth_m, 6), "score": round(self.score, 4)}
        if self.pose is not None:
            out["pose"] = np.round(self.pose, 6).tolist()
        if self.height_m is not None:
            out["height_m"] = round(self.height_m, 6)
        return out


def compute_candidates(depth: np.ndarray, camera: CameraModel | CameraIntrinsics,
                       hand: HandModel | GripperSpec = DEFAULT_GRIPPER,
                       params: GraspabilityParams | None = None,
                       roi: np.ndarray | Rect | None = None) -> list[GraspCandidate]:
    """Grasp candidates, best first, from a metric depth image (float metres along the
    camera's +z; NaN, inf or 0 = missing).

    ``roi``: the allowed pixels, a mask or a rectangle (see :func:`.roi.roi_mask`), shrunk by
    ``params.roi_margin_px``; the whole hand (closing region and finger footprints) must lie
    inside. A flat, empty bin gives an empty list.
    """
    if isinstance(camera, CameraModel):
        intrinsics, X_WC = camera.intrinsics, np.asarray(camera.X_WC, float)
    else:
        intrinsics, X_WC = camera, None
    checked = check_depth(depth, intrinsics)
    return candidates_from_depth(checked, View.of_camera(intrinsics), hand, params, roi, X_WC)


def compute_candidates_from_height_map(height_map: np.ndarray, height_per_level_m: float,
                                       pixel_size_m: float,
                                       hand: HandModel | GripperSpec = DEFAULT_GRIPPER,
                                       params: GraspabilityParams | None = None,
                                       roi: np.ndarray | Rect | None = None,
                                       ) -> list[GraspCandidate]:
    """Grasp candidates from a height map seen from straight above (8/16-bit, brighter =
    higher), given the height of one grey level and the size of one pixel in metres."""
    depth = height_map_to_depth(height_map, height_per_level_m)
    view = View.of_height_map(depth.shape, check_scale(pixel_size_m, "pixel size"))
    top_m = np.iinfo(np.asarray(height_map).dtype).max * height_per_level_m
    return [replace(candidate, height_m=top_m - candidate.depth_m)
            for candidate in candidates_from_depth(depth, view, hand, params, roi, X_WC=None)]


def candidates_from_depth(depth: np.ndarray, view: View, hand: HandModel | GripperSpec,
                          params: GraspabilityParams | None, roi: np.ndarray | Rect | None,
                          X_WC: np.ndarray | None,
                          maps_function: MapsFunction = grasp_maps) -> list[GraspCandidate]:
    """The pipeline on a checked depth (float32, +inf = missing) seen through ``view``."""
    hand = as_hand(hand)
    params = params or GraspabilityParams()
    work = build_work_map(depth, view, params.cell_size_m)
    try:
        hand.in_cells(work.cell_m)
    except ValueError:
        far = float(np.max(depth[np.isfinite(depth)]))
        raise TangleDrakeError(
            f"the image's pixels are {work.cell_m:.3g} m wide at its farthest depth "
            f"({far:.3g} m), coarser than the fingers ({hand.finger_thickness_m:.3g} m): is "
            "the depth in metres, and the camera model the image's?") from None
    allowed = roi_mask(roi, view.width, view.height, params.roi_margin_px)
    if allowed is not None:
        work = replace(work, allowed=work.pixel_mask_to_cells(allowed))
    maps = maps_function(work, hand, params)
    peaks = best_grasps(maps.encoded, work.cell_m, params)
    return [_candidate(peak, work, maps, hand, X_WC) for peak in peaks]


def _candidate(peak: Peak, work: WorkMap, maps: GraspMaps, hand: HandModel,
               X_WC: np.ndarray | None) -> GraspCandidate:
    x, y = work.cell_xy(peak.row, peak.col)
    level = int(maps.encoded[peak.orientation, peak.row, peak.col])
    tips = maps.levels.tip_depth(level)
    z = tips - hand.tcp_above_tips_m
    u, v = work.view.to_pixel(x, y, z)
    angle = float(maps.angles_deg[peak.orientation])
    pose = None if X_WC is None else X_WC @ tool_pose_in_camera(x, y, z, angle)
    return GraspCandidate(float(u), float(v), angle, hand.opening_m, tips, peak.score, pose)


def tool_pose_in_camera(x: float, y: float, z: float, angle_deg: float) -> np.ndarray:
    """``X_CT``: T at (x, y, z), +z along the camera's +z, +y along the closing direction."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return np.array([[s, c, 0.0, x], [-c, s, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]])
