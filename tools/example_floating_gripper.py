"""Example: the project's systems in a diagram of your own, with a free-floating gripper.

No Nextage here: the parallel-jaw gripper hangs from a 4-axis gantry (x, y, z slides and a
yaw turn, each a PD servo, so it always points straight down), over a smaller bin under a
camera placed differently from the station's. The pick state machine is the project's own
``PickPlanner``; only its ``Motion`` differs: ``GantryMotion`` turns a grasp pose straight
into gantry coordinates, where the Nextage's ``ArmMotion`` solves IK. Around it, the same
``GraspabilitySystem``, ``TangleCnnSystem`` (given a model) and ``LiftMonitor`` are wired by
hand, as you would in your own diagram.

    python tools/example_floating_gripper.py [--picks 2] [--parts 6] [--seed 0]
                                            [--model PATH] [--rule harmonic]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence

import numpy as np
from pydrake.geometry import Box, MakeRenderEngineVtk, RenderEngineVtkParams
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import MatrixGain, StateInterpolatorWithDiscreteDerivative
from pydrake.systems.sensors import CameraConfig, RgbdSensor

from tangle_drake.bin_model import bin_sdf, inner_corners
from tangle_drake.graspability import GraspabilityParams, bin_roi
from tangle_drake.graspability.system import GraspabilitySystem
from tangle_drake.gripper import DEFAULT_GRIPPER
from tangle_drake.paths import make_parser
from tangle_drake.pick.motion import PickMotion, PlanningError
from tangle_drake.pick.outcome import LiftMonitor, PickRecord, summarize
from tangle_drake.pick.planner import Mode, PickPlanner, PickSettings
from tangle_drake.pick.selection import resolve_tangle_choice
from tangle_drake.pile import drop_pile
from tangle_drake.planning.grasp_poses import ApproachSettings, pick_poses
from tangle_drake.planning.trajectory import chain, rest_to_rest
from tangle_drake.scenario import BinConfig, PartCount, PileConfig, Scenario
from tangle_drake.station import PLANT_NAME, add_pile_parts, camera_body_pose, camera_model

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
SLOW_SPEED = 0.03
"""Tool speed over the last and first centimetres at the pile, m/s."""


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


def example_scenario(parts: int) -> Scenario:
    """A wider, shallower bin than the station's, further from the origin, under a camera
    0.6 m up with a narrower view and a smaller image."""
    camera = CameraConfig(name="camera", width=480, height=360, rgb=False, depth=True,
                          label=False, z_near=0.05, z_far=2.0,
                          renderer_class="RenderEngineVtk")
    camera.focal = CameraConfig.FovDegrees(y=40)
    return Scenario(bin=BinConfig(center=[0.6, 0.0], floor_height=0.85,
                                  inner_size=[0.22, 0.22], wall_height=0.06),
                    pile=PileConfig(parts=[PartCount("u_hook", parts)], seed=0),
                    camera=camera, camera_height=0.6)


def build_floating_station(scenario: Scenario) -> Diagram:
    """Plant (gantry, gripper, bin, pile, floor), top camera, and the servos' command inputs.

    Ports: ``gantry.position`` in (x, y, z, yaw), ``gantry.state_measured`` out (8),
    ``gripper.position`` in, ``gripper.state_measured`` out, ``camera.depth_image`` out,
    ``sim.body_poses`` out. The plant is named like the station's, so ``drop_pile`` works.
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
    return builder.Build()


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
    """``Motion`` for the gantry: a grasp pose *is* a command (no IK), legs are straight."""

    command_port = "gantry.position"
    command_size = 4
    measured_port = "gantry.state_measured"
    measured_size = 8

    def __init__(self, bin_config: BinConfig, home: np.ndarray, place: np.ndarray,
                 approach: ApproachSettings | None = None) -> None:
        self.bin = bin_config
        self.home = np.asarray(home, float)
        self.place = np.asarray(place, float)
        self.approach = approach or ApproachSettings()
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
        place = np.array([*self.place, lift[3]])

        def leg(a: np.ndarray, b: np.ndarray, speed: float = math.inf):
            return rest_to_rest(a, b, VELOCITY, ACCELERATION, float(np.linalg.norm(b[:3] - a[:3])),
                                speed)

        return PickMotion(
            approach=leg(q_now, pre), descend=chain([leg(pre, slow), leg(slow, grasp, SLOW_SPEED)]),
            lift=chain([leg(grasp, slow, SLOW_SPEED), leg(slow, lift)]),
            transfer=leg(lift, place), home=leg(place, self.home),
            X_WT=poses.grasp.GetAsMatrix4())


def gantry_home(bin_config: BinConfig) -> np.ndarray:
    """Where the gantry waits (x, y, z, yaw): 25 cm behind the bin, out of the camera's view;
    the part is released 10 cm below it and falls to the floor."""
    return np.array([bin_config.center[0] - 0.25, bin_config.center[1], 1.2, 0.0])


