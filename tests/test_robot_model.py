"""The shipped Nextage + gripper model: loads cleanly, matches nextage.md, and is servoed."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from pydrake.geometry import (
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    Capsule,
    ProximityProperties,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from tangle_drake import robot_model
from tangle_drake.drivers.parallel_jaw import finger_positions, opening
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import (
    GRIPPER_JOINTS,
    INIT_RTM,
    LEFT_ARM,
    NEXTAGE_JOINTS,
    RIGHT_ARM,
    add_nextage_with_gripper,
)

WAIST_Z = 0.97


def _plant():
    """A finalized SAP plant (2 ms) with SceneGraph holding the robot and gripper."""
    builder = DiagramBuilder()
    config = MultibodyPlantConfig(time_step=0.002, discrete_contact_approximation="sap")
    plant, scene_graph = AddMultibodyPlant(config, builder)
    nextage, gripper = add_nextage_with_gripper(plant)
    return builder, plant, scene_graph, nextage, gripper


def test_model_loads_without_warnings_and_has_the_table_joints(
        caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="drake")
    _, plant, _, nextage, gripper = _plant()
    plant.Finalize()
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text

    names = [plant.get_joint(i).name() for i in plant.GetJointIndices(nextage)
             if plant.get_joint(i).num_positions() == 1]
    assert tuple(names) == NEXTAGE_JOINTS
    assert plant.num_positions(nextage) == 15
    for spec in robot_model.JOINTS:
        joint = plant.GetJointByName(spec.name, nextage)
        assert joint.type_name() == "revolute"
        assert joint.position_lower_limits()[0] == pytest.approx(spec.lower)
        assert joint.position_upper_limits()[0] == pytest.approx(spec.upper)
        assert joint.velocity_upper_limits()[0] == pytest.approx(spec.velocity)
        assert joint.default_damping() == pytest.approx(0.2)
        assert joint.child_body().default_mass() == pytest.approx(spec.child_mass)
        actuator = plant.GetJointActuatorByName(f"{spec.name}_motor", nextage)
        assert actuator.effort_limit() == pytest.approx(spec.effort)
        assert actuator.has_controller()
    # The right arm's exceptions of nextage.md.
    rarm3 = plant.GetJointByName("RARM_JOINT3")
    assert rarm3.position_lower_limits()[0] == pytest.approx(-2.87979)
    assert plant.GetJointByName("RARM_JOINT2").velocity_upper_limits()[0] == pytest.approx(3.75246)

    stroke = DEFAULT_GRIPPER.finger_stroke
    for name, limits in zip(GRIPPER_JOINTS, ((-stroke, 0.0), (0.0, stroke)), strict=True):
        joint = plant.GetJointByName(name, gripper)
        assert joint.type_name() == "prismatic"
        assert (joint.position_lower_limits()[0], joint.position_upper_limits()[0]) == \
            pytest.approx(limits)
        actuator = plant.GetJointActuatorByName(name, gripper)
        assert actuator.effort_limit() == pytest.approx(DEFAULT_GRIPPER.grip_force)
        assert actuator.has_controller()
    tcp = plant.GetFrameByName("gripper_tcp", gripper)
    assert tcp.GetFixedPoseInBodyFrame().translation() == \
        pytest.approx([0, 0, DEFAULT_GRIPPER.tcp_offset])


@pytest.fixture(scope="module")
def kinematics() -> tuple[MultibodyPlant, object]:
    plant = MultibodyPlant(0.0)
    add_nextage_with_gripper(plant)
    plant.Finalize()
    return plant, plant.CreateDefaultContext()


def test_forward_kinematics_matches_nextage_md(kinematics) -> None:
    plant, context = kinematics
    nextage = plant.GetModelInstanceByName("nextage")
    assert plant.GetFrameByName("WAIST").CalcPoseInWorld(context).translation() == \
        pytest.approx([0, 0, WAIST_Z])

    q = np.zeros(15)
    q[LEFT_ARM] = [0, 0, -1.6, 0, 0, 0]
    plant.SetPositions(context, nextage, q)
    wrist = plant.GetFrameByName("LARM_JOINT5_Link").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(wrist, [0.327, 0.155, 1.009], atol=0.005)

    plant.SetPositions(context, nextage, INIT_RTM)
    for link, y in (("LARM_JOINT5_Link", 0.182), ("RARM_JOINT5_Link", -0.182)):
        wrist = plant.GetFrameByName(link).CalcPoseInWorld(context).translation()
        np.testing.assert_allclose(wrist - [0, 0, WAIST_Z], [0.326, y, 0.068], atol=0.005)
    z_G = plant.GetFrameByName("gripper_base").CalcPoseInWorld(context).rotation().col(2)
    assert np.degrees(np.arccos(-z_G[2])) < 3.0


def test_init_rtm_mirrors_left_arm_and_is_collision_free() -> None:
    np.testing.assert_allclose(INIT_RTM[RIGHT_ARM], INIT_RTM[LEFT_ARM] * [-1, 1, 1, -1, 1, -1])
    assert not INIT_RTM[:3].any()
    builder, plant, scene_graph, _, _ = _plant()
    plant.Finalize()
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()  # default positions are init_rtm
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    assert query.ComputePointPairPenetration() == []


def test_finger_positions_open_the_fingers_symmetrically_and_refuse_impossible_widths() -> None:
    q = finger_positions(0.03)
    assert q == pytest.approx([-0.015, 0.015])
    assert opening(q) == pytest.approx(0.03)
    with pytest.raises(ValueError):
        finger_positions(DEFAULT_GRIPPER.max_opening + 0.001)
    with pytest.raises(ValueError):
        finger_positions(-0.001)


def _servo_sim(with_wire: bool = False):
    """Simulator with both models held by constant desired states (arm at init_rtm)."""
    builder, plant, _, nextage, gripper = _plant()
    wire = None
    if with_wire:  # a 13 g steel wire, 3 mm radius, rigid-hydroelastic like the parts
        props = ProximityProperties()
        AddContactMaterial(friction=CoulombFriction(0.5, 0.5), point_stiffness=1e5,
                           properties=props)
        AddRigidHydroelasticProperties(0.001, props)
        wire = plant.AddRigidBody("wire", plant.AddModelInstance("wire"),
                                  SpatialInertia.SolidCapsuleWithMass(0.013, 0.003, 0.06,
                                                                      [1, 0, 0]))
        plant.RegisterCollisionGeometry(wire, RigidTransform(RotationMatrix.MakeYRotation(
            np.pi / 2)), Capsule(0.003, 0.06), "wire", props)
    plant.Finalize()
    arm = builder.AddSystem(ConstantVectorSource(np.concatenate([INIT_RTM, np.zeros(15)])))
    builder.Connect(arm.get_output_port(), plant.get_desired_state_input_port(nextage))
    hand = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    builder.Connect(hand.get_output_port(), plant.get_desired_state_input_port(gripper))
    simulator = Simulator(builder.Build())
    context = simulator.get_mutable_context()

    def command_width(width: float) -> None:
        q_left, q_right = finger_positions(width)
        hand.get_mutable_source_value(hand.GetMyContextFromRoot(context)).set_value(
            np.array([q_left, q_right, 0.0, 0.0]))

    return simulator, plant, plant.GetMyContextFromRoot(context), gripper, wire, command_width


def test_gripper_follows_its_servo_and_the_arm_holds_its_pose() -> None:
    simulator, plant, context, gripper, _, command_width = _servo_sim()
    tcp = plant.GetFrameByName("gripper_tcp")
    p_start = tcp.CalcPoseInWorld(context).translation().copy()
    for width in (0.0, DEFAULT_GRIPPER.max_opening, 0.02):
        command_width(width)
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.3)
        q_left, q_right = plant.GetPositions(context, gripper)
        assert q_right - q_left == pytest.approx(width, abs=0.002)
        assert q_left == pytest.approx(-q_right, abs=0.001)
        sag = np.linalg.norm(tcp.CalcPoseInWorld(context).translation() - p_start)
        assert sag < 0.001


def test_gripper_holds_a_steel_wire() -> None:
    simulator, plant, context, gripper, wire, command_width = _servo_sim(with_wire=True)
    p_tcp = plant.GetFrameByName("gripper_tcp").CalcPoseInWorld(context).translation()
    plant.SetFreeBodyPose(context, wire, RigidTransform(p_tcp))
    plant.SetPositions(context, gripper, [-0.0035, 0.0035])
    command_width(0.0)
    simulator.AdvanceTo(1.0)
    drop = p_tcp[2] - plant.EvalBodyPoseInWorld(context, wire).translation()[2]
    assert abs(drop) < 0.002


def test_shipped_model_files_are_generated() -> None:
    assert robot_model.main(["--check"]) == 0
