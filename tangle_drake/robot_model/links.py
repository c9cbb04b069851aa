"""The Nextage's link geometry, built from primitives sized like the real links (the original
meshes may not be redistributed), and link inertias from that geometry."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydrake.geometry import Box, Capsule, Cylinder, Shape, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import CalcSpatialInertia, SpatialInertia

from tangle_drake.robot_model.kinematics import FLANGE_OFFSET


@dataclass(frozen=True)
class Primitive:
    """A visual-and-collision primitive in its link's frame.

    ``kind`` is box (size = x, y, z), cylinder or capsule (size = radius, length; along the
    primitive's z) or sphere (size = radius,).
    """

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: str = "white"

    def shape(self) -> Shape:
        if self.kind == "box":
            return Box(*self.size)
        if self.kind == "cylinder":
            return Cylinder(*self.size)
        if self.kind == "capsule":
            return Capsule(*self.size)
        if self.kind == "sphere":
            return Sphere(*self.size)
        raise ValueError(f"unknown primitive kind {self.kind!r}")


_HALF_PI = float(np.pi / 2)
_ALONG_X = (0.0, _HALF_PI, 0.0)
_ALONG_Y = (_HALF_PI, 0.0, 0.0)

COLORS = {
    "white": (0.92, 0.92, 0.9, 1.0),
    "grey": (0.55, 0.57, 0.6, 1.0),
    "dark": (0.2, 0.21, 0.23, 1.0),
}

# Sizes follow the real robot: torso ~0.2 m deep and wide, upper arm and forearm ~9 cm and
# ~8 cm thick. The torso is kept to |y| <= 0.09 so that the upper arm (|y| >= 0.13 near the
# elbow at init_rtm) clears it.
_TORSO_GEOMETRY: dict[str, tuple[Primitive, ...]] = {
    "WAIST": (Primitive("box", (0.20, 0.24, 0.12), (-0.02, 0, -0.06), color="grey"),),
    "CHEST_JOINT0_Link": (Primitive("box", (0.20, 0.18, 0.48), (-0.02, 0, 0.24)),),
    # Neck from inside the chest's top (z = -0.09) up into the head (z = +0.02).
    "HEAD_JOINT0_Link": (Primitive("cylinder", (0.03, 0.12), (0, 0, -0.03), color="dark"),),
    "HEAD_JOINT1_Link": (Primitive("box", (0.13, 0.20, 0.14), (0.005, 0, 0.09)),),
}
_LEFT_ARM_GEOMETRY: dict[str, tuple[Primitive, ...]] = {
    # Shoulder-yaw housing on the chest's side.
    "LARM_JOINT0_Link": (Primitive("cylinder", (0.045, 0.08), (0, 0, 0.01), color="grey"),),
    # Shoulder-pitch housing, then the upper arm hanging at y = 0.095.
    "LARM_JOINT1_Link": (
        Primitive("cylinder", (0.045, 0.07), (0, 0.085, 0), _ALONG_Y, color="grey"),
        Primitive("capsule", (0.045, 0.2), (0, 0.095, -0.125)),
    ),
    # Elbow-pitch housing.
    "LARM_JOINT2_Link": (Primitive("cylinder", (0.042, 0.08), (0, 0, 0), _ALONG_Y, color="grey"),),
    # Forearm along −z down to the wrist pitch.
    "LARM_JOINT3_Link": (Primitive("capsule", (0.04, 0.15), (0, 0, -0.11)),),
    # Wrist-pitch housing and the bracket down to the wrist roll.
    "LARM_JOINT4_Link": (
        Primitive("cylinder", (0.035, 0.07), (0, 0, 0), _ALONG_Y, color="grey"),
        Primitive("box", (0.045, 0.06, 0.06), (-0.0225, 0, -0.03), color="grey"),
    ),
    # Wrist-roll housing behind the flange (x from −FLANGE_OFFSET to +0.045).
    "LARM_JOINT5_Link": (
        Primitive("cylinder", (0.035, 0.045 + FLANGE_OFFSET), (0.02, 0, 0), _ALONG_X,
                  color="dark"),
    ),
}


def _mirror_primitive(p: Primitive) -> Primitive:
    """Reflect a primitive through the x-z plane (every primitive here is symmetric)."""
    x, y, z = p.xyz
    roll, pitch, yaw = p.rpy
    return replace(p, xyz=(x, -y, z), rpy=(-roll, pitch, -yaw))


LINK_GEOMETRY: dict[str, tuple[Primitive, ...]] = {
    **_TORSO_GEOMETRY,
    **_LEFT_ARM_GEOMETRY,
    **{name.replace("LARM", "RARM"): tuple(_mirror_primitive(p) for p in prims)
       for name, prims in _LEFT_ARM_GEOMETRY.items()},
}

COLLISION_FILTER_GROUPS: dict[str, tuple[str, ...]] = {
    # The neck sits in the chest's top and the tilted head reaches down to it.
    "torso_head": ("WAIST", "CHEST_JOINT0_Link", "HEAD_JOINT0_Link", "HEAD_JOINT1_Link"),
    # Forearm, wrist pitch and wrist roll housings touch at full wrist pitch.
    "larm_wrist": ("LARM_JOINT3_Link", "LARM_JOINT4_Link", "LARM_JOINT5_Link"),
    "rarm_wrist": ("RARM_JOINT3_Link", "RARM_JOINT4_Link", "RARM_JOINT5_Link"),
    # Upper arm and forearm overlap around the short elbow link; the elbow's joint limit, not
    # contact, keeps them apart.
    "larm_elbow": ("LARM_JOINT1_Link", "LARM_JOINT2_Link", "LARM_JOINT3_Link"),
    "rarm_elbow": ("RARM_JOINT1_Link", "RARM_JOINT2_Link", "RARM_JOINT3_Link"),
}
"""Groups whose members never collide with each other (Drake already filters parent/child)."""


def _primitive_pose(p: Primitive) -> RigidTransform:
    return RigidTransform(RollPitchYaw(*p.rpy), np.array(p.xyz, float))


def link_inertia(primitives: tuple[Primitive, ...], mass: float) -> tuple[np.ndarray, np.ndarray]:
    """(centre of mass, rotational inertia about it) in the link frame, for uniform density.

    The density is whatever gives ``mass``: the shape of the mass distribution comes from the
    geometry, its total from the table.
    """
    total = SpatialInertia.Zero()
    for p in primitives:
        M_PPo_P = CalcSpatialInertia(p.shape(), 1.0)
        X_LP = _primitive_pose(p)
        M_PPo_L = M_PPo_P.ReExpress(X_LP.rotation())
        total += M_PPo_L.Shift(-X_LP.translation())
    scale = mass / total.get_mass()
    p_LoLcm = total.get_com()
    I_Lcm = total.Shift(p_LoLcm).CalcRotationalInertia().CopyToFullMatrix3() * scale
    return p_LoLcm, I_Lcm