def build_example(scenario: Scenario, station: Diagram, model: str | None,
                  rule: str | None, picks: int) -> Diagram:
    """The example's diagram: station, perception, planner and monitor, wired by hand."""
    camera = camera_model(scenario)
    roi = bin_roi(camera, inner_corners(scenario.bin))
    wire = 0.006  # the u_hook's wire: the fingertips go that deep (see pick.diagram)
    params = GraspabilityParams(insertion_depth_m=wire, roi_margin_px=20)
    bin_config = scenario.bin
    home = gantry_home(bin_config)
    motion = GantryMotion(bin_config, home, place=home[:3] - np.array([0.0, 0.0, 0.1]))

    builder = DiagramBuilder()
    builder.AddSystem(station)
    graspability = builder.AddNamedSystem(
        "graspability", GraspabilitySystem(camera, DEFAULT_GRIPPER, params, roi))
    planner = builder.AddNamedSystem("pick_planner", PickPlanner(
        motion, PickSettings(max_picks=picks, empty_width=wire / 4)))
    depth = station.GetOutputPort("camera.depth_image")
    builder.Connect(depth, graspability.GetInputPort("depth_image"))
    builder.Connect(graspability.GetOutputPort("candidates"), planner.GetInputPort("candidates"))

    choice = resolve_tangle_choice("u_hook", rule, model)
    if choice.notice:
        print(choice.notice)
    if choice.model is not None:
        from tangle_drake.tangle_cnn.system import TangleCnnSystem

        cnn = builder.AddNamedSystem("tangle_cnn", TangleCnnSystem(
            choice.model, camera.intrinsics, choice.rule))
        builder.Connect(depth, cnn.GetInputPort("depth_image"))
        builder.Connect(graspability.GetOutputPort("candidates"), cnn.GetInputPort("candidates"))
        builder.Connect(cnn.GetOutputPort("scored_candidates"),
                        planner.GetInputPort("scored_candidates"))
        builder.Connect(cnn.GetOutputPort("selected_grasp"), planner.GetInputPort("selected_grasp"))

    for name in ("gantry", "gripper"):
        builder.Connect(station.GetOutputPort(f"{name}.state_measured"),
                        planner.GetInputPort(f"{name}.state_measured"))
        builder.Connect(planner.GetOutputPort(f"{name}.position"),
                        station.GetInputPort(f"{name}.position"))
    monitor = builder.AddNamedSystem("lift_monitor", LiftMonitor(
        station.GetSubsystemByName(PLANT_NAME), bin_config))
    builder.Connect(station.GetOutputPort("sim.body_poses"), monitor.GetInputPort("body_poses"))
    builder.Connect(monitor.GetOutputPort("lifted_count"), planner.GetInputPort("lifted_count"))
    builder.ExportOutput(planner.GetOutputPort("mode"), "mode")
    builder.ExportOutput(planner.GetOutputPort("picks"), "picks")
    return builder.Build()


def run(picks: int = 2, parts: int = 6, seed: int = 0, model: str | None = None,
        rule: str | None = None) -> list[PickRecord]:
    """Build, drop a pile, pick; prints each pick and returns the records."""
    start = time.perf_counter()
    scenario = example_scenario(parts)
    station = build_floating_station(scenario)
    home = gantry_home(scenario.bin)

    # Settle the pile with the gantry parked at home and the fingers open.
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    plant = station.GetSubsystemByName(PLANT_NAME)
    gantry = plant.GetModelInstanceByName("gantry")
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), gantry, home)
    station.GetInputPort("gantry.position").FixValue(context, home)
    station.GetInputPort("gripper.position").FixValue(context, [DEFAULT_GRIPPER.max_opening])
    drop_pile(simulator, scenario.bin, scenario.pile, seed=seed)
    state = plant.GetPositionsAndVelocities(plant.GetMyContextFromRoot(context))

    diagram = build_example(scenario, station, model, rule, picks)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), state)
    simulator.Initialize()
    mode, records = diagram.GetOutputPort("mode"), diagram.GetOutputPort("picks")
    shown = 0
    while mode.Eval(context) is not Mode.DONE and context.get_time() < 30.0 * picks:
        simulator.AdvanceTo(context.get_time() + 0.5)
        for record in records.Eval(context)[shown:]:
            print(record.describe())
            shown += 1
    result = list(records.Eval(context))
    print(f"{summarize(result)}; wall time {time.perf_counter() - start:.0f} s")
    return result


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--picks", type=int, default=2)
    parser.add_argument("--parts", type=int, default=6, help="U-hooks in the pile")
    parser.add_argument("--seed", type=int, default=0, help="pile seed")
    parser.add_argument("--model", default=None, help="tangle CNN checkpoint")
    parser.add_argument("--rule", default=None, help="selection rule")
    args = parser.parse_args(argv)
    run(args.picks, args.parts, args.seed, args.model, args.rule)
    return 0


if __name__ == "__main__":
    sys.exit(main())
