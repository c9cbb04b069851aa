"""What Meshcat shows of a pick: the camera framed on the work, and each pick's candidates.

Meshcat opens on a distant side view in which the robot is a small figure and the bin's
contents cannot be seen. :func:`work_view` puts the camera above and beyond the bin's far
corner, looking at a point between the bin and the arm's base, so the live view and a
``--record`` replay open on the work. :func:`frame_share` says how much of a frame of
Meshcat's default camera (three.js, 75 degrees vertical field of view) the bin fills.
:class:`CandidateMarkers` draws the candidates of the pick in progress.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pydrake.geometry import Box, Meshcat, Rgba
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context

from tangle_drake.drivers.registry import carrier
from tangle_drake.pick.diagram import PickDiagram
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import BinConfig, Scenario
from tangle_drake.scenario.drivers import NextageDriver

FOV_Y_DEG = 75.0
"""Meshcat's default perspective camera's vertical field of view."""
DISTANCE_M = 0.9
"""From the view's target to the camera, m (an arm in the scene: it must be in view too)."""
GANTRY_DISTANCE_M = 0.6
"""The same, for a gantry's bin alone."""
ELEVATION_DEG = 40.0
"""How far above the horizontal the camera looks down, deg."""
SIDE_DEG = 30.0
"""How far round from straight beyond the bin (seen from the arm) the camera stands, deg."""


def work_view(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, target) in the world for ``scenario``: the arm's base (the world
    origin, for a Nextage) and the bin both in view; a gantry's bin seen from its corner."""
    bin_ = scenario.bin
    middle = np.array([*bin_.center, bin_.floor_height + 0.5 * bin_.wall_height])
    _, config = carrier(scenario.model_drivers)
    if isinstance(config, NextageDriver):
        robot = np.array([0.0, 0.0, middle[2] + 0.15])  # the torso, above the bin's floor
        target = 0.6 * middle + 0.4 * robot
        away, distance = middle[:2] - robot[:2], DISTANCE_M
    else:
        target, away, distance = middle, np.array([1.0, 1.0]), GANTRY_DISTANCE_M
    away = away / (np.linalg.norm(away) or 1.0)
    side = np.array([-away[1], away[0]])
    horizontal = (math.cos(math.radians(SIDE_DEG)) * away + math.sin(math.radians(SIDE_DEG)) * side)
    elevation = math.radians(ELEVATION_DEG)
    offset = np.array([*(math.cos(elevation) * horizontal), math.sin(elevation)]) * distance
    return target + offset, target


def frame_coordinates(camera: np.ndarray, target: np.ndarray, points: np.ndarray,
                      aspect: float = 1.5) -> np.ndarray:
    """Where ``points`` ((N, 3), world) appear in the frame of a z-up look-at camera at
    ``camera`` aimed at ``target``: (N, 2), -1 to 1 across the frame's width and height (up
    is +), NaN for a point behind the camera."""
    forward = (target - camera) / np.linalg.norm(target - camera)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half_y = math.tan(math.radians(FOV_Y_DEG) / 2)
    rel = np.asarray(points, dtype=np.float64) - camera
    depth = rel @ forward
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = np.stack([rel @ right / depth / (aspect * half_y), rel @ up / depth / half_y], 1)
    xy[depth <= 0] = np.nan
    return xy


def bin_corners(bin_: BinConfig) -> np.ndarray:
    """The bin's eight outer corners (floor and rim), (8, 3)."""
    cx, cy = bin_.center
    sx, sy = (s / 2 + bin_.wall_thickness for s in bin_.inner_size)
    return np.array([[cx + i * sx, cy + j * sy, bin_.floor_height + k * bin_.wall_height]
                     for i in (-1, 1) for j in (-1, 1) for k in (0, 1)])


