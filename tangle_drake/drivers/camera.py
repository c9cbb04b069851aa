"""The top camera, a scenario entry like the drivers: its pose, and every branch of it.

Simulation: an ``RgbdSensor`` fixed in the world above the bin (``camera.rgb_image``,
``camera.depth_image`` in metres, ``sim.camera.label_image``; ``camera.image_time`` is the
time, as it renders on demand). Hardware station: one
``lcmt_image_array`` per frame with a colour and a depth image, on channel
``DRAKE_RGBD_CAMERA_IMAGES_{name}`` of the camera's ``lcm_bus`` (Drake's own convention),
unpacked into the same two ports, and ``camera.image_time``: when the last image with a new
stamp arrived. Robot side: the simulated images sent every
``hardware.camera_period`` in the scenario's ``hardware.depth_format``.
"""

from __future__ import annotations

import numpy as np
from drake import lcmt_image_array
from pydrake.geometry import MakeRenderEngineVtk, RenderEngineVtkParams, SceneGraph
from pydrake.lcm import DrakeLcmInterface
from pydrake.math import RigidTransform
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.lcm import LcmSubscriberSystem
from pydrake.systems.sensors import (
    CameraConfig,
    ImageToLcmImageArrayT,
    PixelType,
    RgbdSensor,
)

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.lcm_io.images import (
    DepthToMillimetres,
    ImageArrayToImages,
    ImageArrival,
    SimulatedImageTime,
)
from tangle_drake.lcm_io.lcm_systems import add_checked_subscriber, add_publisher
from tangle_drake.lcm_io.messages import check_image_array
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.drivers import camera_channel

PORT_PREFIX = "camera"
"""The top camera's ports are ``camera.*`` whatever its name: perception reads them."""


def camera_body_pose(scenario: Scenario) -> RigidTransform:
    """X_WB of the top camera's body (its depth sensor sits at ``camera.X_BD`` in it)."""
    if scenario.camera_height is not None:
        target = [*scenario.bin.center, scenario.bin.floor_height]
        return RigidTransform(top_view_pose(np.array(target), scenario.camera_height))
    if scenario.camera.X_PB.base_frame not in (None, "", "world"):
        raise TangleDrakeError("scenario field 'camera.X_PB.base_frame' must be the world: "
                               "the top camera is fixed above the bin")
    return scenario.camera.X_PB.GetDeterministicValue()


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


def add_sensor(builder: DiagramBuilder, scene_graph: SceneGraph, config: CameraConfig,
               X_WB: RigidTransform) -> RgbdSensor:
    """An ``RgbdSensor`` for ``config`` at ``X_WB`` in the world, with its renderer."""
    if not scene_graph.HasRenderer(config.renderer_name):
        scene_graph.AddRenderer(config.renderer_name,
                                MakeRenderEngineVtk(RenderEngineVtkParams()))
    color, depth = config.MakeCameras()
    sensor = builder.AddNamedSystem(
        config.name, RgbdSensor(scene_graph.world_frame_id(), X_WB, color, depth))
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    return sensor


def add_simulated(builder: DiagramBuilder, scene_graph: SceneGraph, scenario: Scenario,
                  sim_prefix: str) -> None:
    """The top camera's ``camera.*`` ports, and its label image under ``sim_prefix``."""
    sensor = add_sensor(builder, scene_graph, scenario.camera, camera_body_pose(scenario))
    builder.ExportOutput(sensor.color_image_output_port(), f"{PORT_PREFIX}.rgb_image")
    builder.ExportOutput(sensor.depth_image_32F_output_port(), f"{PORT_PREFIX}.depth_image")
    builder.ExportOutput(sensor.label_image_output_port(),
                         f"{sim_prefix}{PORT_PREFIX}.label_image")
    clock = builder.AddNamedSystem(f"{PORT_PREFIX}.image_clock", SimulatedImageTime())
    builder.ExportOutput(clock.get_output_port(), f"{PORT_PREFIX}.image_time")


def add_interface(builder: DiagramBuilder, lcm: DrakeLcmInterface,
                  scenario: Scenario) -> LcmSubscriberSystem:
    """The camera's image messages as ``camera.rgb_image`` and ``camera.depth_image``."""
    config = scenario.camera
    subscriber = add_checked_subscriber(
        builder, f"{PORT_PREFIX}.images", camera_channel(config), lcmt_image_array,
        check_image_array(config.width, config.height), lcm)
    images = builder.AddNamedSystem(f"{PORT_PREFIX}.to_images", ImageArrayToImages())
    builder.Connect(subscriber.get_output_port(), images.get_input_port())
    builder.ExportOutput(images.GetOutputPort("color_image"), f"{PORT_PREFIX}.rgb_image")
    builder.ExportOutput(images.GetOutputPort("depth_image"), f"{PORT_PREFIX}.depth_image")
    arrival = builder.AddNamedSystem(f"{PORT_PREFIX}.arrival",
                                     ImageArrival(scenario.hardware.command_period))
    builder.Connect(subscriber.get_output_port(), arrival.get_input_port())
    builder.ExportOutput(arrival.get_output_port(), f"{PORT_PREFIX}.image_time")
    return subscriber


def add_robot_side(builder: DiagramBuilder, station: Diagram, lcm: DrakeLcmInterface,
                   scenario: Scenario) -> None:
    """Send ``station``'s colour and depth images as one ``lcmt_image_array``."""
    hardware = scenario.hardware
    images = builder.AddNamedSystem(f"{PORT_PREFIX}.image_array",
                                    ImageToLcmImageArrayT(do_compress=False))
    builder.Connect(station.GetOutputPort(f"{PORT_PREFIX}.rgb_image"),
                    images.DeclareImageInputPort[PixelType.kRgba8U]("color"))
    depth = station.GetOutputPort(f"{PORT_PREFIX}.depth_image")
    if hardware.depth_format == "16U":
        millimetres = builder.AddNamedSystem(f"{PORT_PREFIX}.depth_to_mm", DepthToMillimetres())
        builder.Connect(depth, millimetres.get_input_port())
        depth = millimetres.get_output_port()
        depth_input = images.DeclareImageInputPort[PixelType.kDepth16U]("depth")
    else:
        depth_input = images.DeclareImageInputPort[PixelType.kDepth32F]("depth")
    builder.Connect(depth, depth_input)
    add_publisher(builder, f"{PORT_PREFIX}.publisher", camera_channel(scenario.camera),
                  lcmt_image_array, lcm, hardware.camera_period, images.get_output_port())
