"""The labelling rules on hand-made scenes of two C-rings: linked rings come up together
(tangled, the lower one hangs), a ring lying on another rides, a lone ring comes up alone
(not tangled), and two rings in the closing region are tangled without any lift."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import wire
from tangle_drake.parts.catalog import builtin_spec
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.station.scene import render_depth
from tangle_drake.tangle_data.closing_region import parts_in_region
from tangle_drake.tangle_data.collect import default_scenario_text
from tangle_drake.tangle_data.labels import label_pick
from tangle_drake.tangle_data.lift import ForceLift, LiftResult
from tangle_drake.tangle_data.settings import CollectSettings, LiftSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator

SPEC = builtin_spec("c_ring")
RADIUS = SPEC.skeleton[0].radius  # centre line, 20 mm
WIRE = SPEC.wire_diameter / 2
# The ring's circle centre in its body frame (the body origin is the centre of mass); the
# ring's gap spans 200-270 degrees about it.
CENTRE_B = np.array([0.0, RADIUS, 0.0]) - wire.tube_mesh(SPEC).center_mass
BIN_CENTRE = np.array([0.40, 0.15])
FLOOR = 0.80
PARKED = RigidTransform([-1.5, -1.0, 0.05])
WIRE_ANGLE = np.radians(55)  # a point of the wire, opposite the gap
RADIAL = np.array([np.cos(WIRE_ANGLE), np.sin(WIRE_ANGLE), 0.0])
ON_TOP = np.array([0.0, 0.0, 2 * WIRE])  # a ring lying on another, concentric


@pytest.fixture(scope="module")
def sim() -> TangleDataSimulator:
    return TangleDataSimulator(default_scenario_text(), CollectSettings(
        part="c_ring", parts_per_pile=2, lifts_per_pile=1, repeat=3))


def flat_ring(centre_W: np.ndarray) -> RigidTransform:
    """A ring lying flat with its circle centred at ``centre_W``."""
    return RigidTransform(centre_W - CENTRE_B)


def settle(sim: TangleDataSimulator, poses: list[RigidTransform], seconds: float = 0.5):
    """Place the two rings, let them settle, and return the settled context."""
    sim.restore(sim.settler.initial)
    context = sim.simulator.get_mutable_context()
    plant_context = sim.plant.GetMyMutableContextFromRoot(context)
    for body, X in zip(sim.bodies, poses, strict=True):
        sim.plant.SetFreeBodyPose(plant_context, body, X)
    sim.simulator.AdvanceTo(context.get_time() + seconds)
    return context.Clone()


def tool_pose(point_W: np.ndarray, closing_W: np.ndarray, tips_z: float) -> np.ndarray:
    """X_WT of a top-down grasp centred over ``point_W``, closing along ``closing_W``."""
    z = np.array([0.0, 0.0, -1.0])
    y = closing_W / np.linalg.norm(closing_W)
    X = np.eye(4)
    X[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    X[:3, 3] = [point_W[0], point_W[1], tips_z + DEFAULT_GRIPPER.pad_length / 2]
    return X


def test_linked_rings_come_up_together(sim):
    centre = np.array([*BIN_CENTRE, FLOOR + RADIUS + WIRE + 0.001])
    through = centre + RADIUS * RADIAL  # ring B stands upright around ring A's wire here
    up = np.array([0.0, 0.0, 1.0])
    turn = np.radians(305)  # B's gap faces A's middle, away from where A's wire holds B
    e1 = np.cos(turn) * RADIAL + np.sin(turn) * up
    e2 = -np.sin(turn) * RADIAL + np.cos(turn) * up
    R_WB = np.column_stack([e1, e2, np.cross(e1, e2)])
    upright = RigidTransform(RotationMatrix(R_WB), through - R_WB @ CENTRE_B)
    settled = settle(sim, [flat_ring(centre), upright])

    label = label_pick([0], lambda target: sim.lift(settled, target))
    assert label.tangled
    assert label.lift.lifted == (1,)
    assert label.lift.hanging == (1,) and label.lift.riding == ()
    # Once both rings hang clear of everything else, nothing can change: the lift ends.
    assert label.lift.cleared and label.lift.rise[1] > 0.03

    full = ForceLift(sim.simulator, sim.plant, sim.lifter.freeze, sim.part, sim.points,
                     sim.scenario.bin, LiftSettings(early_exit=False))
    sim.restore(settled)
    whole = full.run(0, rise_threshold=0.03, stall_fraction=0.5)
    assert whole.lifted == (1,) and whole.hanging == (1,) and not whole.cleared
    assert whole.rise[1] > 0.08 and whole.target_rise == pytest.approx(0.12, abs=0.01)
    # Perturbed re-runs (1 mm, 1 degree, friction +-10 %) agree: linked rings stay linked.
    assert sim.repeat_votes(settled, task=0, rank=0, label=label) == 3


def test_a_ring_lying_on_the_target_rides_and_a_lone_ring_comes_up_alone(sim):
    on_floor = np.array([*BIN_CENTRE, FLOOR + WIRE + 0.0005])
    settled = settle(sim, [flat_ring(on_floor), flat_ring(on_floor + ON_TOP)])
    stacked = label_pick([0], lambda target: sim.lift(settled, target))
    assert stacked.tangled
    assert stacked.lift.riding == (1,) and stacked.lift.hanging == ()

    alone = label_pick([1], lambda target: sim.lift(settled, target))
    assert not alone.tangled
    assert alone.lift.lifted == () and not alone.lift.stalled
    assert alone.lift.cleared  # nothing else could come up, so the lift stopped early
    assert sim.repeat_votes(settled, task=0, rank=1, label=alone) == 0


def test_lone_ring_graspability_candidates_are_not_tangled(sim):
    settled = settle(sim, [flat_ring(np.array([*BIN_CENTRE, FLOOR + WIRE + 0.0005])), PARKED])
    depth = render_depth(sim.station, settled)
    candidates = sim.candidates(depth)
    assert candidates
    poses = sim.part_poses()
    for candidate in candidates[:2]:
        region = parts_in_region(candidate.pose, poses, sim.points, sim.region)
        assert region == [0]
        label = label_pick(region, lambda target: sim.lift(settled, target))
        assert label.is_sample and not label.tangled


def test_two_rings_in_the_closing_region_are_tangled_without_a_lift(sim):
    on_floor = np.array([*BIN_CENTRE, FLOOR + WIRE + 0.0005])
    settled = settle(sim, [flat_ring(on_floor), flat_ring(on_floor + ON_TOP)])
    poses = sim.part_poses()
    # Over both wires, across them: the lower ring is hidden from the camera by the upper
    # one, but it lies between the fingers all the same.
    grasp = tool_pose(on_floor + RADIUS * RADIAL, RADIAL, tips_z=FLOOR + 0.001)
    region = parts_in_region(grasp, poses, sim.points, sim.region)
    assert region == [0, 1]
    lifts_before = sim.lifts_run
    label = label_pick(region, lambda target: sim.lift(settled, target))
    assert label.tangled and label.lift is None and label.target == -1
    assert sim.lifts_run == lifts_before

    # Fingertips above the upper ring: nothing to grasp, not a sample.
    above = tool_pose(on_floor + RADIUS * RADIAL, RADIAL, tips_z=FLOOR + 0.03)
    empty = label_pick(parts_in_region(above, poses, sim.points, sim.region), _no_lift)
    assert not empty.is_sample
    with pytest.raises(ValueError):
        _ = empty.tangled


def _no_lift(target: int) -> LiftResult:
    raise AssertionError("no lift may run")


def test_bad_lift_settings_are_clear_errors():
    with pytest.raises(TangleDrakeError, match="too stiff"):
        LiftSettings(frequency_hz=200.0).validate(0.002)
    with pytest.raises(TangleDrakeError, match="height_m"):
        LiftSettings(height_m=-0.1).validate(0.002)
    with pytest.raises(TangleDrakeError, match="lifts-per-pile"):
        CollectSettings(part="u_hook", lifts_per_pile=9).validate(0.002)
