"""One builder for the station: the robot, gripper, bin, pile and top camera as one Drake diagram.

Ports are named ``{model}.{port}`` like Drake's ``hardware_sim``, so the pick diagram wired to a
simulated station is the one wired to the hardware station (issue 7 adds ``hardware=True``):

=========================== ====== =====================================================
port                        dir    meaning
=========================== ====== =====================================================
``nextage.position``        in     commanded joint positions, ``robot.NEXTAGE_JOINTS`` order
``nextage.position_measured`` out  measured joint positions
``nextage.state_measured``  out    measured [positions, velocities]
``gripper.position``        in     commanded opening width between the finger pads, m
``gripper.state_measured``  out    measured [width, width rate]
``camera.rgb_image``        out    top camera colour image
``camera.depth_image``      out    top camera depth, metres along the optical axis (32F)
=========================== ====== =====================================================

Simulation-only ports, which no real robot has, start with ``sim.``: ``sim.plant_state``,
``sim.body_poses``, ``sim.query_object``, ``sim.contact_results``, ``sim.camera.label_image``,
and ``sim.{name}.rgb_image`` for each of the scenario's view cameras.
Controllers must not read them; benchmarks and tests may.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import (
    Box,
    MakeRenderEngineVtk,
    Meshcat,
    MeshcatVisualizer,
    RenderEngineVtkParams,
)
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import ModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmBuses
from pydrake.systems.primitives import MatrixGain, StateInterpolatorWithDiscreteDerivative
from pydrake.systems.sensors import CameraConfig, RgbdSensor

from tangle_drake.bin_model import bin_sdf
from tangle_drake.camera import CameraIntrinsics, CameraModel, top_view_pose
from tangle_drake.errors import TangleDrakeError
from tangle_drake.parts import load_part
from tangle_drake.paths import make_parser
from tangle_drake.robot import HOME
from tangle_drake.scenario import Scenario

PLANT_NAME = "plant"
PILE_SCOPE = "pile"
SIM_ONLY_PREFIX = "sim."

# Width/velocity of the two symmetric fingers from the gripper's [q_l, q_r, v_l, v_r] state.
_FINGERS_TO_WIDTH = np.array([[-1.0, 1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 1.0]])


def camera_model(scenario: Scenario) -> CameraModel:
    """The top camera's intrinsics and world pose, computed from the scenario alone.

    Perception needs these both in simulation and on hardware, where they come from calibration
    written into the same scenario.
    """
    _, depth = scenario.camera.MakeCameras()
    info = depth.core().intrinsics()
    intrinsics = CameraIntrinsics(info.width(), info.height(), info.focal_x(), info.focal_y(),
                                  info.center_x(), info.center_y())
    X_WC = camera_body_pose(scenario) @ depth.core().sensor_pose_in_camera_body()
    return CameraModel(intrinsics, X_WC.GetAsMatrix4())


def camera_body_pose(scenario: Scenario) -> RigidTransform:
    """X_WB of the top camera's body (its depth sensor sits at ``camera.X_BD`` in it)."""
    if scenario.camera_height is not None:
        target = [*scenario.bin.center, scenario.bin.floor_height]
        return RigidTransform(top_view_pose(np.array(target), scenario.camera_height))
    if scenario.camera.X_PB.base_frame not in (None, "", "world"):
        raise TangleDrakeError("scenario field 'camera.X_PB.base_frame' must be the world: "
                               "the top camera is fixed above the bin")
    return scenario.camera.X_PB.GetDeterministicValue()


def pile_model_name(index: int) -> str:
    """Scope of the ``index``-th pile part's model instance (``pile_03::u_hook``)."""
    return f"{PILE_SCOPE}_{index:02d}"


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


def build_station(scenario: Scenario, meshcat: Meshcat | None = None, hardware: bool = False,
                  lcm_buses: LcmBuses | None = None) -> Diagram:
    """The simulated station diagram for ``scenario`` (see the module docstring for its ports).

    ``hardware=True`` gives the hardware station instead: the same ports over the robot's LCM
    drivers (``tangle_drake.hardware.station``; ``lcm_buses`` overrides the scenario's buses,
    and ``meshcat`` is not used).
    """
    if hardware:
        from tangle_drake.hardware.station import build_hardware_station

        return build_hardware_station(scenario, lcm_buses)
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    plant.set_name(PLANT_NAME)

    parser = make_parser(plant)
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    parser.AddModelsFromString(bin_sdf(scenario.bin), "sdf")
    # The floor the robot stands on: a thin box, as half spaces make deformable-contact warnings.
    plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform([0, 0, -0.05]),
                                    Box(10, 10, 0.1), "ground", CoulombFriction(0.5, 0.4))
    add_pile_parts(plant, scenario)
    plant.Finalize()
    _set_initial_positions(plant, scenario)

    if plant.HasModelInstanceNamed("nextage"):
        _export_arm(builder, plant, plant.GetModelInstanceByName("nextage"))
    if plant.HasModelInstanceNamed("gripper"):
        _export_gripper(builder, plant, plant.GetModelInstanceByName("gripper"))
    _add_camera(builder, scene_graph, scenario)
    for config in scenario.view_cameras:
        _add_view_camera(builder, scene_graph, config)

    builder.ExportOutput(plant.get_state_output_port(), "sim.plant_state")
    builder.ExportOutput(plant.get_body_poses_output_port(), "sim.body_poses")
    builder.ExportOutput(scene_graph.get_query_output_port(), "sim.query_object")
    builder.ExportOutput(plant.get_contact_results_output_port(), "sim.contact_results")
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    diagram.set_name("station")
    return diagram


