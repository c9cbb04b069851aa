"""GraspabilitySystem in a tiny Drake diagram fed with a constant depth image."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.graspability import GraspabilityParams, GraspCandidate, compute_candidates
from tangle_drake.graspability.synthetic import pile_field
from tangle_drake.graspability.system import GraspabilitySystem
from tangle_drake.perception.camera import CameraIntrinsics, CameraModel, top_view_pose


def test_system_outputs_the_functions_candidates():
    k = CameraIntrinsics.from_fov_y(320, 240, 45.0)
    camera = CameraModel(k, top_view_pose(np.array([0.4, 0.0, 0.1]), 0.5))
    depth = pile_field(np.random.default_rng(11), k, n_parts=10).render(k, 0.5)
    image = ImageDepth32F(k.width, k.height)
    image.mutable_data[:, :, 0] = depth
    params = GraspabilityParams(top_k=4)

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(image)))
    system = builder.AddSystem(GraspabilitySystem(camera, params=params))
    builder.Connect(source.get_output_port(), system.GetInputPort("depth_image"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()

    found = system.GetOutputPort("candidates").Eval(system.GetMyContextFromRoot(context))
    assert len(found) == 4 and all(isinstance(c, GraspCandidate) for c in found)
    expected = compute_candidates(depth, camera, params=params)
    assert [c.to_dict() for c in found] == [c.to_dict() for c in expected]
    for c in found:  # world frame: T just above the bin floor at z = 0.1, below the camera
        assert 0.1 < c.pose[2, 3] < 0.2
        assert np.allclose(c.pose[:3, :3] @ c.pose[:3, :3].T, np.eye(3))
