"""SDFormat text for a one-link part: inertia, one visual mesh, capsule or convex-mesh collisions.

Contact: every collision gets ``drake:proximity_properties`` with steel-on-steel Coulomb
friction (static 0.5, dynamic 0.4) and is declared *rigid hydroelastic*. Under Drake's
``hydroelastic_with_fallback`` model, part-on-part and part-on-bin contacts (rigid against
rigid) fall back to point contact, which capsules handle well and fast, while the gripper's
compliant-hydroelastic finger pads get a contact patch. With point contact alone SAP softens a
~10 g wire's contact so much at 2 ms that the fingers crush through it and it drops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from tangle_drake.parts.mass import MassProperties
from tangle_drake.parts.wire import CapsuleSpec

MU_STATIC = 0.5
MU_DYNAMIC = 0.4
BODY_NAME = "body"
_MESH_RESOLUTION_HINT = 0.003  # m; only meshes Drake must tessellate use it (not convex pieces)


def _num(x: float) -> str:
    """Nine significant digits; round-off dust (below 1e-15) written as 0."""
    return "0" if abs(x) < 1e-15 else f"{x:.9g}"


def _vec(values) -> str:
    return " ".join(_num(float(v)) for v in values)


def _capsule_pose(capsule: CapsuleSpec) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre, roll-pitch-yaw turning +z (Drake's capsule axis) onto the capsule, and length."""
    axis = capsule.end - capsule.start
    length = float(np.linalg.norm(axis))
    u = axis / length
    pitch = math.acos(max(-1.0, min(1.0, float(u[2]))))
    yaw = math.atan2(float(u[1]), float(u[0]))
    return (capsule.start + capsule.end) / 2.0, np.array([0.0, pitch, yaw]), length


def _friction(resolution_hint: float) -> str:
    return (
        "<drake:proximity_properties>"
        f"<drake:mu_static>{_num(MU_STATIC)}</drake:mu_static>"
        f"<drake:mu_dynamic>{_num(MU_DYNAMIC)}</drake:mu_dynamic>"
        "<drake:rigid_hydroelastic/>"
        f"<drake:mesh_resolution_hint>{_num(resolution_hint)}</drake:mesh_resolution_hint>"
        "</drake:proximity_properties>"
    )


def write_part_sdf(
    path: Path,
    model_name: str,
    props: MassProperties,
    visual_uri: str,
    color: tuple[float, float, float, float],
    capsules: Sequence[CapsuleSpec] = (),
    convex_uris: Sequence[str] = (),
) -> None:
    """Write a self-contained SDF (mesh URIs relative to `path`) for one free rigid part."""
    i = props.inertia
    collisions = []
    for k, capsule in enumerate(capsules):
        centre, rpy, length = _capsule_pose(capsule)
        collisions.append(
            f'      <collision name="capsule_{k:02d}">\n'
            f"        <pose>{_vec(centre)} {_vec(rpy)}</pose>\n"
            f"        <geometry><capsule><radius>{_num(capsule.radius)}</radius>"
            f"<length>{_num(length)}</length></capsule></geometry>\n"
            f"        {_friction(capsule.radius)}\n"
            "      </collision>\n"
        )
    for k, uri in enumerate(convex_uris):
        collisions.append(
            f'      <collision name="convex_{k:02d}">\n'
            f"        <geometry><mesh><uri>{escape(uri)}</uri><drake:declare_convex/></mesh>"
            "</geometry>\n"
            f"        {_friction(_MESH_RESOLUTION_HINT)}\n"
            "      </collision>\n"
        )
    text = (
        '<?xml version="1.0"?>\n'
        '<sdf version="1.9" xmlns:drake="http://drake.mit.edu">\n'
        f'  <model name="{escape(model_name)}">\n'
        f'    <link name="{BODY_NAME}">\n'
        "      <inertial>\n"
        f"        <pose>{_vec(props.com)} 0 0 0</pose>\n"
        f"        <mass>{_num(props.mass)}</mass>\n"
        f"        <inertia><ixx>{_num(i[0, 0])}</ixx><iyy>{_num(i[1, 1])}</iyy>"
        f"<izz>{_num(i[2, 2])}</izz><ixy>{_num(i[0, 1])}</ixy><ixz>{_num(i[0, 2])}</ixz>"
        f"<iyz>{_num(i[1, 2])}</iyz></inertia>\n"
        "      </inertial>\n"
        '      <visual name="visual">\n'
        f"        <geometry><mesh><uri>{escape(visual_uri)}</uri></mesh></geometry>\n"
        f"        <material><diffuse>{_vec(color)}</diffuse></material>\n"
        "      </visual>\n"
        f"{''.join(collisions)}"
        "    </link>\n"
        "  </model>\n"
        "</sdf>\n"
    )
    path.write_text(text, encoding="utf-8")
