"""Generator of the shipped Nextage + parallel-jaw gripper model files.

The kinematic table of the Nextage (``shared/reference/nextage.md``) is written down here and
nowhere else; the URDF, the gripper SDF (from :class:`tangle_drake.gripper.GripperSpec`), the
model directives and ``package.xml`` under ``models/nextage/`` are generated from it so that the
numbers cannot drift apart. The original meshes may not be redistributed, so every link is built
from primitives sized like the real one; inertias come from that geometry, scaled to the table's
masses.

``python -m tangle_drake.robot_model`` rewrites the files; ``--check`` only compares them.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from pydrake.geometry import Box, Capsule, Cylinder, Shape, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import CalcSpatialInertia, SpatialInertia

from tangle_drake.gripper import DEFAULT_GRIPPER, GripperSpec

WAIST_HEIGHT = 0.97
"""Height of the ``WAIST`` origin above the floor (world z = 0), m."""

FLANGE_OFFSET = 0.005
"""Distance of the tool flange from the ``*_JOINT5_Link`` origin along the link's −x, m.

The wrist-roll housing of the model fills x ∈ [−FLANGE_OFFSET, +0.045] of that link, so the
gripper's palm starts just outside it.
"""

JOINT_DAMPING = 0.2
"""Viscous joint damping of the original model, N·m·s/rad."""


@dataclass(frozen=True)
class JointSpec:
    """One row of the kinematic table: a revolute joint and the mass of its child link."""

    name: str
    parent: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: str
    lower: float
    upper: float
    effort: float
    velocity: float
    child_mass: float

    @property
    def child(self) -> str:
        return f"{self.name}_Link"


# The table of nextage.md, left arm as given there.
_TORSO_JOINTS = (
    JointSpec("CHEST_JOINT0", "WAIST", (0, 0, 0), (0, 0, 0), "z",
              -2.84489, 2.84489, 100, 1.91986, 3.0),
    JointSpec("HEAD_JOINT0", "CHEST_JOINT0_Link", (0, 0, 0.5695), (0, 0, 0), "z",
              -1.22173, 1.22173, 100, 2.61799, 0.317929),
    JointSpec("HEAD_JOINT1", "HEAD_JOINT0_Link", (0, 0, 0), (0, 0, 0), "y",
              -0.349066, 1.22173, 100, 4.36332, 0.0808593),
)
_LEFT_ARM_JOINTS = (
    JointSpec("LARM_JOINT0", "CHEST_JOINT0_Link", (0, 0.145, 0.370296), (-0.261799, 0, 0), "z",
              -1.53589, 1.53589, 150, 3.00197, 1.32626),
    JointSpec("LARM_JOINT1", "LARM_JOINT0_Link", (0, 0, 0), (0, 0, 0), "y",
              -2.44346, 1.0472, 200, 2.32129, 1.14898),
    JointSpec("LARM_JOINT2", "LARM_JOINT1_Link", (0, 0.095, -0.25), (0, 0, 0), "y",
              -2.75762, 0, 100, 3.99680, 0.577518),
    JointSpec("LARM_JOINT3", "LARM_JOINT2_Link", (-0.03, 0, 0), (0, 0, 0), "z",
              -1.8326, 2.87979, 100, 4.60767, 0.457418),
    JointSpec("LARM_JOINT4", "LARM_JOINT3_Link", (0, 0, -0.235), (0, 0, 0), "y",
              -1.74533, 1.74533, 100, 3.90954, 0.418434),
    JointSpec("LARM_JOINT5", "LARM_JOINT4_Link", (-0.047, 0, -0.09), (0, 0, 0), "x",
              -2.84489, 2.84489, 100, 5.23599, 1.05156),
)


def _mirror(joint: JointSpec) -> JointSpec:
    """The right-arm twin of a left-arm joint, by the rule of nextage.md."""
    name = joint.name.replace("LARM", "RARM")
    parent = joint.parent.replace("LARM", "RARM")
    x, y, z = joint.xyz
    roll, pitch, yaw = joint.rpy
    mirrored = replace(joint, name=name, parent=parent, xyz=(x, -y, z), rpy=(-roll, pitch, yaw))
    if name == "RARM_JOINT3":
        mirrored = replace(mirrored, lower=-2.87979, upper=1.8326)
    if name == "RARM_JOINT2":
        mirrored = replace(mirrored, velocity=3.75246)
    return mirrored


JOINTS: tuple[JointSpec, ...] = (
    _TORSO_JOINTS + _LEFT_ARM_JOINTS + tuple(_mirror(j) for j in _LEFT_ARM_JOINTS)
)
"""All 15 joints, in the order of ``tangle_drake.robot.NEXTAGE_JOINTS``."""

INIT_RTM_LEFT_ARM = (0.010472, 0.0, -1.745329, -0.265290, 0.164061, -0.055851)
"""The named pose ``init_rtm`` of LARM_JOINT0..5 (chest and head at 0)."""
RIGHT_ARM_MIRROR_SIGNS = (-1.0, 1.0, 1.0, -1.0, 1.0, -1.0)
"""A right-arm pose is the left-arm pose times these signs (joints 0, 3 and 5 flipped)."""


def init_rtm() -> dict[str, float]:
    """The ``init_rtm`` pose as joint name -> position, for all 15 joints."""
    pose = {j.name: 0.0 for j in JOINTS}
    for j, q, sign in zip(_LEFT_ARM_JOINTS, INIT_RTM_LEFT_ARM, RIGHT_ARM_MIRROR_SIGNS,
                          strict=True):
        pose[j.name] = q
        pose[_mirror(j).name] = q * sign
    return pose


_WAIST_MASS = 5.0
"""Not in the table: WAIST is welded to the world, so its mass never enters the dynamics."""

# PD gains of the simulated position servos (our choice, not a fact of the robot), per joint
# suffix: (p [N·m/rad], d [N·m·s/rad]). p keeps the gravity sag of the stretched arm below
# ~0.5 mm at the wrist; d damps each joint near critically for the arm's inertia seen by it.
_GAINS = {
    "CHEST_JOINT0": (20000.0, 400.0),
    "HEAD_JOINT0": (500.0, 2.0),
    "HEAD_JOINT1": (500.0, 2.0),
    "JOINT0": (20000.0, 250.0),
    "JOINT1": (30000.0, 300.0),
    "JOINT2": (20000.0, 130.0),
    "JOINT3": (5000.0, 10.0),
    "JOINT4": (5000.0, 20.0),
    "JOINT5": (2000.0, 3.0),
}


def joint_gains(name: str) -> tuple[float, float]:
    """(p, d) of the PD servo of joint ``name``."""
    return _GAINS.get(name) or _GAINS[name.split("_", 1)[1]]


# --- Link geometry ---------------------------------------------------------------------------


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

_COLORS = {
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


# --- Inertia -----------------------------------------------------------------------------------


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


# --- XML writers -------------------------------------------------------------------------------


def _num(x: float) -> str:
    """Compact, deterministic number format (no '-0')."""
    text = f"{float(x):.8g}"
    return "0" if text == "-0" else text


def _nums(values) -> str:
    return " ".join(_num(v) for v in values)


def _xml_text(root: ET.Element, header: str) -> str:
    ET.indent(root, space="  ")
    body = ET.tostring(root, encoding="unicode")
    return f'<?xml version="1.0"?>\n<!-- {header} -->\n{body}\n'


_GENERATED = "Generated by `python -m tangle_drake.robot_model` - do not edit by hand."


def _urdf_geometry(parent: ET.Element, p: Primitive) -> None:
    ET.SubElement(parent, "origin", xyz=_nums(p.xyz), rpy=_nums(p.rpy))
    geometry = ET.SubElement(parent, "geometry")
    if p.kind == "box":
        ET.SubElement(geometry, "box", size=_nums(p.size))
    elif p.kind == "sphere":
        ET.SubElement(geometry, "sphere", radius=_num(p.size[0]))
    elif p.kind == "cylinder":
        ET.SubElement(geometry, "cylinder", radius=_num(p.size[0]), length=_num(p.size[1]))
    else:
        ET.SubElement(geometry, "drake:capsule", radius=_num(p.size[0]), length=_num(p.size[1]))


def _urdf_link(robot: ET.Element, name: str, mass: float) -> None:
    primitives = LINK_GEOMETRY[name]
    com, inertia = link_inertia(primitives, mass)
    link = ET.SubElement(robot, "link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=_nums(com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=_num(mass))
    ET.SubElement(inertial, "inertia", ixx=_num(inertia[0, 0]), ixy=_num(inertia[0, 1]),
                  ixz=_num(inertia[0, 2]), iyy=_num(inertia[1, 1]), iyz=_num(inertia[1, 2]),
                  izz=_num(inertia[2, 2]))
    for i, p in enumerate(primitives):
        visual = ET.SubElement(link, "visual", name=f"{name}_visual_{i}")
        _urdf_geometry(visual, p)
        ET.SubElement(visual, "material", name=p.color)
    for i, p in enumerate(primitives):
        collision = ET.SubElement(link, "collision", name=f"{name}_collision_{i}")
        _urdf_geometry(collision, p)


_AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


def nextage_urdf() -> str:
    """The Nextage URDF: 15 PD-servoed revolute joints, primitive geometry."""
    robot = ET.Element("robot", {"name": "nextage", "xmlns:drake": "http://drake.mit.edu"})
    for color, rgba in _COLORS.items():
        material = ET.SubElement(robot, "material", name=color)
        ET.SubElement(material, "color", rgba=_nums(rgba))
    _urdf_link(robot, "WAIST", _WAIST_MASS)
    for j in JOINTS:
        _urdf_link(robot, j.child, j.child_mass)
    for j in JOINTS:
        joint = ET.SubElement(robot, "joint", name=j.name, type="revolute")
        ET.SubElement(joint, "parent", link=j.parent)
        ET.SubElement(joint, "child", link=j.child)
        ET.SubElement(joint, "origin", xyz=_nums(j.xyz), rpy=_nums(j.rpy))
        ET.SubElement(joint, "axis", xyz=_nums(_AXES[j.axis]))
        ET.SubElement(joint, "limit", lower=_num(j.lower), upper=_num(j.upper),
                      effort=_num(j.effort), velocity=_num(j.velocity))
        ET.SubElement(joint, "dynamics", damping=_num(JOINT_DAMPING))
    for j in JOINTS:
        p, d = joint_gains(j.name)
        transmission = ET.SubElement(robot, "transmission", name=f"{j.name}_trans")
        ET.SubElement(transmission, "type").text = "transmission_interface/SimpleTransmission"
        ET.SubElement(transmission, "joint", name=j.name)
        actuator = ET.SubElement(transmission, "actuator", name=f"{j.name}_motor")
        ET.SubElement(actuator, "drake:controller_gains", p=_num(p), d=_num(d))
    for group, members in COLLISION_FILTER_GROUPS.items():
        element = ET.SubElement(robot, "drake:collision_filter_group", name=group)
        for member in members:
            ET.SubElement(element, "drake:member", link=member)
        ET.SubElement(element, "drake:ignored_collision_filter_group", name=group)
    return _xml_text(robot, _GENERATED)


# --- Gripper -----------------------------------------------------------------------------------

FINGER_MU = 0.9
"""Friction coefficient (static and dynamic) of the finger pads: rubber-ish on steel wire."""

FINGER_STIFFNESS = 1.0e5
"""Point-contact stiffness of the finger pads, N/m, so that it does not depend on the plant's
penetration allowance: 40 N sinks a pad ~0.8 mm into a part of the same stiffness.

