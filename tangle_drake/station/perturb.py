"""Small perturbations of the simulated physics: of a settled pile, to measure how stable the
lift's labels are, and of each physical pick, so that a model does not learn one simulator's
gripper.

A label that flips when every part moves by a millimetre or the friction changes by a few
percent is a coin toss the CNN cannot learn. ``--repeat K`` re-runs each lift K-1 more times
under these perturbations and records how many of the K lifts said *tangled*. A physical pick
(:class:`PickPhysics`) draws its friction, the finger pads' stiffness and a small error of the
grasp pose from a :class:`PhysicsSpread`, seeded per pick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.geometry import GeometryId, ProximityProperties, RoleAssign, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import Body
from pydrake.systems.framework import Context

from tangle_drake.common.errors import TangleDrakeError


@dataclass(frozen=True)
class Perturbation:
    """Pose noise on every pile part and a friction factor on every contact."""

    position_sigma_m: float = 0.001
    angle_sigma_deg: float = 1.0
    friction_spread: float = 0.1
    """The friction factor is drawn uniformly from [1 - spread, 1 + spread]."""
    resettle_s: float = 0.05
    """Simulated time to let the parts push out of the overlaps the noise made."""


@dataclass(frozen=True)
class PhysicsSpread:
    """How far each physical pick's physics is drawn from the model's (0: not at all)."""

    friction: float = 0.2
    """Every contact's friction is scaled by a factor uniform in [1 - f, 1 + f]."""
    pad_stiffness: float = 0.5
    """The finger pads' hydroelastic modulus is scaled by a factor log-uniform in
    [1 / (1 + s), 1 + s] (rubber pads vary, and wear)."""
    position_m: float = 0.002
    """Standard deviation of the grasp's error along each horizontal axis, m (the camera's
    calibration and the robot's repeatability)."""
    angle_deg: float = 3.0
    """...and of its error about the vertical, degrees."""

    def __post_init__(self) -> None:
        if not 0 <= self.friction < 1:
            raise TangleDrakeError(f"friction spread must lie in [0, 1), got {self.friction}")
        for name in ("pad_stiffness", "position_m", "angle_deg"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise TangleDrakeError(f"{name} spread must be >= 0, got {value!r}")


@dataclass(frozen=True)
class PickPhysics:
    """One pick's draw: contact factors, and the grasp pose's error."""

    friction: float = 1.0
    pad_stiffness: float = 1.0
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The grasp's error: world x and y, m, and about the vertical, degrees."""

    @classmethod
    def draw(cls, spread: PhysicsSpread, rng: np.random.Generator) -> PickPhysics:
        stiffness = np.log1p(spread.pad_stiffness)
        return cls(friction=float(rng.uniform(1 - spread.friction, 1 + spread.friction)),
                   pad_stiffness=float(np.exp(rng.uniform(-stiffness, stiffness))),
                   offset=(float(rng.normal(0, spread.position_m)),
                           float(rng.normal(0, spread.position_m)),
                           float(rng.normal(0, spread.angle_deg))))

    def to_dict(self) -> dict:
        return {"friction": round(self.friction, 6), "pad_stiffness": round(self.pad_stiffness, 6),
                "offset": [round(x, 6) for x in self.offset]}


def offset_pose(pose: np.ndarray, offset: tuple[float, float, float]) -> np.ndarray:
    """``pose`` (4x4, world) moved by ``offset``: x, y (m) and a turn about the vertical
    through its origin (degrees)."""
    dx, dy, angle = offset
    moved = np.array(pose, dtype=float)
    moved[:3, :3] = RotationMatrix.MakeZRotation(np.radians(angle)).matrix() @ moved[:3, :3]
    moved[:2, 3] += (dx, dy)
    return moved


class ContactScaler:
    """Scales, in one context, the friction of every collision geometry and the stiffness of
    every compliant one (the finger pads: the only geometries with a hydroelastic modulus).

    Drake combines two geometries' friction as ``2ab / (a + b)``, so scaling every geometry's
    coefficients by ``c`` scales every contact's friction by exactly ``c``. Restoring a saved
    context restores both (SceneGraph keeps geometry properties in the context's parameters).
    """

    def __init__(self, plant: MultibodyPlant, scene_graph: SceneGraph) -> None:
        self.plant = plant
        self.scene_graph = scene_graph
        inspector = scene_graph.model_inspector()
        self.original: dict[GeometryId, ProximityProperties] = {}
        for geometry in inspector.GetAllGeometryIds():
            props = inspector.GetProximityProperties(geometry)
            if props is not None and props.HasProperty("material", "coulomb_friction"):
                self.original[geometry] = ProximityProperties(props)

    def apply(self, root_context: Context, friction: float = 1.0,
              pad_stiffness: float = 1.0) -> None:
        """Set every geometry's friction, and every compliant one's hydroelastic modulus, to
        these factors times the model's values."""
        context = self.scene_graph.GetMyMutableContextFromRoot(root_context)
        source = self.plant.get_source_id()
        for geometry, props in self.original.items():
            coulomb = props.GetProperty("material", "coulomb_friction")
            scaled = ProximityProperties(props)
            scaled.UpdateProperty("material", "coulomb_friction", CoulombFriction(
                friction * coulomb.static_friction(), friction * coulomb.dynamic_friction()))
            if props.HasProperty("hydroelastic", "hydroelastic_modulus"):
                modulus = props.GetProperty("hydroelastic", "hydroelastic_modulus")
                scaled.UpdateProperty("hydroelastic", "hydroelastic_modulus",
                                      pad_stiffness * modulus)
            self.scene_graph.AssignRole(context, source, geometry, scaled, RoleAssign.kReplace)


def jiggle_parts(plant: MultibodyPlant, plant_context: Context, bodies: list[Body],
                 perturbation: Perturbation, rng: np.random.Generator) -> None:
    """Move every part by Gaussian noise in position and orientation, velocities zeroed."""
    for body in bodies:
        X = body.EvalPoseInWorld(plant_context)
        axis = rng.normal(size=3)
        angle = np.radians(perturbation.angle_sigma_deg) * rng.normal()
        dR = RotationMatrix(AngleAxis(angle, axis / np.linalg.norm(axis)))
        shift = rng.normal(scale=perturbation.position_sigma_m / np.sqrt(3), size=3)
        plant.SetFreeBodyPose(plant_context, body,
                              RigidTransform(dR @ X.rotation(), X.translation() + shift))
        plant.SetFreeBodySpatialVelocity(plant_context, body, SpatialVelocity.Zero())
