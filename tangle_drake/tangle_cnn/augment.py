"""The paper's x8 augmentation: the symmetries of the square crop (dihedral group D4).

Transform ``t`` in 0..7 mirrors the crop left-right if ``t >= 4``, then rotates it by
``(t % 4) * 90`` degrees. The paper grew 4,590 training images to 36,720 this way (x8), so
``d4`` is the default. Note what it means: the odd rotations turn the closing direction, which
``extract_crop`` lays horizontally, vertical; the network then learns to judge grasps in both
orientations instead of relying on the convention. The mirror and the 180-degree rotation keep
it horizontal (a parallel gripper is symmetric under both). ``none`` trains on the crops as
they are.

An epoch visits every (sample, transform) pair once, in a shuffled order, which is the
paper's augmented dataset without holding eight copies in memory.
"""

from __future__ import annotations

import numpy as np
import torch


def dihedral(x: torch.Tensor, transform: int) -> torch.Tensor:
    """Transform ``transform`` (0..7) of the last two (square) dimensions of ``x``."""
    if transform >= 4:
        x = torch.flip(x, dims=(-1,))
    return torch.rot90(x, transform % 4, dims=(-2, -1))


def augment_batch(x: torch.Tensor, transforms: np.ndarray) -> torch.Tensor:
    """Apply ``transforms[i]`` to ``x[i]``; one vectorised call per distinct transform."""
    out = torch.empty_like(x)
    for transform in np.unique(transforms):
        rows = torch.from_numpy(np.flatnonzero(transforms == transform))
        out[rows] = dihedral(x[rows], int(transform))
    return out
