"""The simulated station: the scenario's models, bin, ground, pile and cameras in one plant, and
each model's simulated driver around it.

The plant is built in a fixed order (directives, bin, ground, pile, tray), so the same scenario
gives the same plant, and contact physics (which is chaotic) the same results, every time. Drivers
come from ``scenario.model_drivers`` (:mod:`tangle_drake.drivers`); every model with actuators
must have one, or its servos would be off and it would fall.
"""

from __future__ import annotations

import itertools

import numpy as np
from pydrake.geometry import Box, Meshcat, MeshcatVisualizer, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import ModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import Body, ModelInstanceIndex
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.sensors import CameraConfig

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import make_parser
from tangle_drake.drivers import camera, force_torque
from tangle_drake.drivers.registry import driver_module
from tangle_drake.parts import load_part
from tangle_drake.scenario import Scenario
from tangle_drake.station.bin_model import bin_boxes, bin_sdf

PLANT_NAME = "plant"
PILE_SCOPE = "pile"
SIM_ONLY_PREFIX = "sim."
GROUND_FRICTION = CoulombFriction(0.5, 0.4)


class SimulatedStation(Diagram):
    """The simulated station diagram, with what tools and tests need of its insides.

    The accessors take the context of the root diagram the station is part of (the station's
    own when it is simulated alone). Controllers must not use them: they see ports only.
    """

    hardware = False

    def __init__(self, builder: DiagramBuilder, scenario: Scenario, plant: MultibodyPlant,
                 scene_graph: SceneGraph) -> None:
        super().__init__()
        builder.BuildInto(self)
        self.set_name("station")
        self.scenario = scenario
        self._plant = plant
        self._scene_graph = scene_graph
        self._pile = part_bodies(plant)

    @property
    def plant(self) -> MultibodyPlant:
        return self._plant

    @property
    def scene_graph(self) -> SceneGraph:
        return self._scene_graph

    @property
    def pile_bodies(self) -> list[Body]:
        """The body of each pile part, in pile order."""
        return list(self._pile)

    def plant_context(self, root: Context) -> Context:
        return self._plant.GetMyContextFromRoot(root)

    def mutable_plant_context(self, root: Context) -> Context:
        return self._plant.GetMyMutableContextFromRoot(root)

    def plant_state(self, root: Context) -> np.ndarray:
        """The plant's positions and velocities."""
        return self._plant.GetPositionsAndVelocities(self.plant_context(root))

    def set_plant_state(self, root: Context, state: np.ndarray) -> None:
        self._plant.SetPositionsAndVelocities(self.mutable_plant_context(root), state)

    def part_poses(self, root: Context) -> np.ndarray:
        """(N, 4, 4) world poses of the pile's parts."""
        context = self.plant_context(root)
        return np.array([b.EvalPoseInWorld(context).GetAsMatrix4() for b in self._pile])

    def hold_still(self, context: Context) -> None:
        """Fix every driver's command input to hold its model where it is now.

        For jobs that run the station without a controller (making a pile, rendering a
        scene); ``context`` is the station's own, also where the station is part of a larger
        diagram. Also primes the command interpolators so the first step commands no jump.
        """
        plant_context = self.GetSubsystemContext(self._plant, context)
        for name, config in self.scenario.model_drivers.items():
            command = driver_module(config).held_command(self._plant, plant_context, name)
            interpolator = self.GetSubsystemByName(f"{name}.command_interpolator")
            interpolator.set_initial_position(
                self.GetMutableSubsystemContext(interpolator, context), command)
            self.GetInputPort(f"{name}.position").FixValue(context, command)


def pile_model_name(index: int) -> str:
    """Scope of the ``index``-th pile part's model instance (``pile_03::u_hook``)."""
    return f"{PILE_SCOPE}_{index:02d}"


def add_ground(plant: MultibodyPlant) -> None:
    """The floor the robot stands on (world z = 0): a thin box, as half spaces make
    deformable-contact warnings."""
    plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform([0, 0, -0.05]),
                                    Box(10, 10, 0.1), "ground", GROUND_FRICTION)


def add_pile_parts(plant: MultibodyPlant, scenario: Scenario) -> list[ModelInstanceIndex]:
    """Add every part the scenario's pile asks for (before ``Finalize``)."""
    instances: list[ModelInstanceIndex] = []
    for entry in scenario.pile.parts:
        model = load_part(entry.part, mesh_scale=entry.mesh_scale)
        for _ in range(entry.count):
            parser = make_parser(plant, pile_model_name(len(instances)))
            instances.extend(parser.AddModels(str(model.sdf_path)))
    return instances


def pile_instances(plant: MultibodyPlant) -> list[ModelInstanceIndex]:
    """The pile's parts in a finalized station plant, in the order they were added."""
    instances = [ModelInstanceIndex(i) for i in range(plant.num_model_instances())]
    return [i for i in instances if plant.GetModelInstanceName(i).startswith(PILE_SCOPE + "_")]


