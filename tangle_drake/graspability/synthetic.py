"""Synthetic piles of wire parts in a bin, rendered as depth images: test and benchmark data.

Scenes live on a fine metric height field in the camera's x-y plane (x right, y down, the
camera looking straight down at a floor ``floor_depth_m`` away). Parts are wire tubes along a
polyline; each rests, flat, on the highest point beneath it. Rendering marches every pixel's
ray down to the first surface, so the depth image has the perspective, the parallax and the
visible inner wall faces of a real top-down camera.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose


class HeightField:
    """Heights above the floor (m) on a square-celled grid centred on the optical axis."""

    def __init__(self, size_m: tuple[float, float], resolution_m: float = 0.0005) -> None:
        self.resolution_m = resolution_m
        nx, ny = (round(extent / resolution_m) | 1 for extent in size_m)
        self.heights = np.zeros((ny, nx), np.float32)

    def to_cell(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, ...]:
        """Fractional (column, row) of camera-frame points (x, y) on the field."""
        ny, nx = self.heights.shape
        return (np.asarray(x) / self.resolution_m + (nx - 1) / 2,
                np.asarray(y) / self.resolution_m + (ny - 1) / 2)

    def add_box(self, x0: float, y0: float, x1: float, y1: float, top_m: float) -> None:
        """Raise the rectangle ``[x0, x1] x [y0, y1]`` to at least ``top_m``."""
        (c0, c1), (r0, r1) = self.to_cell(np.array([x0, x1]), np.array([y0, y1]))
        rows = slice(max(0, math.ceil(r0)), max(0, math.floor(r1) + 1))
        cols = slice(max(0, math.ceil(c0)), max(0, math.floor(c1) + 1))
        np.maximum(self.heights[rows, cols], top_m, out=self.heights[rows, cols])

    def add_wire(self, points_m: np.ndarray, diameter_m: float) -> None:
        """A round wire along the polyline ``points_m`` (N, 2), resting on what lies below."""
        radius = diameter_m / 2 / self.resolution_m
        cols, rows = self.to_cell(points_m[:, 0], points_m[:, 1])
        margin = math.ceil(radius) + 2
        r0, c0 = max(0, math.floor(rows.min()) - margin), max(0, math.floor(cols.min()) - margin)
        r1 = min(self.heights.shape[0], math.ceil(rows.max()) + margin + 1)
        c1 = min(self.heights.shape[1], math.ceil(cols.max()) + margin + 1)
        if r1 <= r0 or c1 <= c0:
            return
        line = np.ones((r1 - r0, c1 - c0), np.uint8)
        shift = 4  # sub-cell precision of cv2.polylines
        pts = np.stack([cols - c0, rows - r0], axis=1) * (1 << shift)
        cv2.polylines(line, [np.rint(pts).astype(np.int32)], False, 0, 1, cv2.LINE_8, shift)
        distance = cv2.distanceTransform(line, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        inside = distance <= radius
        if not inside.any():
            return
        crop = self.heights[r0:r1, c0:c1]
        base = float(crop[inside].max())
        lift = (radius + np.sqrt(np.maximum(radius**2 - distance**2, 0))) * self.resolution_m
        profile = base + lift
        np.maximum(crop, np.where(inside, profile, 0).astype(np.float32), out=crop)

    def render(self, intrinsics: CameraIntrinsics, floor_depth_m: float) -> np.ndarray:
        """Depth image (float32 m) of a camera ``floor_depth_m`` above the floor, looking down."""
        k = intrinsics
        u, v = np.meshgrid(np.arange(k.width, dtype=np.float32),
                           np.arange(k.height, dtype=np.float32))
        a, b = (u - k.cx) / k.fx, (v - k.cy) / k.fy

        def below_surface(t: np.ndarray) -> np.ndarray:
            cols, rows = self.to_cell(a * t, b * t)
            h = cv2.remap(self.heights, cols.astype(np.float32), rows.astype(np.float32),
                          cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            return t >= floor_depth_m - h

        step = 2 * self.resolution_m
        top = floor_depth_m - float(self.heights.max())
        hit = np.full(a.shape, floor_depth_m, np.float32)
        found = np.zeros(a.shape, bool)
        for t in np.arange(top, floor_depth_m, step, dtype=np.float32):
            new = ~found & below_surface(np.full(a.shape, t, np.float32))
            hit[new], found[new] = t, True
        low, high = np.maximum(hit - step, top), hit.copy()
        for _ in range(8):  # bisect to well below a cell
            mid = (low + high) / 2
            inside = below_surface(mid)
            high, low = np.where(inside, mid, high), np.where(inside, low, mid)
        return np.where(found, high, floor_depth_m).astype(np.float32)


def wire_part(rng: np.random.Generator, centre: np.ndarray, length_m: float) -> np.ndarray:
    """A random wire shape's centreline (N, 2) in metres: a bar, an arc or a hook."""
    kind = rng.integers(3)
    s = np.linspace(-0.5, 0.5, 33) * length_m
    if kind == 0:
        local = np.stack([s, np.zeros_like(s)], axis=1)
    else:
        bend = rng.uniform(1.2, 4.0) if kind == 1 else rng.uniform(3.0, 5.0)
        radius = length_m / bend
        phi = s / radius
        local = np.stack([radius * np.sin(phi), radius * (1 - np.cos(phi))], axis=1)
        if kind == 2:  # hook: a straight shank, then a curl
            local[s < 0] = np.stack([s[s < 0], np.zeros(np.count_nonzero(s < 0))], axis=1)
        local -= local.mean(axis=0)
    angle = rng.uniform(0, 2 * np.pi)
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    return local @ rotation.T + centre


