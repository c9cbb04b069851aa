"""Depth crop (metres) -> network input: height above the grasp's fingertips, clipped and scaled.

The network sees ``clip(grasp_depth - crop, -below_m, above_m) / scale_m`` per pixel:

- ``grasp_depth - crop`` is the height of each surface above the fingertip level of the grasp
  (positive = above the fingertips, where it meets the fingers or the closing region; negative =
  below them, where the fingers never reach). Both are distances along the optical axis of a
  camera looking down, so the camera's height cancels: the same pile under a camera mounted
  0.6 m or 1.2 m high gives the same input (the crop is already metric in x and y, crops.py).
- The clip keeps the input range fixed: anything more than ``below_m`` under the fingertips
  (the bin floor, a deep hole) reads the same, and anything more than ``above_m`` above them
  (the finger length) reads the same.
- ``scale_m`` brings the default range [-2 cm, 6 cm] to [-0.5, 1.5].

With a ``target_mask`` (:mod:`.target_mask`) the input has a second channel marking the
target part's pixels, drawn from the clipped heights; models trained before it existed have
none and read one channel.

The values are stored in every checkpoint, so a model is always fed as it was trained.
``apply`` serves numpy arrays and torch tensors (the ONNX export traces it).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, TypeVar

import numpy as np
import torch

from tangle_drake.tangle_cnn.target_mask import TargetMask

Array = TypeVar("Array", np.ndarray, torch.Tensor)


@dataclass(frozen=True)
class Normalisation:
    """Height range (metres, relative to the fingertips) and scale of the network's input."""

    below_m: float = 0.02
    above_m: float = 0.06
    scale_m: float = 0.04
    target_mask: TargetMask | None = None
    """Add the target mask as a second channel (``None``: the height channel alone)."""

    def __post_init__(self) -> None:
        if not (self.below_m >= 0 and self.above_m > 0 and self.scale_m > 0):
            raise ValueError(f"invalid normalisation {self}: below_m >= 0, above_m > 0 and "
                             "scale_m > 0 are needed")

    def apply(self, crops: Array, grasp_depths: Array) -> Array:
        """(N, S, S) crops in metres and (N,) fingertip depths -> (N, S, S) network input."""
        height = grasp_depths[:, None, None] - crops
        return height.clip(-self.below_m, self.above_m) / self.scale_m

    @property
    def channels(self) -> int:
        return 1 if self.target_mask is None else 2

    def inputs(self, crops: np.ndarray, grasp_depths: np.ndarray) -> np.ndarray:
        """(N, S, S) crops in metres and (N,) fingertip depths -> (N, C, S, S) float32 input."""
        height = self.apply(np.asarray(crops, dtype=np.float32),
                            np.asarray(grasp_depths, dtype=np.float32)).astype(np.float32)
        if self.target_mask is None:
            return height[:, None]
        return np.stack([height, self.target_mask.apply(height * np.float32(self.scale_m))], 1)

    def masks(self, crops: np.ndarray, grasp_depths: np.ndarray) -> np.ndarray:
        """The target-mask channel alone, (N, S, S) (the ONNX graph's ``target_masks``)."""
        if self.target_mask is None:
            raise ValueError("this normalisation has no target mask")
        return self.inputs(crops, grasp_depths)[:, 1]

    def to_dict(self) -> dict:
        mask = None if self.target_mask is None else self.target_mask.to_dict()
        return {**asdict(self), "target_mask": mask}

    @staticmethod
    def from_dict(data: Mapping[str, Any]) -> Normalisation:
        """Inverse of :meth:`to_dict`; a dict without ``target_mask`` (older checkpoints) has
        none. Raises ``TypeError``/``ValueError``/``KeyError`` on a bad dict."""
        mask = data.get("target_mask")
        return Normalisation(**{**data, "target_mask": None if mask is None else
                                TargetMask.from_dict(mask)})


DEFAULT_NORMALISATION = Normalisation()
