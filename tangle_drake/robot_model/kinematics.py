"""The Nextage's kinematic table (``shared/reference/nextage.md``), written down here and nowhere
else: joints, limits, link masses, the ``init_rtm`` pose and the simulated servos' gains."""

from __future__ import annotations

from dataclasses import dataclass, replace

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
"""All 15 joints, in the order of ``tangle_drake.robot_model.nextage.NEXTAGE_JOINTS``."""

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


WAIST_MASS = 5.0
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
