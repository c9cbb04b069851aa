"""Freezing the parts a lift cannot reach: locked where they lie, their contacts with each other
and the bin out of the geometry queries, and all of it undone by a thaw."""

import numpy as np
import pytest
from pydrake.math import RigidTransform

from tangle_drake.parts.catalog import builtin_spec
from tangle_drake.station.pile_freeze import PileFreeze, parts_beyond
from tangle_drake.tangle_data.collect import default_scenario_text
from tangle_drake.tangle_data.settings import CollectSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator

FLOOR = 0.80  # the data scenario's bin: centre (0.40, 0.15), inside 16 x 20 cm
WIRE = builtin_spec("c_ring").wire_diameter / 2
FAR = np.array([0.35, 0.09])
NEAR = np.array([0.45, 0.21])


@pytest.fixture(scope="module")
def sim() -> TangleDataSimulator:
    return TangleDataSimulator(default_scenario_text(), CollectSettings(
        part="c_ring", parts_per_pile=3, lifts_per_pile=1))


def place(sim: TangleDataSimulator):
    """Two rings stacked far from the grasp spot (lying still, touching each other and the
    floor) and one dropped from 2 cm near it."""
    sim.restore(sim.settler.initial)
    context = sim.simulator.get_mutable_context()
    plant_context = sim.plant.GetMyMutableContextFromRoot(context)
    poses = [RigidTransform([*FAR, FLOOR + WIRE]), RigidTransform([*FAR, FLOOR + 3 * WIRE]),
             RigidTransform([*NEAR, FLOOR + 0.02])]
    for body, X in zip(sim.bodies, poses, strict=True):
        sim.plant.SetFreeBodyPose(plant_context, body, X)
    return context


def touching(sim: TangleDataSimulator, context) -> set[frozenset]:
    """Pairs of body names in contact, from the plant's geometry query."""
    query = sim.plant.get_geometry_query_input_port().Eval(
        sim.plant.GetMyContextFromRoot(context))
    inspector = query.inspector()

    def name(geometry) -> str:
        body = sim.plant.GetBodyFromFrameId(inspector.GetFrameId(geometry))
        return sim.plant.GetModelInstanceName(body.model_instance())

    return {frozenset((name(p.id_A), name(p.id_B)))
            for p in query.ComputePointPairPenetration()}


def test_frozen_parts_lie_still_out_of_the_queries_and_a_thaw_brings_them_back(sim):
    context = place(sim)
    freeze = PileFreeze(sim.plant, sim.station.scene_graph, sim.bodies)
    centres = freeze.centres(context)
    assert parts_beyond(centres, sim.scenario.bin, NEAR, 0.10) == [0, 1]
    assert parts_beyond(centres, sim.scenario.bin, NEAR, 0.30) == []
    before = touching(sim, context)
    assert len(before) >= 2  # the stacked rings touch each other and the bin's floor

    freeze.freeze(context, [0, 1])
    assert freeze.frozen == [0, 1]
    assert touching(sim, context) == set()
    sim.simulator.AdvanceTo(context.get_time() + 0.3)
    moved = freeze.centres(context) - centres
    assert np.all(moved[:2] == 0.0)
    assert moved[2, 2] < -0.01  # the free ring fell onto the floor
    with pytest.raises(RuntimeError, match="thaw"):
        freeze.freeze(context, [2])

    freeze.thaw(context)
    assert freeze.frozen == []
    after = touching(sim, context)
    assert before <= after  # the stacked rings' contacts are back (and the fallen ring's)
    assert not any(b.is_locked(sim.plant.GetMyContextFromRoot(context)) for b in sim.bodies)


def test_a_part_outside_the_bin_is_never_frozen(sim):
    context = place(sim)
    freeze = PileFreeze(sim.plant, sim.station.scene_graph, sim.bodies)
    centres = freeze.centres(context)
    centres[0, :2] = (-1.0, -1.0)  # on the ground beside the station
    assert parts_beyond(centres, sim.scenario.bin, NEAR, 0.10) == [1]


def test_a_part_on_the_ground_while_others_are_frozen_neither_crashes_nor_lands(sim):
    # Drake crashes on a contact with world-body geometry while any body is locked
    # (RobotLocomotion/drake#24773): a part knocked out of the bin must not end the run.
    context = place(sim)
    plant_context = sim.plant.GetMyMutableContextFromRoot(context)
    sim.plant.SetFreeBodyPose(plant_context, sim.bodies[2], RigidTransform([1.0, 0.6, WIRE]))
    assert any("ground" in str(pair) for pair in touching_geometries(sim, context))
    freeze = PileFreeze(sim.plant, sim.station.scene_graph, sim.bodies)
    freeze.freeze(context, [0, 1])
    sim.simulator.AdvanceTo(context.get_time() + 0.1)
    assert freeze.centres(context)[2, 2] < 0.0  # it fell through the floor, out of the way
    freeze.thaw(context)


def touching_geometries(sim: TangleDataSimulator, context) -> list[tuple[str, str]]:
    """Names of the geometries in contact."""
    query = sim.plant.get_geometry_query_input_port().Eval(
        sim.plant.GetMyContextFromRoot(context))
    inspector = query.inspector()
    return [(inspector.GetName(p.id_A), inspector.GetName(p.id_B))
            for p in query.ComputePointPairPenetration()]