def _set_initial_positions(plant: MultibodyPlant, scenario: Scenario) -> None:
    if plant.HasModelInstanceNamed("nextage"):
        plant.SetDefaultPositions(plant.GetModelInstanceByName("nextage"), HOME)
    for name, value in scenario.initial_positions.items():
        if not plant.HasJointNamed(name):
            raise TangleDrakeError(f"scenario field 'initial_positions': no joint named {name!r}")
        plant.GetJointByName(name).set_default_positions([value])


def _export_arm(builder: DiagramBuilder, plant: MultibodyPlant,
                instance: ModelInstanceIndex) -> None:
    n = plant.num_positions(instance)
    # Position commands become desired [q, v] for the plant's joint PD controllers; the
    # velocity is the command's discrete derivative, as Drake's iiwa driver does it.
    interpolator = builder.AddNamedSystem(
        "nextage.command_interpolator",
        StateInterpolatorWithDiscreteDerivative(n, plant.time_step(),
                                                suppress_initial_transient=True))
    builder.Connect(interpolator.get_output_port(), plant.get_desired_state_input_port(instance))
    builder.ExportInput(interpolator.get_input_port(), "nextage.position")
    position = builder.AddNamedSystem(
        "nextage.position_selector", MatrixGain(np.hstack([np.eye(n), np.zeros((n, n))])))
    builder.Connect(plant.get_state_output_port(instance), position.get_input_port())
    builder.ExportOutput(position.get_output_port(), "nextage.position_measured")
    builder.ExportOutput(plant.get_state_output_port(instance), "nextage.state_measured")


def _export_gripper(builder: DiagramBuilder, plant: MultibodyPlant,
                    instance: ModelInstanceIndex) -> None:
    if plant.num_positions(instance) != 2:
        raise TangleDrakeError("the gripper model must have exactly two finger joints")
    interpolator = builder.AddNamedSystem(
        "gripper.command_interpolator",
        StateInterpolatorWithDiscreteDerivative(1, plant.time_step(),
                                                suppress_initial_transient=True))
    # [width, width rate] -> [q_l, q_r, v_l, v_r] with the fingers moving symmetrically.
    to_fingers = builder.AddNamedSystem(
        "gripper.width_to_fingers", MatrixGain(0.5 * np.array([[-1, 0], [1, 0], [0, -1], [0, 1]])))
    builder.Connect(interpolator.get_output_port(), to_fingers.get_input_port())
    builder.Connect(to_fingers.get_output_port(), plant.get_desired_state_input_port(instance))
    builder.ExportInput(interpolator.get_input_port(), "gripper.position")
    width = builder.AddNamedSystem("gripper.state_to_width", MatrixGain(_FINGERS_TO_WIDTH))
    builder.Connect(plant.get_state_output_port(instance), width.get_input_port())
    builder.ExportOutput(width.get_output_port(), "gripper.state_measured")


def _add_sensor(builder: DiagramBuilder, scene_graph, config: CameraConfig,
                X_WB: RigidTransform) -> RgbdSensor:
    if not scene_graph.HasRenderer(config.renderer_name):
        scene_graph.AddRenderer(config.renderer_name,
                                MakeRenderEngineVtk(RenderEngineVtkParams()))
    color, depth = config.MakeCameras()
    sensor = builder.AddNamedSystem(
        config.name, RgbdSensor(scene_graph.world_frame_id(), X_WB, color, depth))
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return sensor


def _add_view_camera(builder: DiagramBuilder, scene_graph, config: CameraConfig) -> None:
    if config.X_PB.base_frame not in (None, "", "world"):
        raise TangleDrakeError(f"view camera {config.name!r}: X_PB must be in the world frame")
    sensor = _add_sensor(builder, scene_graph, config, config.X_PB.GetDeterministicValue())
    builder.ExportOutput(sensor.color_image_output_port(),
                         f"{SIM_ONLY_PREFIX}{config.name}.rgb_image")


def _add_camera(builder: DiagramBuilder, scene_graph, scenario: Scenario) -> None:
    sensor = _add_sensor(builder, scene_graph, scenario.camera, camera_body_pose(scenario))
    builder.ExportOutput(sensor.color_image_output_port(), "camera.rgb_image")
    builder.ExportOutput(sensor.depth_image_32F_output_port(), "camera.depth_image")
    builder.ExportOutput(sensor.label_image_output_port(), "sim.camera.label_image")


def hold_robot_still(station: Diagram, context: Context) -> None:
    """Fix the robot's command inputs to its current pose (arm still, gripper as it is).

    The robot is the Nextage, or the free-floating gripper's gantry
    (:mod:`tangle_drake.floating_gripper`), whichever the station has.

    For jobs that use the station without a controller: making a pile, rendering a scene.
    Also primes the command interpolators so the first step commands no jump.
    """
    plant: MultibodyPlant = station.GetSubsystemByName(PLANT_NAME)
    plant_context = plant.GetMyContextFromRoot(context)
    for model, width_of in (("nextage", None), ("gantry", None),
                            ("gripper", _FINGERS_TO_WIDTH[0])):
        if not plant.HasModelInstanceNamed(model):
            continue
        q = plant.GetPositions(plant_context, plant.GetModelInstanceByName(model))
        command = q if width_of is None else np.array([width_of[:2] @ q])
        interpolator = station.GetSubsystemByName(f"{model}.command_interpolator")
        interpolator.set_initial_position(
            interpolator.GetMyMutableContextFromRoot(context), command)
        station.GetInputPort(f"{model}.position").FixValue(context, command)
