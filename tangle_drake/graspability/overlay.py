"""Pictures of the candidates: the hand drawn where the index would put it.

Each candidate shows both finger footprints and the closing line between the fingers' inner
faces, projected at the tool centre's depth, with its rank and score; the best is green.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tangle_drake.graspability.candidates import GraspCandidate
from tangle_drake.graspability.hand import HandModel
from tangle_drake.graspability.workmap import View
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER

_COLOURS = ((0, 200, 0), (0, 200, 255), (0, 140, 255), (0, 60, 255), (200, 0, 200))
"""BGR by rank: green for the best, then yellow to red, magenta for the rest."""


def depth_preview(depth: np.ndarray) -> np.ndarray:
    """A BGR picture of a depth image: nearer is brighter (histogram-equalised, so parts on a
    floor stay visible next to tall bin walls), missing pixels are black."""
    finite = np.isfinite(depth) & (depth > 0)
    grey = np.zeros(depth.shape, np.uint8)
    if finite.any():
        near, far = float(depth[finite].min()), float(depth[finite].max())
        scaled = 255 * (far - depth[finite]) / max(far - near, 1e-9)
        grey[finite] = np.clip(scaled, 0, 255).astype(np.uint8)
        grey = cv2.equalizeHist(grey)
        grey[~finite] = 0
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


def emap_underlay(picture: np.ndarray, emap: np.ndarray) -> np.ndarray:
    """``picture`` (BGR) half covered by the entanglement map (0-1, the image's size) in
    colour, blue = calm to red = entangled, where the map is defined (non-zero)."""
    colour = cv2.applyColorMap(np.clip(255 * emap, 0, 255).astype(np.uint8), cv2.COLORMAP_JET)
    blended = cv2.addWeighted(picture, 0.5, colour, 0.5, 0.0)
    return np.where((emap > 0)[..., None], blended, picture)


def draw_candidates(picture: np.ndarray, candidates: list[GraspCandidate], hand: HandModel,
                    view: View) -> np.ndarray:
    """``picture`` (BGR, the image's size) with each candidate's hand drawn on a copy."""
    out = picture.copy()
    for rank in reversed(range(len(candidates))):  # the best drawn last, on top
        _draw_hand(out, candidates[rank], rank, hand, view)
    return out


def top_view(depth: np.ndarray, candidates: list[GraspCandidate],
             intrinsics: CameraIntrinsics) -> np.ndarray:
    """The top camera's metric ``depth`` as a picture with the robot's gripper drawn at each
    of ``candidates`` (the pick pictures and the benchmark's gallery)."""
    return draw_candidates(depth_preview(depth), candidates,
                           HandModel.from_gripper(DEFAULT_GRIPPER), View.of_camera(intrinsics))


def _draw_hand(out: np.ndarray, candidate: GraspCandidate, rank: int, hand: HandModel,
               view: View) -> None:
    colour = _COLOURS[min(rank, len(_COLOURS) - 1)]
    mx, my = view.metres_per_pixel(candidate.depth_m - hand.tcp_above_tips_m)
    a = math.radians(candidate.angle_deg)
    closing = np.array([math.cos(a), math.sin(a)])
    across = np.array([-math.sin(a), math.cos(a)])
    centre = np.array([candidate.u, candidate.v])

    def pixels(offsets_m: np.ndarray) -> np.ndarray:
        return centre + offsets_m / np.array([mx, my])

    half_t, half_w = hand.finger_thickness_m / 2, hand.finger_width_m / 2
    for side in (-1, 1):
        middle = side * (hand.opening_m / 2 + half_t) * closing
        corners = [middle + s * half_t * closing + t * half_w * across
                   for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        cv2.polylines(out, [_fixed(pixels(np.array(corners)))], True, colour, 1, cv2.LINE_AA, 4)
    inner = pixels(np.array([-hand.opening_m / 2 * closing, hand.opening_m / 2 * closing]))
    cv2.polylines(out, [_fixed(inner)], False, colour, 1, cv2.LINE_AA, 4)
    cv2.circle(out, _fixed(centre[None])[0], 2 << 4, colour, -1, cv2.LINE_AA, 4)
    label = f"{rank + 1}:{candidate.score:.2f}"
    anchor = (int(candidate.u) + 4, int(candidate.v) - 4)
    cv2.putText(out, label, anchor, cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(out, label, anchor, cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)


def _fixed(points: np.ndarray) -> np.ndarray:
    """Pixel coordinates in OpenCV's 4-bit fixed point (sub-pixel drawing)."""
    return np.rint(points * 16).astype(np.int32)
