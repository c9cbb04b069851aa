"""The parallel-jaw gripper's SDF, written from :class:`.gripper.GripperSpec`."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from pydrake.geometry import Box
from pydrake.multibody.tree import CalcSpatialInertia

from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.robot_model.writers import GENERATED, num, nums, xml_text

FINGER_MU = 0.9
"""Friction coefficient (static and dynamic) of the finger pads: rubber-ish on steel wire."""

FINGER_STIFFNESS = 1.0e5
"""Point-contact stiffness of the finger pads, N/m, so that it does not depend on the plant's
penetration allowance: 40 N sinks a pad ~0.8 mm into a part of the same stiffness.

At a 2 ms SAP step this is not what decides a grasp of a light part: SAP's near-rigid
regularisation makes a ~10 g wire squeezed between the fingers far softer than this, and with
point contact the fingers crush through it and it drops. Hence the hydroelastic pads below.
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
    ET.SubElement(parent, "pose").text = f"{nums(xyz)} {nums(rpy)}"


def _sdf_box(parent: ET.Element, tag: str, name: str, size, xyz, rgba=None) -> ET.Element:
    element = ET.SubElement(parent, tag, name=name)
    _sdf_pose(element, xyz)
    geometry = ET.SubElement(element, "geometry")
    ET.SubElement(ET.SubElement(geometry, "box"), "size").text = nums(size)
    if rgba is not None:
        material = ET.SubElement(element, "material")
        ET.SubElement(material, "diffuse").text = nums(rgba)
    return element


def _sdf_inertial(link: ET.Element, mass: float, size, xyz) -> None:
    inertia = CalcSpatialInertia(Box(*size), 1.0).CalcRotationalInertia().CopyToFullMatrix3()
    inertia *= mass / (size[0] * size[1] * size[2])
    inertial = ET.SubElement(link, "inertial")
    _sdf_pose(inertial, xyz)
    ET.SubElement(inertial, "mass").text = num(mass)
    element = ET.SubElement(inertial, "inertia")
    for key, value in (("ixx", inertia[0, 0]), ("ixy", 0), ("ixz", 0), ("iyy", inertia[1, 1]),
                       ("iyz", 0), ("izz", inertia[2, 2])):
        ET.SubElement(element, key).text = num(value)


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
        ET.SubElement(properties, "drake:mu_dynamic").text = num(FINGER_MU)
        ET.SubElement(properties, "drake:mu_static").text = num(FINGER_MU)
        ET.SubElement(properties, "drake:point_contact_stiffness").text = num(
            FINGER_STIFFNESS)
        ET.SubElement(properties, "drake:compliant_hydroelastic")
        ET.SubElement(properties, "drake:hydroelastic_modulus").text = num(
            FINGER_HYDROELASTIC_MODULUS)

        joint = ET.SubElement(model, "joint", name=f"{side}_finger_sliding_joint",
                              type="prismatic")
        ET.SubElement(joint, "parent").text = "gripper_base"
        ET.SubElement(joint, "child").text = f"{side}_finger"
        axis = ET.SubElement(joint, "axis")
        ET.SubElement(axis, "xyz").text = "0 1 0"
        limit = ET.SubElement(axis, "limit")
        ET.SubElement(limit, "lower").text = num(limits[0])
        ET.SubElement(limit, "upper").text = num(limits[1])
        ET.SubElement(limit, "effort").text = num(spec.grip_force)
        ET.SubElement(limit, "velocity").text = num(GRIPPER_FINGER_SPEED)
        ET.SubElement(ET.SubElement(axis, "dynamics"), "damping").text = num(
            spec.grip_force / GRIPPER_FINGER_SPEED)
        ET.SubElement(joint, "drake:controller_gains", p=num(GRIPPER_FINGER_P), d="0")

    tcp = ET.SubElement(model, "frame", name="gripper_tcp", attached_to="gripper_base")
    _sdf_pose(tcp, (0, 0, spec.tcp_offset))
    # The fingers meet at q = 0 (a joint limit): no point in colliding them with each other.
    group = ET.SubElement(model, "drake:collision_filter_group", name="fingers")
    for side in ("left", "right"):
        ET.SubElement(group, "drake:member").text = f"{side}_finger"
    ET.SubElement(group, "drake:ignored_collision_filter_group").text = "fingers"
    return xml_text(sdf, GENERATED)
