"""The bin's box holds a part that is pushed hard into its floor beside a wall."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ExternallyAppliedSpatialForce,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource

from tangle_drake.common.paths import make_parser
from tangle_drake.parts import load_part
from tangle_drake.scenario import BinConfig, Scenario
from tangle_drake.station.bin_model import bin_sdf, inside_bin


def _pried(down_n: float, out_n: float, tilt_deg: float, inset: float) -> np.ndarray:
    """Where an E-shape lying tilted against the bin's +x wall, its wall-side end pushed down
    by ``down_n`` and toward the wall by ``out_n`` for a second, comes to be (its COM)."""
    bin_config = BinConfig()
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(Scenario().plant_config, builder)
    make_parser(plant).AddModelsFromString(bin_sdf(bin_config), "sdf")
    part = load_part("e_shape")
    instance = make_parser(plant).AddModels(str(part.sdf_path))[0]
    plant.Finalize()
    body = plant.GetBodyByName(part.body_name, instance)
    push = ExternallyAppliedSpatialForce()
    push.body_index = body.index()
    push.p_BoBq_B = np.array([0.02, 0.0, 0.0])  # the end toward the wall
    push.F_Bq_W = SpatialForce(np.zeros(3), np.array([out_n, 0.0, -down_n]))
    source = builder.AddSystem(ConstantValueSource(AbstractValue.Make([push])))
    builder.Connect(source.get_output_port(), plant.get_applied_spatial_force_input_port())
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    wall_x = bin_config.center[0] + bin_config.inner_size[0] / 2
    plant.SetFreeBodyPose(context, body, RigidTransform(
        RollPitchYaw(0, np.radians(tilt_deg), 0),
        [wall_x - 0.025 + inset, bin_config.center[1], bin_config.floor_height + 0.006]))
    simulator.AdvanceTo(1.0)
    return plant.EvalBodyPoseInWorld(context, body).translation()


# Pushes that took a part out under the wall when the walls stood on the floor (25 of 54
# such pushes did; none does now).
@pytest.mark.parametrize("down_n, out_n, tilt_deg, inset", [
    (2.0, 5.0, 10.0, 0.0), (5.0, 5.0, 20.0, 0.0), (5.0, 10.0, 35.0, 0.008),
    (20.0, 5.0, 10.0, 0.008)])
def test_a_part_pried_into_the_floor_by_a_wall_stays_in_the_bin(
        down_n: float, out_n: float, tilt_deg: float, inset: float) -> None:
    p = _pried(down_n, out_n, tilt_deg, inset)
    assert inside_bin(BinConfig(), p), f"the part left the bin: it is at {np.round(p, 4)}"