def pile_field(rng: np.random.Generator, intrinsics: CameraIntrinsics, n_parts: int = 25,
               floor_depth_m: float = 0.5, bin_inner_m: tuple[float, float] = (0.36, 0.26),
               wall: tuple[float, float] = (0.01, 0.08)) -> HeightField:
    """``n_parts`` wires (6-10 mm thick, 40-110 mm long) dropped into a bin (inner size, wall
    thickness and height in metres), on a field covering the camera's view of the floor."""
    half_x = floor_depth_m * (intrinsics.width / 2) / intrinsics.fx
    half_y = floor_depth_m * (intrinsics.height / 2) / intrinsics.fy
    field = HeightField((2 * half_x + 0.02, 2 * half_y + 0.02))
    thickness, height = wall
    ix, iy = bin_inner_m[0] / 2, bin_inner_m[1] / 2
    for x0, y0, x1, y1 in ((-ix - thickness, -iy - thickness, ix + thickness, -iy),
                           (-ix - thickness, iy, ix + thickness, iy + thickness),
                           (-ix - thickness, -iy, -ix, iy), (ix, -iy, ix + thickness, iy)):
        field.add_box(x0, y0, x1, y1, height)
    for _ in range(n_parts):
        length, diameter = rng.uniform(0.04, 0.11), rng.uniform(0.006, 0.010)
        while True:  # inside the bin: a part over a wall would rest on the wall's top
            points = wire_part(rng, rng.uniform([-ix, -iy], [ix, iy]), length)
            if np.all(np.abs(points) <= np.array([ix, iy]) - diameter / 2):
                break
        field.add_wire(points, diameter)
    return field


def synthetic_pile(rng: np.random.Generator, image_size: tuple[int, int] = (640, 480),
                   n_parts: int = 25, floor_depth_m: float = 0.5,
                   fov_y_deg: float = 45.0) -> tuple[np.ndarray, CameraModel]:
    """A depth image of a :func:`pile_field` and its camera, ``floor_depth_m`` above the bin
    floor's centre, looking down (``camera.top_view_pose``)."""
    intrinsics = CameraIntrinsics.from_fov_y(*image_size, fov_y_deg)
    field = pile_field(rng, intrinsics, n_parts, floor_depth_m)
    depth = field.render(intrinsics, floor_depth_m)
    return depth, CameraModel(intrinsics, top_view_pose(np.zeros(3), floor_depth_m))
