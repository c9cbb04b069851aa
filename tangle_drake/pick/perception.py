"""The pick planner's look at the bin: wait for an image taken after the arm stopped, read
the candidates in the selection's order and choose the first that can be done (:mod:`.choose`).
A mixin of :class:`~tangle_drake.pick.planner.PickPlanner`, which gives it its ports,
settings, motion and ``_enter`` / ``_finish``; the closed loop's stir and the planner's
"nothing to pick" come from there too."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import replace

import numpy as np
from pydrake.systems.framework import Context

from tangle_drake.common.failures import FailureKind, pick_failure
from tangle_drake.perception.crops import candidate_crops
from tangle_drake.pick.choose import choose, rank_scored
from tangle_drake.pick.modes import Mode, PlannerState
from tangle_drake.pick.outcome import VIEW_CANDIDATES, PickRecord, PickView
from tangle_drake.selection.rules import ScoredCandidate


class Perception:
    """SETTLE's wait for a fresh image, and PERCEIVE."""

    def _look(self, context: Context, s: PlannerState, t: float) -> PlannerState:
        """PERCEIVE once the camera's last image arrived after SETTLE began (the arm's last
        motion ended); wait for one, and past ``image_timeout`` stop: a STALE_IMAGE failure."""
        if not self._image_time.HasValue(context):
            return replace(s, mode=Mode.PERCEIVE, since=t)
        arrived = float(self._image_time.Eval(context)[0])
        if arrived >= s.since:
            return replace(s, mode=Mode.PERCEIVE, since=t)
        if t - s.since < self._settings.settle_time + self._settings.image_timeout:
            return s
        age = "no image yet" if arrived == -np.inf else \
            f"the last one arrived at t={arrived:.2f} s"
        record = PickRecord(index=len(s.picks) + 1, failure=FailureKind.STALE_IMAGE,
                            reason=f"no camera image after the arm stopped at t={s.since:.2f} s "
                                   f"({age}): is the camera frozen?")
        return self._finish(s, record, t)

    def _perceive(self, context: Context, s: PlannerState) -> PlannerState:
        t = context.get_time()
        if s.loop.stir_due:  # the grasp that asked for it waits in ``s.record``
            return self._stir(context, s, t, s.record)
        record = PickRecord(index=len(s.picks) + 1)
        start = time.perf_counter()
        candidates = list(self._candidates.Eval(context))
        record.timing = replace(record.timing, perception_s=time.perf_counter() - start)
        scored = [ScoredCandidate(c, None, float(c.score)) for c in candidates]
        ranked = scored
        start = time.perf_counter()  # HasValue evaluates a connected port: the CNN runs here
        if self._scored.HasValue(context):
            selected = self._selected.Eval(context) if self._selected.HasValue(context) else None
            scored = list(self._scored.Eval(context))
            ranked = rank_scored(scored, selected)
            record.timing = replace(record.timing, cnn_s=time.perf_counter() - start)
        if self._settings.record_view and self._depth.HasValue(context):
            depth = np.array(self._depth.Eval(context).data)[:, :, 0]
            record.view = PickView(depth, scored[:VIEW_CANDIDATES])
        if not ranked:
            record.failure = FailureKind.NO_CANDIDATE
            record.reason = "no grasp candidate in the bin"
            return self._nothing_to_pick(context, s, record, t)
        plan = choose(record, ranked, self._motion, self._measured.Eval(context),
                      s.empty_grasps, self._settings.repeat_rule, self._tips_above(context))
        if plan is None:
            kinds = Counter(r.kind for r in record.rejected)
            record.failure = pick_failure(kinds)
            record.reason = "no candidate can be picked (" + ", ".join(
                f"{n} {kind.value}" for kind, n in kinds.items()) + ")"
            return self._nothing_to_pick(context, s, record, t)
        if self._settings.record_crop is not None and self._depth.HasValue(context):
            depth = np.asarray(self._depth.Eval(context).data)[:, :, 0]
            record.crop = candidate_crops(depth, self._intrinsics, [record.candidate],
                                          self._settings.record_crop)[0]
        record.timing = replace(record.timing, started_at=t)
        s = replace(s, plan=plan, record=record, started=t, width=self._settings.open_width)
        return self._enter(Mode.APPROACH, s, t)

    def _tips_above(self, context: Context) -> float | None:
        """Closed loop, where the bin is seen: the world height the lift takes the fingertips
        to, so that what hangs from them is weighed clear of the pile
        (``RecoverySettings.hanging_length``); ``None``: the approach's own lift height."""
        if self._recovery is None or self._recovery.hanging_length <= 0 \
                or not self._contents.HasValue(context):
            return None
        contents = self._contents.Eval(context)
        return contents.bin.floor_height + contents.top() + self._recovery.hanging_length

