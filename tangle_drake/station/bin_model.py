"""The bin the parts lie in (and the output tray they go to): a floor and four walls on a
stand, generated from a ``BinConfig``."""

from __future__ import annotations

import numpy as np

from tangle_drake.scenario import BinConfig

# Steel-on-painted-steel friction; the same number for the floor, walls and stand.
_FRICTION = (0.5, 0.4)


def bin_boxes(config: BinConfig) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Name -> (centre in world, full size) of each box of the bin, stand included.

    The walls reach down through the floor and the stand is as wide as the floor, so the box
    has no seam: with walls standing on a thin floor, a wire pried into the floor beside a
    wall (point contact lets it sink a few millimetres) was pushed out under the wall by the
    floor's side face, and the part was lost through a solid box.
    """
    cx, cy = config.center
    sx, sy = config.inner_size
    t, h, f = config.wall_thickness, config.wall_height, config.floor_thickness
    z0 = config.floor_height
    wall_z, wall_h = z0 + (h - f) / 2, h + f
    return {
        "floor": (np.array([cx, cy, z0 - f / 2]), np.array([sx + 2 * t, sy + 2 * t, f])),
        "wall_front": (np.array([cx + (sx + t) / 2, cy, wall_z]),
                       np.array([t, sy + 2 * t, wall_h])),
        "wall_back": (np.array([cx - (sx + t) / 2, cy, wall_z]),
                      np.array([t, sy + 2 * t, wall_h])),
        "wall_left": (np.array([cx, cy + (sy + t) / 2, wall_z]), np.array([sx, t, wall_h])),
        "wall_right": (np.array([cx, cy - (sy + t) / 2, wall_z]), np.array([sx, t, wall_h])),
        "stand": (np.array([cx, cy, (z0 - f) / 2]),
                  np.array([sx + 2 * t, sy + 2 * t, z0 - f])),
    }


BIN_MODEL = "bin"
"""The bin's model instance in a station's plant."""


def bin_sdf(config: BinConfig, name: str = BIN_MODEL, stand: bool = True) -> str:
    """SDFormat text of the box as one static model named ``name`` (welded to the world);
    ``stand=False`` leaves out the stand under it (the tray: a stand beside the bin would show
    in the top camera's view, which widens below the bin's floor)."""
    links = []
    for box_name, (center, size) in bin_boxes(config).items():
        if box_name == "stand" and not stand:
            continue
        colour = "0.35 0.37 0.4 1" if box_name != "stand" else "0.55 0.5 0.45 1"
        box = f"<box><size>{size[0]:.6f} {size[1]:.6f} {size[2]:.6f}</size></box>"
        links.append(f"""
    <link name="{box_name}">
      <pose>{center[0]:.6f} {center[1]:.6f} {center[2]:.6f} 0 0 0</pose>
      <visual name="visual"><geometry>{box}</geometry>
        <material><diffuse>{colour}</diffuse></material></visual>
      <collision name="collision"><geometry>{box}</geometry>
        <drake:proximity_properties>
          <drake:mu_static>{_FRICTION[0]}</drake:mu_static>
          <drake:mu_dynamic>{_FRICTION[1]}</drake:mu_dynamic>
        </drake:proximity_properties></collision>
    </link>""")
    return f"""<?xml version="1.0"?>
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="{name}">
    <static>true</static>{"".join(links)}
  </model>
</sdf>
"""


RELEASE_ABOVE_RIM = 0.10
"""The tool centre releases a part this far above the tray's rim, m: the part, hanging up to
a few centimetres below it, drops in clear of the walls."""


def release_point(tray: BinConfig) -> np.ndarray:
    """Where the tool centre releases a part over ``tray``: above its floor's centre, m."""
    return np.array([*tray.center, tray.floor_height + tray.wall_height + RELEASE_ABOVE_RIM])


def inside_bin(config: BinConfig, p_W: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Whether world point(s) (..., 3) lie above the bin's inner floor, ``margin`` from the walls.

    A pile may rise above the walls and still be in the bin, so there is no upper bound.
    """
    p_W = np.asarray(p_W, float)
    half = np.asarray(config.inner_size) / 2 - margin
    d = np.abs(p_W[..., :2] - np.asarray(config.center))
    return np.all(d <= half, axis=-1) & (p_W[..., 2] >= config.floor_height - 0.005)


def inner_corners(config: BinConfig) -> np.ndarray:
    """The inner floor's four corners in world coordinates, (4, 3)."""
    cx, cy = config.center
    hx, hy = np.asarray(config.inner_size) / 2
    z = config.floor_height
    return np.array([[cx - hx, cy - hy, z], [cx + hx, cy - hy, z],
                     [cx + hx, cy + hy, z], [cx - hx, cy + hy, z]])
