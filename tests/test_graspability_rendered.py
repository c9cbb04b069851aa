"""Graspability on Drake-rendered piles: candidate poses land on real parts (ground truth)."""

import numpy as np
import pytest

from tangle_drake.common.paths import diagrams_dir
from tangle_drake.graspability import bin_roi, compute_candidates
from tangle_drake.parts import BUILTIN_PARTS
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.scenario import PartCount, load_scenario
from tangle_drake.station import part_bodies
from tangle_drake.station.bin_model import inner_corners
from tangle_drake.station.scene import make_scene


@pytest.mark.parametrize("part", BUILTIN_PARTS)
def test_candidates_map_to_world_poses_on_real_parts(part):
    scenario = load_scenario(diagrams_dir() / "pile_only.yaml")
    scenario.pile.parts = [PartCount(part=part, count=10)]
    scene = make_scene(scenario)
    candidates = compute_candidates(scene.depth, scene.camera, DEFAULT_GRIPPER,
                                    roi=bin_roi(scene.camera, inner_corners(scenario.bin)))
    assert len(candidates) >= 3

    plant = scene.station.plant
    query = scene.station.GetOutputPort("sim.query_object").Eval(scene.context)
    part_geometries = {g for body in part_bodies(plant)
                       for g in plant.GetCollisionGeometriesForBody(body)}
    tcp_to_tips = DEFAULT_GRIPPER.pad_length / 2
    for candidate in candidates:
        X_WT = candidate.pose
        assert X_WT is not None
        np.testing.assert_allclose(X_WT[:3, 2], [0, 0, -1], atol=1e-6)  # approach: down
        assert abs(X_WT[2, 1]) < 1e-6  # closing direction horizontal
        # The tool centre sits between the finger pads: a part's wire passes within reach of
        # the pads, i.e. some part geometry is closer than half the opening to the centre,
        # and nothing is under the fingertips' level at the centre except what they close on.
        p_WT = X_WT[:3, 3]
        distances = [d.distance for d in query.ComputeSignedDistanceToPoint(p_WT, 0.1)
                     if d.id_G in part_geometries]
        assert distances and min(distances) < DEFAULT_GRIPPER.max_opening / 2
        tips_z = p_WT[2] - tcp_to_tips
        assert tips_z >= scenario.bin.floor_height - 1e-3
        # The closing region (between the open fingers) shows a part in the label image.
        labels = scene.label_image()
        part_labels = {int(body.index()) for body in part_bodies(plant)}
        scale = scene.camera.intrinsics.fx / candidate.depth_m
        along = np.linspace(-0.5, 0.5, 31) * DEFAULT_GRIPPER.max_opening * scale
        across = np.linspace(-0.5, 0.5, 7) * DEFAULT_GRIPPER.finger_width * scale
        s, t = np.meshgrid(along, across)
        angle = np.radians(candidate.angle_deg)
        us = np.round(candidate.u + s * np.cos(angle) - t * np.sin(angle)).astype(int)
        vs = np.round(candidate.v + s * np.sin(angle) + t * np.cos(angle)).astype(int)
        assert part_labels & set(labels[vs, us].ravel().tolist())
