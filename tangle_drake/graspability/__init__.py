"""Graspability index (Domae et al. 2014), as used by Matsumura et al. 2019, section III-A.

Pure numpy/OpenCV: ranked parallel-jaw grasp candidates from one depth image or height map.
The Drake system wrapping it lives in :mod:`tangle_drake.graspability.system` (the only module
here that imports Drake).
"""

from tangle_drake.graspability.candidates import (
    GraspCandidate,
    compute_candidates,
    compute_candidates_from_height_map,
)
from tangle_drake.graspability.hand import HandModel
from tangle_drake.graspability.params import FINGER_GRIP_SPAN_M, GraspabilityParams
from tangle_drake.graspability.roi import bin_roi, roi_mask

__all__ = [
    "FINGER_GRIP_SPAN_M",
    "GraspCandidate",
    "GraspabilityParams",
    "HandModel",
    "bin_roi",
    "compute_candidates",
    "compute_candidates_from_height_map",
    "roi_mask",
]
