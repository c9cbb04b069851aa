"""The Nextage URDF, written from the kinematic table and the link geometry."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from tangle_drake.robot_model.kinematics import JOINT_DAMPING, JOINTS, WAIST_MASS, joint_gains
from tangle_drake.robot_model.links import (
    COLLISION_FILTER_GROUPS,
    COLORS,
    LINK_GEOMETRY,
    Primitive,
    link_inertia,
)
from tangle_drake.robot_model.writers import GENERATED, num, nums, xml_text


def _urdf_geometry(parent: ET.Element, p: Primitive) -> None:
    ET.SubElement(parent, "origin", xyz=nums(p.xyz), rpy=nums(p.rpy))
    geometry = ET.SubElement(parent, "geometry")
    if p.kind == "box":
        ET.SubElement(geometry, "box", size=nums(p.size))
    elif p.kind == "sphere":
        ET.SubElement(geometry, "sphere", radius=num(p.size[0]))
    elif p.kind == "cylinder":
        ET.SubElement(geometry, "cylinder", radius=num(p.size[0]), length=num(p.size[1]))
    else:
        ET.SubElement(geometry, "drake:capsule", radius=num(p.size[0]), length=num(p.size[1]))


def _urdf_link(robot: ET.Element, name: str, mass: float) -> None:
    primitives = LINK_GEOMETRY[name]
    com, inertia = link_inertia(primitives, mass)
    link = ET.SubElement(robot, "link", name=name)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=nums(com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=num(mass))
    ET.SubElement(inertial, "inertia", ixx=num(inertia[0, 0]), ixy=num(inertia[0, 1]),
                  ixz=num(inertia[0, 2]), iyy=num(inertia[1, 1]), iyz=num(inertia[1, 2]),
                  izz=num(inertia[2, 2]))
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
    for color, rgba in COLORS.items():
        material = ET.SubElement(robot, "material", name=color)
        ET.SubElement(material, "color", rgba=nums(rgba))
    _urdf_link(robot, "WAIST", WAIST_MASS)
    for j in JOINTS:
        _urdf_link(robot, j.child, j.child_mass)
    for j in JOINTS:
        joint = ET.SubElement(robot, "joint", name=j.name, type="revolute")
        ET.SubElement(joint, "parent", link=j.parent)
        ET.SubElement(joint, "child", link=j.child)
        ET.SubElement(joint, "origin", xyz=nums(j.xyz), rpy=nums(j.rpy))
        ET.SubElement(joint, "axis", xyz=nums(_AXES[j.axis]))
        ET.SubElement(joint, "limit", lower=num(j.lower), upper=num(j.upper),
                      effort=num(j.effort), velocity=num(j.velocity))
        ET.SubElement(joint, "dynamics", damping=num(JOINT_DAMPING))
    for j in JOINTS:
        p, d = joint_gains(j.name)
        transmission = ET.SubElement(robot, "transmission", name=f"{j.name}_trans")
        ET.SubElement(transmission, "type").text = "transmission_interface/SimpleTransmission"
        ET.SubElement(transmission, "joint", name=j.name)
        actuator = ET.SubElement(transmission, "actuator", name=f"{j.name}_motor")
        ET.SubElement(actuator, "drake:controller_gains", p=num(p), d=num(d))
    for group, members in COLLISION_FILTER_GROUPS.items():
        element = ET.SubElement(robot, "drake:collision_filter_group", name=group)
        for member in members:
            ET.SubElement(element, "drake:member", link=member)
        ET.SubElement(element, "drake:ignored_collision_filter_group", name=group)
    return xml_text(robot, GENERATED)