def part_bodies(plant: MultibodyPlant) -> list[Body]:
    """The single body of each pile part, in pile order."""
    return [plant.get_body(plant.GetBodyIndices(i)[0]) for i in pile_instances(plant)]


def build_simulated_station(scenario: Scenario,
                            meshcat: Meshcat | None = None) -> SimulatedStation:
    """The simulated station for ``scenario`` (see :mod:`tangle_drake.station` for its ports)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    plant.set_name(PLANT_NAME)
    parser = make_parser(plant)
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    parser.AddModelsFromString(bin_sdf(scenario.bin), "sdf")
    add_ground(plant)
    add_pile_parts(plant, scenario)
    if scenario.tray is not None:  # last: the pile's bodies and geometries keep their order
        _check_tray_out_of_view(scenario)
        parser.AddModelsFromString(bin_sdf(scenario.tray, "tray", stand=False), "sdf")
    plant.Finalize()
    _check_drivers(plant, scenario)
    for name, config in scenario.model_drivers.items():
        driver_module(config).set_home(plant, name, config, scenario)
    _set_initial_positions(plant, scenario)
    for name, config in scenario.model_drivers.items():
        driver_module(config).add_simulated(builder, plant, name, config, scenario)
    for name, sensor in scenario.force_torque_sensors.items():
        force_torque.add_simulated(builder, plant, name, sensor)

    camera.add_simulated(builder, scene_graph, scenario, SIM_ONLY_PREFIX)
    for config in scenario.view_cameras:
        _add_view_camera(builder, scene_graph, config)
    builder.ExportOutput(plant.get_state_output_port(), f"{SIM_ONLY_PREFIX}plant_state")
    builder.ExportOutput(plant.get_body_poses_output_port(), f"{SIM_ONLY_PREFIX}body_poses")
    builder.ExportOutput(scene_graph.get_query_output_port(), f"{SIM_ONLY_PREFIX}query_object")
    builder.ExportOutput(plant.get_contact_results_output_port(),
                         f"{SIM_ONLY_PREFIX}contact_results")
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    return SimulatedStation(builder, scenario, plant, scene_graph)


def _check_drivers(plant: MultibodyPlant, scenario: Scenario) -> None:
    """Every driver names a model of the directives, and every actuated model has a driver."""
    for name in scenario.model_drivers:
        if not plant.HasModelInstanceNamed(name):
            raise TangleDrakeError(f"scenario field 'model_drivers.{name}' names no model the "
                                   "directives add")
    for index in range(plant.num_model_instances()):
        instance = ModelInstanceIndex(index)
        name = plant.GetModelInstanceName(instance)
        if plant.num_actuators(instance) and name not in scenario.model_drivers:
            raise TangleDrakeError(f"model {name!r} has actuators but no entry in the "
                                   "scenario's model_drivers (e.g. !NextageDriver, "
                                   "!GantryDriver, !ParallelJawDriver)")


def _check_tray_out_of_view(scenario: Scenario) -> None:
    """The tray must not show in the top camera's image: perception reads the whole depth
    image's levels, and a tray in view changes the graspability index's candidates."""
    tray = scenario.tray
    model = camera.camera_model(scenario)
    width, height = model.intrinsics.width, model.intrinsics.height
    for name, (center, size) in bin_boxes(tray).items():
        if name == "stand":  # the tray has none
            continue
        for corner in itertools.product(*[(c - s / 2, c + s / 2) for c, s in zip(
                center, size, strict=True)]):
            u, v, depth = model.world_to_pixel(np.array(corner))
            if depth > 0 and 0 <= u < width and 0 <= v < height:
                raise TangleDrakeError(
                    f"scenario field 'tray': the tray shows in the top camera's view (its "
                    f"corner {np.round(corner, 3).tolist()} at pixel ({u:.0f}, {v:.0f})); "
                    "move it further from the bin")


def _set_initial_positions(plant: MultibodyPlant, scenario: Scenario) -> None:
    for name, value in scenario.initial_positions.items():
        if not plant.HasJointNamed(name):
            raise TangleDrakeError(f"scenario field 'initial_positions': no joint named {name!r}")
        plant.GetJointByName(name).set_default_positions([value])


def _add_view_camera(builder: DiagramBuilder, scene_graph: SceneGraph,
                     config: CameraConfig) -> None:
    if config.X_PB.base_frame not in (None, "", "world"):
        raise TangleDrakeError(f"view camera {config.name!r}: X_PB must be in the world frame")
    sensor = camera.add_sensor(builder, scene_graph, config, config.X_PB.GetDeterministicValue())
    builder.ExportOutput(sensor.color_image_output_port(),
                         f"{SIM_ONLY_PREFIX}{config.name}.rgb_image")
