"""Small perturbations of a settled pile, to measure how stable the lift's labels are.

A label that flips when every part moves by a millimetre or the friction changes by a few
percent is a coin toss the CNN cannot learn. ``--repeat K`` re-runs each lift K-1 more times
under these perturbations and records how many of the K lifts said *tangled*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.geometry import GeometryId, ProximityProperties, RoleAssign, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import Body
from pydrake.systems.framework import Context


@dataclass(frozen=True)
class Perturbation:
    """Pose noise on every pile part and a friction factor on every contact."""

    position_sigma_m: float = 0.001
    angle_sigma_deg: float = 1.0
    friction_spread: float = 0.1
    """The friction factor is drawn uniformly from [1 - spread, 1 + spread]."""
    resettle_s: float = 0.05
    """Simulated time to let the parts push out of the overlaps the noise made."""


class FrictionScaler:
    """Scales the friction of every collision geometry, in one context, by one factor.

    Drake combines two geometries' friction as ``2ab / (a + b)``, so scaling every geometry's
    coefficients by ``c`` scales every contact's friction by exactly ``c``.
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

    def apply(self, root_context: Context, factor: float) -> None:
        """Set every geometry's friction to ``factor`` times its model value."""
        context = self.scene_graph.GetMyMutableContextFromRoot(root_context)
        source = self.plant.get_source_id()
        for geometry, props in self.original.items():
            friction = props.GetProperty("material", "coulomb_friction")
            scaled = ProximityProperties(props)
            scaled.UpdateProperty("material", "coulomb_friction", CoulombFriction(
                factor * friction.static_friction(), factor * friction.dynamic_friction()))
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
