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

The values are stored in every checkpoint, so a model is always fed as it was trained.
The same function serves numpy arrays and torch tensors (the ONNX export traces it).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TypeVar

import numpy as np
import torch

Array = TypeVar("Array", np.ndarray, torch.Tensor)


@dataclass(frozen=True)
class Normalisation:
    """Height range (metres, relative to the fingertips) and scale of the network's input."""

    below_m: float = 0.02
    above_m: float = 0.06
    scale_m: float = 0.04

    def __post_init__(self) -> None:
        if not (self.below_m >= 0 and self.above_m > 0 and self.scale_m > 0):
            raise ValueError(f"invalid normalisation {self}: below_m >= 0, above_m > 0 and "
                             "scale_m > 0 are needed")

    def apply(self, crops: Array, grasp_depths: Array) -> Array:
        """(N, S, S) crops in metres and (N,) fingertip depths -> (N, S, S) network input."""
        height = grasp_depths[:, None, None] - crops
        return height.clip(-self.below_m, self.above_m) / self.scale_m

    def to_dict(self) -> dict:
        return asdict(self)


DEFAULT_NORMALISATION = Normalisation()
