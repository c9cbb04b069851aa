"""Stirring the bin: a sweep of the closed fingers through what is left, when nothing more can
be picked from the pile as it lies.

Two things stop a closed-loop cell before its bin is empty: parts that no grasp reaches (a
part lying against a wall, where the palm's overhang keeps the fingers out; the graspability
index then offers nothing), and piles whose grasps keep coming up empty (an E-shape's bar end
slips out of the fingers, and the next candidates are its neighbours). In both the pile must
change. The sweep starts as near the wall closest to what is left as the palm allows, as
near level with it as the floor there is free, goes along the floor towards the bin's middle,
and rises clear; a part against the wall
is dragged off it, a pile is turned over. The closed fingers lead with the palm's short side.

Everything here is geometry on :class:`~tangle_drake.pick.bin_contents.BinContents`; the
``Motion`` plans the move through the tool poses (:func:`stir_poses`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tangle_drake.pick.bin_contents import BinContents
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec

RIM_CLEARANCE = 0.02
"""The fingertips start and end the sweep this far above the rim, m."""


@dataclass(frozen=True)
class StirSettings:
    """When the bin counts as empty, and how the sweep goes (SI units)."""

    min_height: float = 0.002
    """A cell of the floor holds something where the surface is higher than this, m."""
    min_area: float = 1e-4
    """The bin looks empty when less floor than this holds something, m² (a lying wire 6 mm
    thick covers this much in 17 mm)."""
    tip_height: float = 0.002
    """The fingertips sweep this far above the floor, m: under a lying wire's middle..."""
    above_parts: float = 0.003
    """...or, where something lies under the sweep's start, this far above it (the fingers
    never come down on a part)."""
    length: float = 0.1
    """The sweep's length, m (it stops short of the far wall)."""
    speed: float = 0.05
    """The tool centre's speed down into the bin, along the sweep and up, m/s."""
    wall_clearance: float = 0.005
    """The palm keeps this far from the walls, m."""
    force_limit: float = 30.0
    """A sweep whose wrist feels more than this across (N) has met something it must not
    push (a part jammed against a wall, the wall itself): it goes back the way it came.
    Pushing loose parts along takes well under this in the simulation
    (``docs/closed-loop.md``)."""

    def __post_init__(self) -> None:
        for name in ("min_height", "min_area", "length", "speed", "force_limit"):
            if not getattr(self, name) > 0:
                raise ValueError(f"StirSettings.{name} must be positive")
        for name in ("tip_height", "above_parts", "wall_clearance"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"StirSettings.{name} must be >= 0")


@dataclass(frozen=True)
class StirLine:
    """One sweep: the fingertips' path in the world, m."""

    start: np.ndarray
    """World (x, y, z) of the fingertips where the sweep begins."""
    end: np.ndarray
    direction: np.ndarray
    """Unit world (x, y) direction of the sweep."""


def looks_empty(contents: BinContents, settings: StirSettings) -> bool:
    """Whether the camera sees nothing left in the bin."""
    return contents.area(settings.min_height) < settings.min_area


def stir_line(contents: BinContents, settings: StirSettings,
              spec: GripperSpec = DEFAULT_GRIPPER) -> StirLine | None:
    """The sweep through what is left in the bin (see the module docstring); ``None`` when the
    bin looks empty or is too small for the palm to go down into it."""
    if looks_empty(contents, settings):
        return None
    occupied = contents.occupied(settings.min_height)
    centroid = contents.cell_xy(*np.nonzero(occupied)).mean(axis=0)
    b = contents.bin
    low = np.asarray(b.center, float) - np.asarray(b.inner_size, float) / 2
    high = low + np.asarray(b.inner_size, float)
    # The wall nearest what is left: the sweep starts there and goes away from it.
    gaps = [centroid[0] - low[0], high[0] - centroid[0], centroid[1] - low[1],
            high[1] - centroid[1]]
    wall = int(np.argmin(gaps))
    axis = wall // 2  # 0: the sweep runs along x, 1: along y
    sign = 1.0 if wall % 2 == 0 else -1.0
    along = spec.palm_size[0] / 2 + settings.wall_clearance  # the palm's short side leads
    across = spec.palm_size[1] / 2 + settings.wall_clearance
    side = 1 - axis
    if high[axis] - low[axis] < 2 * along or high[side] - low[side] < 2 * across:
        return None
    # Down where nothing lies under the closed fingers (their half-diagonal and a margin),
    # as near level with what is left as there is such a place; else above what lies there.
    reach = np.hypot(spec.finger_width / 2, spec.finger_thickness) + 0.002
    start = np.empty(2)
    start[axis] = low[axis] + along if sign > 0 else high[axis] - along
    sides = np.arange(low[side] + across, high[side] - across + 1e-9, contents.cell)
    sides = sides[np.argsort(np.abs(sides - centroid[side]), kind="stable")]
    under = np.inf
    for position in sides:
        start[side] = position
        under = contents.top_within(start, reach)
        if under <= settings.min_height:
            break
    else:
        start[side] = np.clip(centroid[side], low[side] + across, high[side] - across)
        under = contents.top_within(start, reach)
    height = settings.tip_height if under <= settings.min_height else max(
        settings.tip_height, under + settings.above_parts)
    direction = np.zeros(2)
    direction[axis] = sign
    room = high[axis] - low[axis] - 2 * along
    end = start + min(settings.length, room) * direction
    z = b.floor_height + height
    return StirLine(np.array([*start, z]), np.array([*end, z]), direction)


def stir_poses(line: StirLine, rim: float,
               spec: GripperSpec = DEFAULT_GRIPPER) -> list[np.ndarray]:
    """The tool poses ``X_WT`` (4x4) of the sweep: above its start, at its start, at its end,
    above its end. The tool points down, its x axis (the palm's short side) along the sweep;
    "above" puts the fingertips :data:`RIM_CLEARANCE` over the bin's ``rim`` (world z, m)."""
    x = np.array([*line.direction, 0.0])
    z = np.array([0.0, 0.0, -1.0])
    R = np.column_stack([x, np.cross(z, x), z])
    tips_below_tcp = spec.reach - spec.tcp_offset
    top = max(line.start[2], rim) + RIM_CLEARANCE
    poses = []
    for point, tips_z in ((line.start, top), (line.start, line.start[2]),
                          (line.end, line.end[2]), (line.end, top)):
        X = np.eye(4)
        X[:3, :3] = R
        X[:3, 3] = [point[0], point[1], tips_z + tips_below_tcp]
        poses.append(X)
    return poses
