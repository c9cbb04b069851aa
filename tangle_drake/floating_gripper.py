"""A free-floating parallel-jaw gripper: the station and ``Motion`` for picking without an arm.

The gripper hangs from a 4-axis gantry (x, y, z slides and a yaw turn, each a PD servo, so
it always points straight down) over the scenario's bin, under its camera, with its pile.
The pick state machine is the project's own ``PickPlanner``; only its ``Motion`` differs:
``GantryMotion`` turns a grasp pose straight into gantry coordinates, where the Nextage's
``ArmMotion`` solves IK. Without IK, joint limits or an arm to collide, a pick is fast to
plan and to simulate, which is what the benchmark's many trials need
(``tangle-drake bench``); ``tools/example_floating_gripper.py`` shows it in a few lines.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Box, MakeRenderEngineVtk, RenderEngineVtkParams
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import MatrixGain, StateInterpolatorWithDiscreteDerivative
from pydrake.systems.sensors import RgbdSensor

from tangle_drake.bin_model import bin_sdf
from tangle_drake.gripper import DEFAULT_GRIPPER
from tangle_drake.paths import make_parser
from tangle_drake.pick.motion import PickMotion, PlanningError
from tangle_drake.planning.grasp_poses import ApproachSettings, pick_poses
from tangle_drake.planning.trajectory import MIN_DURATION, chain, hold, rest_to_rest
from tangle_drake.scenario import BinConfig, Scenario
from tangle_drake.station import PLANT_NAME, add_pile_parts, camera_body_pose

GANTRY_SDF = """<?xml version="1.0"?>
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="gantry">
{links}
{joints}
  </model>
</sdf>"""
_AXES = (("x", "prismatic", "1 0 0", -1.0, 1.0), ("y", "prismatic", "0 1 0", -1.0, 1.0),
         ("z", "prismatic", "0 0 1", 0.8, 1.6), ("yaw", "revolute", "0 0 1", -3.1, 3.1))
_GAINS = {"prismatic": (20000.0, 400.0), "revolute": (200.0, 3.0)}
"""PD gains of the slides (N/m, N·s/m) and the turn (N·m/rad, N·m·s/rad)."""
VELOCITY = np.array([0.5, 0.5, 0.5, 2.0])
"""Gantry speed limits: m/s for the slides, rad/s for the turn."""
ACCELERATION = np.array([2.0, 2.0, 2.0, 6.0])
"""m/s², rad/s²."""
FREE_VELOCITY = np.array([1.0, 1.0, 1.0, 4.0])
"""Limits of the empty gripper's moves that touch nothing (from home to above the grasp,
and down to where the slow stretch begins), so they may go faster."""
FREE_ACCELERATION = np.array([5.0, 5.0, 5.0, 15.0])
SLOW_SPEED = 0.03
"""Tool speed over the last and first centimetres at the pile, m/s (the arm's too)."""


def gantry_sdf() -> str:
    """Four links on four single-axis joints from the world, each joint servoed."""
    links, joints, parent = [], [], "world"
    for name, kind, axis, lower, upper in _AXES:
        links.append(f"""    <link name="{name}_link"><inertial><mass>0.5</mass><inertia>
      <ixx>1e-3</ixx><iyy>1e-3</iyy><izz>1e-3</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz>
    </inertia></inertial></link>""")
        p, d = _GAINS[kind]
        joints.append(f"""    <joint name="{name}" type="{kind}"><parent>{parent}</parent>
      <child>{name}_link</child><axis><xyz>{axis}</xyz>
      <limit><lower>{lower}</lower><upper>{upper}</upper><effort>500</effort></limit></axis>
      <drake:controller_gains p="{p}" d="{d}"/></joint>""")
        parent = f"{name}_link"
    return GANTRY_SDF.format(links="\n".join(links), joints="\n".join(joints))


def gantry_home(bin_config: BinConfig) -> np.ndarray:
    """Where the gantry waits (x, y, z, yaw): 25 cm behind the bin, out of the camera's view;
    the part is released 10 cm below it and falls to the floor."""
    return np.array([bin_config.center[0] - 0.25, bin_config.center[1], 1.2, 0.0])


def build_floating_station(scenario: Scenario) -> Diagram:
    """Plant (gantry, gripper, bin, pile, floor), top camera, and the servos' command inputs.

    The scenario's robot directives are ignored: the gantry takes the robot's place, parked at
    :func:`gantry_home`. Ports: ``gantry.position`` in (x, y, z, yaw),
    ``gantry.state_measured`` out (8), ``gripper.position`` in, ``gripper.state_measured``
    out, ``camera.depth_image`` out, ``sim.body_poses`` out. The plant is named like the
    station's, so ``drop_pile`` and ``hold_robot_still`` work on it.
    """
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    plant.set_name(PLANT_NAME)
    parser = make_parser(plant)
    gantry = parser.AddModelsFromString(gantry_sdf(), "sdf")[0]
    gripper = parser.AddModelsFromUrl("package://nextage/sdf/parallel_jaw_gripper.sdf")[0]
    # Gripper frame G's +z (approach) points down from the yaw link.
    plant.WeldFrames(plant.GetFrameByName("yaw_link", gantry),
                     plant.GetFrameByName("gripper_base", gripper),
                     RigidTransform(RotationMatrix.MakeXRotation(math.pi)))
    parser.AddModelsFromString(bin_sdf(scenario.bin), "sdf")
    plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform([0, 0, -0.05]),
                                    Box(10, 10, 0.1), "ground", CoulombFriction(0.5, 0.4))
    add_pile_parts(plant, scenario)
    plant.Finalize()
    plant.SetDefaultPositions(gantry, gantry_home(scenario.bin))

    _servo(builder, plant, gantry, "gantry", np.eye(8), np.eye(8), 4)
    half = 0.5 * np.array([[-1, 0], [1, 0], [0, -1], [0, 1]])
    to_width = np.array([[-1.0, 1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 1.0]])
    _servo(builder, plant, gripper, "gripper", to_width, half, 1)

    scene_graph.AddRenderer(scenario.camera.renderer_name,
                            MakeRenderEngineVtk(RenderEngineVtkParams()))
    color, depth = scenario.camera.MakeCameras()
    sensor = builder.AddNamedSystem("camera", RgbdSensor(
        scene_graph.world_frame_id(), camera_body_pose(scenario), color, depth))
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    builder.ExportOutput(sensor.depth_image_32F_output_port(), "camera.depth_image")
    builder.ExportOutput(plant.get_body_poses_output_port(), "sim.body_poses")
    diagram = builder.Build()
    diagram.set_name("floating_station")
    return diagram


