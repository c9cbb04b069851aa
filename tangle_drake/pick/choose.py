"""Choosing the grasp to try: the selection's order, minus what cannot or should not be done.

The planner tries candidates in the selection's order (``scored_candidates``, best first,
with ``selected_grasp`` at the front). A candidate is turned down, with its
:class:`~tangle_drake.common.failures.FailureKind`, if it has no world pose, if it repeats a grasp
that came up empty where the pile has not changed since (same place and closing direction,
fingertips at the same depth), or if the ``Motion`` cannot plan it.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tangle_drake.common.failures import FailureKind
from tangle_drake.pick.outcome import PickRecord, Rejection
from tangle_drake.planning.motion import Motion, PickMotion, PlanningError
from tangle_drake.selection.rules import ScoredCandidate


@dataclass(frozen=True)
class EmptyGrasp:
    """A grasp that came up empty: where, and how deep the pile was there."""

    X_WT: np.ndarray
    depth_m: float


@dataclass(frozen=True)
class RepeatRule:
    """When a candidate repeats an empty grasp (SI units)."""

    distance: float
    angle_deg: float
    depth: float
    """Fingertip depths this close mean the pile there has not changed, m."""

    def repeats(self, candidate: Any, empty: Sequence[EmptyGrasp]) -> bool:
        cos_limit = np.cos(np.radians(self.angle_deg))
        X = candidate.pose
        return any(np.linalg.norm(X[:3, 3] - e.X_WT[:3, 3]) < self.distance
                   and abs(float(X[:3, 1] @ e.X_WT[:3, 1])) > cos_limit
                   and abs(float(candidate.depth_m) - e.depth_m) < self.depth for e in empty)


def rank_scored(scored: list[ScoredCandidate],
                selected: Any = None) -> list[ScoredCandidate]:
    """``scored`` in the selection's order (``scored_candidates`` are best first,
    :func:`~tangle_drake.selection.rules.rank`), with ``selected`` at the front."""
    if selected is None:
        return list(scored)
    key = (selected.u, selected.v, selected.angle_deg)
    front = [s for s in scored if (s.candidate.u, s.candidate.v, s.candidate.angle_deg) == key]
    return front + [s for s in scored if s not in front]


def choose(record: PickRecord, ranked: list[ScoredCandidate], motion: Motion,
           measured: np.ndarray, empty: Sequence[EmptyGrasp], rule: RepeatRule,
           tips_above: float | None = None) -> PickMotion | None:
    """Plan the first candidate of ``ranked`` that can be done (its lift taking the fingertips
    up to ``tips_above``, where given); fills ``record``'s candidate, rank, the model's probability,
    rejections and planning time. ``None`` if none can."""
    start = time.perf_counter()
    plan = None
    for rank, scored in enumerate(ranked):
        candidate = scored.candidate
        if candidate.pose is None:
            record.rejected.append(Rejection(rank, FailureKind.NO_POSE,
                                             "the candidate has no X_WT"))
            continue
        if rule.repeats(candidate, empty):
            record.rejected.append(Rejection(rank, FailureKind.REPEAT,
                                             "a grasp there came up empty"))
            continue
        try:
            plan = motion.plan_pick(candidate.pose, measured, tips_above)
        except PlanningError as error:
            record.rejected.append(Rejection(rank, error.kind, error.detail))
            continue
        record.candidate, record.rank = candidate, rank
        record.p_model, record.p_model_name = scored.p_model, scored.p_model_name
        break
    record.timing = replace(record.timing, planning_s=time.perf_counter() - start)
    return plan