At a 2 ms SAP step this is not what decides a grasp of a light part: SAP's near-rigid
regularisation makes a ~10 g wire squeezed between the fingers far softer than this, and with
point contact the fingers crush through it (measured). Hence the hydroelastic pads below.
"""

FINGER_HYDROELASTIC_MODULUS = 1.0e7
"""Hydroelastic modulus of the compliant finger pads, Pa (firm rubber).

The pads are also compliant-hydroelastic boxes: against a part declared rigid-hydroelastic
(in Drake's default ``hydroelastic_with_fallback`` contact model) they hold a 13 g, 3 mm
capsule wire at a 2 ms SAP step, where point contact lets it slip. Against anything else the
same boxes fall back to point contact.
"""

GRIPPER_FINGER_P = 20000.0
"""Proportional gain of each finger's servo, N/m: a finger commanded 2 mm past its contact
already pushes the full grip force, so closing to width 0 clamps a 3 mm wire firmly."""

GRIPPER_FINGER_SPEED = 0.2
"""Free closing speed of each finger, m/s.

MultibodyPlant does not enforce velocity limits, and while the servo saturates at grip_force
its d-term does nothing; so the speed is set by viscous joint damping grip_force / speed,
which acts whatever the servo does (the servo's own d is 0).
"""


def _sdf_pose(parent: ET.Element, xyz, rpy=(0, 0, 0)) -> None:
    ET.SubElement(parent, "pose").text = f"{_nums(xyz)} {_nums(rpy)}"


def _sdf_box(parent: ET.Element, tag: str, name: str, size, xyz, rgba=None) -> ET.Element:
    element = ET.SubElement(parent, tag, name=name)
    _sdf_pose(element, xyz)
    geometry = ET.SubElement(element, "geometry")
    ET.SubElement(ET.SubElement(geometry, "box"), "size").text = _nums(size)
    if rgba is not None:
        material = ET.SubElement(element, "material")
        ET.SubElement(material, "diffuse").text = _nums(rgba)
    return element


def _sdf_inertial(link: ET.Element, mass: float, size, xyz) -> None:
    inertia = CalcSpatialInertia(Box(*size), 1.0).CalcRotationalInertia().CopyToFullMatrix3()
    inertia *= mass / (size[0] * size[1] * size[2])
    inertial = ET.SubElement(link, "inertial")
    _sdf_pose(inertial, xyz)
    ET.SubElement(inertial, "mass").text = _num(mass)
    element = ET.SubElement(inertial, "inertia")
    for key, value in (("ixx", inertia[0, 0]), ("ixy", 0), ("ixz", 0), ("iyy", inertia[1, 1]),
                       ("iyz", 0), ("izz", inertia[2, 2])):
        ET.SubElement(element, key).text = _num(value)


def gripper_sdf(spec: GripperSpec = DEFAULT_GRIPPER) -> str:
    """The parallel-jaw gripper: palm ``gripper_base`` (frame G) and two PD-servoed fingers.

    Both finger bodies share G's pose at q = 0; finger ``left`` (−y side) has its inner face at
    y = q_left, ``right`` at y = q_right, so the opening is q_right − q_left.
    """
    sdf = ET.Element("sdf", {"version": "1.9", "xmlns:drake": "http://drake.mit.edu"})
    model = ET.SubElement(sdf, "model", name="gripper")
    palm_depth = spec.palm_size[2]
    palm = ET.SubElement(model, "link", name="gripper_base")
    palm_center = (0, 0, palm_depth / 2)
    _sdf_inertial(palm, spec.palm_mass, spec.palm_size, palm_center)
    _sdf_box(palm, "visual", "palm_visual", spec.palm_size, palm_center, (0.25, 0.26, 0.28, 1))
    _sdf_box(palm, "collision", "palm_collision", spec.palm_size, palm_center)

    finger_size = (spec.finger_width, spec.finger_thickness, spec.finger_length)
    upper_length = spec.finger_length - spec.pad_length
    for side, sign, limits in (("left", -1.0, (-spec.finger_stroke, 0.0)),
                               ("right", 1.0, (0.0, spec.finger_stroke))):
        y = sign * spec.finger_thickness / 2
        link = ET.SubElement(model, "link", name=f"{side}_finger")
        center = (0, y, palm_depth + spec.finger_length / 2)
        _sdf_inertial(link, spec.finger_mass, finger_size, center)
        _sdf_box(link, "visual", f"{side}_finger_visual",
                 (spec.finger_width, spec.finger_thickness, upper_length),
                 (0, y, palm_depth + upper_length / 2), (0.7, 0.72, 0.75, 1))
        _sdf_box(link, "visual", f"{side}_pad_visual",
                 (spec.finger_width, spec.finger_thickness, spec.pad_length),
                 (0, y, spec.reach - spec.pad_length / 2), (0.85, 0.35, 0.1, 1))
        collision = _sdf_box(link, "collision", f"{side}_finger_collision", finger_size, center)
        properties = ET.SubElement(collision, "drake:proximity_properties")
        ET.SubElement(properties, "drake:mu_dynamic").text = _num(FINGER_MU)
        ET.SubElement(properties, "drake:mu_static").text = _num(FINGER_MU)
        ET.SubElement(properties, "drake:point_contact_stiffness").text = _num(
            FINGER_STIFFNESS)
        ET.SubElement(properties, "drake:compliant_hydroelastic")
        ET.SubElement(properties, "drake:hydroelastic_modulus").text = _num(
            FINGER_HYDROELASTIC_MODULUS)

        joint = ET.SubElement(model, "joint", name=f"{side}_finger_sliding_joint",
                              type="prismatic")
        ET.SubElement(joint, "parent").text = "gripper_base"
        ET.SubElement(joint, "child").text = f"{side}_finger"
        axis = ET.SubElement(joint, "axis")
        ET.SubElement(axis, "xyz").text = "0 1 0"
        limit = ET.SubElement(axis, "limit")
        ET.SubElement(limit, "lower").text = _num(limits[0])
        ET.SubElement(limit, "upper").text = _num(limits[1])
        ET.SubElement(limit, "effort").text = _num(spec.grip_force)
        ET.SubElement(limit, "velocity").text = _num(GRIPPER_FINGER_SPEED)
        ET.SubElement(ET.SubElement(axis, "dynamics"), "damping").text = _num(
            spec.grip_force / GRIPPER_FINGER_SPEED)
        ET.SubElement(joint, "drake:controller_gains", p=_num(GRIPPER_FINGER_P), d="0")

    tcp = ET.SubElement(model, "frame", name="gripper_tcp", attached_to="gripper_base")
    _sdf_pose(tcp, (0, 0, spec.tcp_offset))
    # The fingers meet at q = 0 (a joint limit): no point in colliding them with each other.
    group = ET.SubElement(model, "drake:collision_filter_group", name="fingers")
    for side in ("left", "right"):
        ET.SubElement(group, "drake:member").text = f"{side}_finger"
    ET.SubElement(group, "drake:ignored_collision_filter_group").text = "fingers"
    return _xml_text(sdf, _GENERATED)


# --- Directives and package --------------------------------------------------------------------


def model_directives(spec: GripperSpec = DEFAULT_GRIPPER) -> str:
    """Nextage on its stand plus the gripper on the left flange, as Drake model directives.

    Default positions are ``init_rtm`` and an open gripper, so a default context starts in a
    collision-free pose (all-zero joints would sink the hanging arms into the waist).
    """
    arm_defaults = "".join(f"\n      {name}: [{_num(q)}]" for name, q in init_rtm().items())
    return f"""# {_GENERATED}
# WAIST stands {WAIST_HEIGHT} m above the floor (world z = 0). The gripper frame G (gripper_base)
# sits on the left flange, {FLANGE_OFFSET * 1000:g} mm along -x of LARM_JOINT5_Link, rotated so that
# G's +z (approach) is the link's -x (the tool axis) and G's y (closing) is the link's y.
directives:
- add_model:
    name: nextage
    file: package://nextage/urdf/nextage.urdf
    default_joint_positions:{arm_defaults}
- add_weld:
    parent: world
    child: nextage::WAIST
    X_PC:
      translation: [0, 0, {_num(WAIST_HEIGHT)}]
- add_model:
    name: gripper
    file: package://nextage/sdf/parallel_jaw_gripper.sdf
    default_joint_positions:
      left_finger_sliding_joint: [{_num(-spec.finger_stroke)}]
      right_finger_sliding_joint: [{_num(spec.finger_stroke)}]
- add_weld:
    parent: nextage::LARM_JOINT5_Link
    child: gripper::gripper_base
    X_PC:
      translation: [{_num(-FLANGE_OFFSET)}, 0, 0]
      rotation: !Rpy {{ deg: [0, -90, 0] }}
"""


def package_xml() -> str:
    """``package.xml`` that lets Drake's PackageMap resolve ``package://nextage/...``."""
    return f"""<?xml version="1.0"?>
<!-- {_GENERATED} -->
<package format="2">
  <name>nextage</name>
  <version>0.1.0</version>
  <description>
    Kawada NEXTAGE OPEN (primitive geometry, Drake PD servos) with a parallel-jaw gripper,
    for tangle_drake. Kinematics from the public nextage_description package; no meshes.
  </description>
  <maintainer email="tangle-drake@example.invalid">tangle_drake</maintainer>
  <license>BSD-3-Clause</license>
</package>
"""


def generated_files() -> dict[str, str]:
    """Shipped model files, keyed by path relative to ``models/nextage``."""
    return {
        "urdf/nextage.urdf": nextage_urdf(),
        "sdf/parallel_jaw_gripper.sdf": gripper_sdf(),
        "nextage_with_gripper.dmd.yaml": model_directives(),
        "package.xml": package_xml(),
    }


def _package_dir() -> Path:
    return Path(__file__).resolve().parent.parent / "models" / "nextage"


def main(argv: list[str] | None = None) -> int:
    """Write the model files, or with ``--check`` report those that differ from the code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if a shipped file differs from the generated one")
    parser.add_argument("--out", type=Path, default=_package_dir(),
                        help="package directory (default: models/nextage of this checkout)")
    args = parser.parse_args(argv)
    stale = []
    for relative, text in generated_files().items():
        path = args.out / relative
        current = path.read_text() if path.is_file() else None
        if current == text:
            continue
        stale.append(relative)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    if args.check and stale:
        print("stale model files (run python -m tangle_drake.robot_model):", *stale,
              sep="\n  ", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