def frame_share(camera: np.ndarray, target: np.ndarray, bin_: BinConfig,
                aspect: float = 1.5) -> float:
    """The share of the frame (0-1) that the box around the bin's corners covers (0 if a
    corner is behind the camera)."""
    xy = frame_coordinates(camera, target, bin_corners(bin_), aspect)
    if np.isnan(xy).any():
        return 0.0
    xy = np.clip(xy, -1, 1)
    return float(np.ptp(xy[:, 0]) * np.ptp(xy[:, 1]) / 4)


def frame_the_work(meshcat: Meshcat, scenario: Scenario) -> None:
    """Point ``meshcat``'s camera at the work (see :func:`work_view`)."""
    camera, target = work_view(scenario)
    meshcat.SetCameraPose(camera, target)


CHOSEN_RGBA = Rgba(0.1, 0.9, 0.1, 0.9)
OTHER_RGBA = (Rgba(1.0, 0.85, 0.0, 0.7), Rgba(1.0, 0.55, 0.0, 0.7), Rgba(1.0, 0.3, 0.0, 0.7),
              Rgba(0.9, 0.0, 0.6, 0.7))
"""The rule's 2nd to 5th candidates, yellow to magenta (the overlay's order of colours)."""
ROOT = "/candidates"


class CandidateMarkers:
    """Draws each pick's ranked candidates in Meshcat while that pick runs: for each, the
    closing segment between the finger pads and the two finger footprints at the fingertips,
    the chosen one green. Each pick's markers are shown when it starts and hidden when it
    ends, keyed at those simulated times in a recording, so a replay shows pick 2's markers,
    not pick 1's, during pick 2. Fed with the pick diagram's ``current_pick`` (its records
    need ``PickSettings.record_view``) by :meth:`observer`, from the simulator's monitor."""

    def __init__(self, meshcat: Meshcat, gripper: GripperSpec = DEFAULT_GRIPPER) -> None:
        self._meshcat = meshcat
        self._gripper = gripper
        self._shown: int | None = None

    def observer(self, pick: PickDiagram, recording: bool) -> Callable[[Context], None]:
        """What the simulator's monitor calls with the root context after each step."""
        port = pick.diagram.GetOutputPort("current_pick")
        return lambda root: self.update(port.Eval(root), root.get_time(), recording)

    def update(self, record: PickRecord | None, t: float, recording: bool) -> None:
        """Show ``record``'s candidates (``None``: no pick runs) at simulated time ``t``."""
        index = None if record is None or record.view is None else record.index
        if index == self._shown:
            return
        at = t if recording else None
        if self._shown is not None:
            self._meshcat.SetProperty(f"{ROOT}/pick_{self._shown}", "visible", False, at)
        if index is not None:
            self._draw(f"{ROOT}/pick_{index}", record)
            self._meshcat.SetProperty(f"{ROOT}/pick_{index}", "visible", False, 0.0
                                      if recording else None)
            self._meshcat.SetProperty(f"{ROOT}/pick_{index}", "visible", True, at)
        self._shown = index

    def _draw(self, path: str, record: PickRecord) -> None:
        g = self._gripper
        half = g.max_opening / 2 + g.finger_thickness / 2
        finger = Box(g.finger_width, g.finger_thickness, 0.004)
        shapes = {"closing": (Box(0.002, g.max_opening, 0.002), RigidTransform()),
                  "finger_a": (finger, RigidTransform([0.0, half, 0.0])),
                  "finger_b": (finger, RigidTransform([0.0, -half, 0.0]))}
        others = iter(OTHER_RGBA)
        for rank, scored in enumerate(record.view.ranked):
            c = scored.candidate
            if c.pose is None:
                continue
            rgba = CHOSEN_RGBA if c is record.candidate else next(others, OTHER_RGBA[-1])
            X_WT = RigidTransform(np.asarray(c.pose))
            for name, (shape, X_TS) in shapes.items():
                where = f"{path}/{rank}/{name}"
                self._meshcat.SetObject(where, shape, rgba)
                self._meshcat.SetTransform(where, X_WT @ X_TS)