def _servo(builder: DiagramBuilder, plant: MultibodyPlant, instance, name: str,
           measured: np.ndarray, to_desired: np.ndarray, size: int) -> None:
    """``{name}.position`` (size) in, through a discrete-derivative interpolator to the
    model's PD servos; ``{name}.state_measured`` out, the model's state times ``measured``."""
    interpolator = builder.AddNamedSystem(
        f"{name}.command_interpolator",
        StateInterpolatorWithDiscreteDerivative(size, plant.time_step(),
                                                suppress_initial_transient=True))
    desired = builder.AddSystem(MatrixGain(to_desired))
    builder.Connect(interpolator.get_output_port(), desired.get_input_port())
    builder.Connect(desired.get_output_port(), plant.get_desired_state_input_port(instance))
    builder.ExportInput(interpolator.get_input_port(), f"{name}.position")
    state = builder.AddSystem(MatrixGain(measured))
    builder.Connect(plant.get_state_output_port(instance), state.get_input_port())
    builder.ExportOutput(state.get_output_port(), f"{name}.state_measured")


class GantryMotion:
    """``Motion`` for the gantry: a grasp pose *is* a command (no IK), legs are straight.

    ``return_home=False`` ends the pick at the top of the lift (the transfer and the way home
    are empty): enough to count what came up, which is all a benchmark asks.
    """

    command_port = "gantry.position"
    command_size = 4
    measured_port = "gantry.state_measured"
    measured_size = 8

    def __init__(self, bin_config: BinConfig, approach: ApproachSettings | None = None,
                 return_home: bool = True) -> None:
        self.bin = bin_config
        self.home = gantry_home(bin_config)
        self.place = self.home[:3] - np.array([0.0, 0.0, 0.1])
        self.approach = approach or ApproachSettings()
        self.return_home = return_home
        self.lower = np.array([axis[3] for axis in _AXES])
        self.upper = np.array([axis[4] for axis in _AXES])

    def hold_command(self, measured: np.ndarray) -> np.ndarray:
        return np.asarray(measured[:4], float).copy()

    def command_for(self, X_WT: RigidTransform, yaw_near: float) -> np.ndarray:
        """Gantry coordinates putting T at ``X_WT``, yaw the twin nearer ``yaw_near``."""
        if X_WT.rotation().col(2)[2] > -0.999:
            raise PlanningError("unreachable", "the gantry can only point straight down")
        y_axis = X_WT.rotation().col(1)  # T's y = (sin yaw, -cos yaw, 0) under this weld
        yaw = math.atan2(y_axis[0], -y_axis[1])
        twins = [a for a in (yaw, yaw - math.pi, yaw + math.pi)
                 if self.lower[3] <= a <= self.upper[3]]
        yaw = min(twins, key=lambda a: abs(a - yaw_near))  # atan2's range: one always fits
        q = np.array([*X_WT.translation(), yaw])
        q[2] += DEFAULT_GRIPPER.tcp_offset  # the yaw link sits above T by the TCP offset
        if np.any(q < self.lower) or np.any(q > self.upper):
            raise PlanningError("unreachable", "outside the gantry's travel")
        return q

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray) -> PickMotion:
        q_now = self.hold_command(measured)
        poses = pick_poses(RigidTransform(np.asarray(X_WT, float)), self.bin, self.approach)
        pre, slow, grasp, lift = (self.command_for(X, q_now[3]) for X in
                                  (poses.pregrasp, poses.slow_start, poses.grasp, poses.lift))

        def leg(a: np.ndarray, b: np.ndarray, speed: float = math.inf, free: bool = False):
            return rest_to_rest(a, b, FREE_VELOCITY if free else VELOCITY,
                                FREE_ACCELERATION if free else ACCELERATION,
                                float(np.linalg.norm(b[:3] - a[:3])), speed)

        if self.return_home:
            place = np.array([*self.place, lift[3]])
            transfer, home = leg(lift, place), leg(place, self.home)
        else:
            transfer = home = hold(lift, MIN_DURATION)
        return PickMotion(
            approach=leg(q_now, pre, free=True),
            descend=chain([leg(pre, slow, free=True), leg(slow, grasp, SLOW_SPEED)]),
            lift=chain([leg(grasp, slow, SLOW_SPEED), leg(slow, lift)]),
            transfer=transfer, home=home, X_WT=poses.grasp.GetAsMatrix4())

