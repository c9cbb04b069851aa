"""``GraspabilitySystem``: the graspability index as a Drake system (the package's only
Drake-importing module), so it drops into any diagram behind a depth camera."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.graspability.candidates import compute_candidates
from tangle_drake.graspability.hand import HandModel
from tangle_drake.graspability.params import GraspabilityParams
from tangle_drake.graspability.roi import Rect
from tangle_drake.perception.camera import CameraModel
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec


class GraspabilitySystem(LeafSystem):
    """Depth image in, ranked grasp candidates out.

    Input port ``depth_image``: ``ImageDepth32F`` of the camera described by ``camera``
    (e.g. an ``RgbdSensor``'s ``depth_image_32f``). Output port ``candidates``: an abstract
    value holding a ``list[GraspCandidate]``, best first, with poses (``X_WT``) in the world
    frame. Stateless: the output is computed (and cached by Drake) from the input.
    """

    def __init__(self, camera: CameraModel, hand: HandModel | GripperSpec = DEFAULT_GRIPPER,
                 params: GraspabilityParams | None = None,
                 roi: np.ndarray | Rect | None = None) -> None:
        super().__init__()
        self._camera = camera
        self._hand = hand
        self._params = params or GraspabilityParams()
        self._roi = roi
        k = camera.intrinsics
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(k.width, k.height)))
        self.DeclareAbstractOutputPort(
            "candidates", lambda: Value[object]([]), self._calc_candidates,
            prerequisites_of_calc={self._depth.ticket()})

    def _calc_candidates(self, context: Context, output: AbstractValue) -> None:
        image = self._depth.Eval(context)
        depth = np.asarray(image.data)[:, :, 0]
        output.set_value(compute_candidates(depth, self._camera, self._hand, self._params,
                                            self._roi))
