"""Freezing the parts of a settled pile that a lift cannot reach: both labellers' main saving.

A lift at one spot of a 15-part pile moves a few parts; the others lie still, yet every plant
step computes their contacts with each other and with the bin (Drake's point-contact pairs,
each with its Jacobians, were a third of a physical pick's time) and hands them to the contact
solver. :class:`PileFreeze` locks those parts (locked, they are no unknowns of the solver) and
takes their contacts with each other and with the bin out of the geometry queries with a
transient collision filter in the context: two locked bodies, or a locked body and the welded
bin, can exert nothing on each other, so only the queries go. Their contacts with the parts
that stay free are kept: a dragged part meets an immovable neighbour instead of a movable one.

With any body locked, Drake crashes on a contact that involves geometry of the world body itself
(RobotLocomotion/drake#24773): here the ground, 0.8-0.9 m below the bin's floor. So only parts
inside the bin are frozen, and while any is, the ground's contacts leave the queries too: a part
knocked out of the bin during the lift falls through the floor instead of crashing the run (it
plays no part in what the lift brings up either way). Without a freeze nothing changes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometrySet, Role, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Body
from pydrake.systems.framework import Context

from tangle_drake.scenario import BinConfig
from tangle_drake.station.bin_model import BIN_MODEL, inside_bin

FREEZE_BEYOND_RADII = 2.0
"""Parts whose centre lies farther than this many bounding radii (horizontally) from the
lifted target's are frozen: the target rises straight up and every part lies within one
bounding radius of its centre, so it can never touch them; only a part it drags along could,
and would then meet an immovable neighbour instead of a movable one."""


def parts_beyond(centres: np.ndarray, bin_config: BinConfig, point_xy: np.ndarray,
                 distance: float) -> list[int]:
    """Indices of the parts whose centre (rows of ``centres``, (N, 3) world) lies farther than
    ``distance`` horizontally from ``point_xy`` and inside the bin: those a lift there cannot
    reach and that may be frozen."""
    gaps = np.linalg.norm(centres[:, :2] - np.asarray(point_xy)[:2], axis=1)
    return [int(n) for n in np.flatnonzero((gaps > distance) & inside_bin(bin_config, centres))]


class PileFreeze:
    """Locks chosen pile parts and filters their contacts with each other and the bin, in one
    context, until :meth:`thaw`. Built once per plant, reused lift after lift."""

    def __init__(self, plant: MultibodyPlant, scene_graph: SceneGraph,
                 bodies: Sequence[Body]) -> None:
        self.plant = plant
        self.scene_graph = scene_graph
        self.bodies = list(bodies)
        self._geometries = [plant.GetCollisionGeometriesForBody(b) for b in self.bodies]
        self._bin_geometries = [
            geometry for index in plant.GetBodyIndices(plant.GetModelInstanceByName(BIN_MODEL))
            for geometry in plant.GetCollisionGeometriesForBody(plant.get_body(index))]
        self._world_geometries = plant.GetCollisionGeometriesForBody(plant.world_body())
        self._all_geometries = scene_graph.model_inspector().GetAllGeometryIds(Role.kProximity)
        self._frozen: list[int] = []
        self._filter = None

    @property
    def frozen(self) -> list[int]:
        """Pile indices of the parts frozen now."""
        return list(self._frozen)

    def centres(self, root_context: Context) -> np.ndarray:
        """Every pile part's centre in the world, (N, 3)."""
        plant_context = self.plant.GetMyContextFromRoot(root_context)
        return np.array([b.EvalPoseInWorld(plant_context).translation() for b in self.bodies])

    def speeds(self, root_context: Context) -> np.ndarray:
        """Every pile part's translational speed, (N,) m/s."""
        plant_context = self.plant.GetMyContextFromRoot(root_context)
        return np.array([np.linalg.norm(b.EvalSpatialVelocityInWorld(plant_context)
                                        .translational()) for b in self.bodies])

    def freeze(self, root_context: Context, parts: Sequence[int]) -> None:
        """Lock ``parts`` (pile indices) where they lie, at rest, and drop their contacts with
        each other and with the bin from the geometry queries."""
        if self._frozen:
            raise RuntimeError("PileFreeze.freeze: thaw the parts frozen before")
        if not parts:
            return
        plant_context = self.plant.GetMyMutableContextFromRoot(root_context)
        for n in parts:
            self.bodies[n].Lock(plant_context)
        geometries = [g for n in parts for g in self._geometries[n]] + self._bin_geometries
        manager = self.scene_graph.collision_filter_manager(
            self.scene_graph.GetMyMutableContextFromRoot(root_context))
        declaration = CollisionFilterDeclaration().ExcludeWithin(GeometrySet(geometries))
        if self._world_geometries:
            declaration.ExcludeBetween(GeometrySet(self._world_geometries),
                                       GeometrySet(self._all_geometries))
        self._filter = manager.ApplyTransient(declaration)
        self._frozen = list(parts)

    def thaw(self, root_context: Context) -> None:
        """Unlock the frozen parts and restore their contacts (nothing if none is frozen)."""
        if not self._frozen:
            return
        plant_context = self.plant.GetMyMutableContextFromRoot(root_context)
        for n in self._frozen:
            self.bodies[n].Unlock(plant_context)
        manager = self.scene_graph.collision_filter_manager(
            self.scene_graph.GetMyMutableContextFromRoot(root_context))
        manager.RemoveDeclaration(self._filter)
        self._frozen, self._filter = [], None
