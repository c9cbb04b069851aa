"""The planning plant: Nextage, gripper and bin, without the pile, for IK and collision checks.

The parts are left out on purpose: the gripper must touch them, the pile changes with every
pick, and the graspability index already keeps the fingers clear of the parts around the
target. What planning must keep clear of is the bin (walls, floor, stand) and the robot itself.

Configurations here are the plant's full ``q`` (17: the 15 Nextage joints and, between them in
Drake's depth-first order, the two finger joints); use :meth:`PlanningModel.full_q` and
:meth:`PlanningModel.nextage_q` to convert from and to the station's 15-vectors.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, GeometryId
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from tangle_drake.common.paths import make_parser
from tangle_drake.drivers.parallel_jaw import finger_positions
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.robot_model.nextage import LEFT_ARM, NEXTAGE_JOINTS, add_nextage_with_gripper
from tangle_drake.scenario import BinConfig
from tangle_drake.station.bin_model import bin_sdf

TCP_FRAME = "gripper_tcp"
"""The gripper model's frame at the tool centre T (:mod:`tangle_drake.robot_model.gripper`)."""

DISTANCE_HORIZON = 0.05
"""Geometry pairs farther apart than this are not measured, m (a cap that keeps checks fast)."""


class Clearance(NamedTuple):
    """Smallest signed distances at one configuration, m."""

    to_bin: float
    to_self: float


class PlanningModel:
    """A continuous-time plant of the robot, its gripper, the bin and the output tray (if
    any), with one context.

    Not thread-safe: every query moves the one context.
    """

    def __init__(self, bin_config: BinConfig, spec: GripperSpec = DEFAULT_GRIPPER,
                 tray: BinConfig | None = None) -> None:
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
        self.nextage, self.gripper = add_nextage_with_gripper(plant)
        make_parser(plant).AddModelsFromString(bin_sdf(bin_config), "sdf")
        if tray is not None:
            make_parser(plant).AddModelsFromString(bin_sdf(tray, "tray", stand=False), "sdf")
        plant.Finalize()
        # The wrist's last two links hold the gripper at fixed gaps along the tool axis
        # (7 mm, 30 mm): their pairs with it never close, and a clearance bound would trip
        # on them.
        wrist = plant.CollectRegisteredGeometries(
            [plant.GetBodyByName(name, self.nextage)
             for name in ("LARM_JOINT4_Link", "LARM_JOINT5_Link")])
        hand = plant.CollectRegisteredGeometries(
            [plant.get_body(index) for index in plant.GetBodyIndices(self.gripper)])
        scene_graph.collision_filter_manager().Apply(
            CollisionFilterDeclaration().ExcludeBetween(wrist, hand))
        self.plant: MultibodyPlant = plant
        self.spec = spec
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)
        self._scene_graph_context = scene_graph.GetMyContextFromRoot(self.context)
        self._query_port = scene_graph.get_query_output_port()
        self.tcp = plant.GetFrameByName(TCP_FRAME, self.gripper)
        self.arm_indices = np.array(
            [plant.GetJointByName(name, self.nextage).position_start()
             for name in NEXTAGE_JOINTS[LEFT_ARM]])
        """Where LARM_JOINT0..5 sit in the full q."""
        self.chest_index = plant.GetJointByName("CHEST_JOINT0", self.nextage).position_start()
        self.lower = plant.GetPositionLowerLimits()
        self.upper = plant.GetPositionUpperLimits()
        self._robot_geometries = self._geometries_of(self.nextage) | self._geometries_of(
            self.gripper)

    def _geometries_of(self, instance) -> set[GeometryId]:
        plant = self.plant
        return {geometry for index in plant.GetBodyIndices(instance)
                for geometry in plant.GetCollisionGeometriesForBody(plant.get_body(index))}

    def full_q(self, nextage_q: np.ndarray, width: float | None = None) -> np.ndarray:
        """The plant's q for the station's 15 Nextage joints and a gripper opening (default:
        fully open, the widest the fingers ever are while the arm moves near the bin)."""
        width = self.spec.max_opening if width is None else float(np.clip(
            width, 0.0, self.spec.max_opening))
        q = np.zeros(self.plant.num_positions())
        self.plant.SetPositionsInArray(self.nextage, np.asarray(nextage_q, float), q)
        self.plant.SetPositionsInArray(self.gripper, finger_positions(width, self.spec), q)
        return q

    def nextage_q(self, q: np.ndarray) -> np.ndarray:
        """The 15 Nextage joints of a full q, in ``robot.NEXTAGE_JOINTS`` order."""
        return self.plant.GetPositionsFromArray(self.nextage, q)

    def tcp_pose(self, q: np.ndarray) -> RigidTransform:
        """X_WT at configuration ``q``."""
        self.plant.SetPositions(self.plant_context, q)
        return self.tcp.CalcPoseInWorld(self.plant_context)

    def clearance(self, q: np.ndarray) -> Clearance:
        """How far the robot keeps from the bin and from itself at ``q`` (signed distances,
        negative for penetration), each capped at :data:`DISTANCE_HORIZON`."""
        self.plant.SetPositions(self.plant_context, q)
        query = self._query_port.Eval(self._scene_graph_context)
        to_bin = to_self = DISTANCE_HORIZON
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(DISTANCE_HORIZON):
            robot_a = pair.id_A in self._robot_geometries
            robot_b = pair.id_B in self._robot_geometries
            if robot_a and robot_b:
                to_self = min(to_self, pair.distance)
            elif robot_a or robot_b:
                to_bin = min(to_bin, pair.distance)
        return Clearance(to_bin, to_self)
