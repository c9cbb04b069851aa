"""The closed loop's modes of the pick planner: tare, weigh, shake, put back (:mod:`.recovery`
decides; this carries it out). A mixin of :class:`~tangle_drake.pick.planner.PickPlanner`,
which gives it its ports, settings, motion and ``_enter`` / ``_check``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from pydrake.systems.framework import Context
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.pick.modes import Mode, PlannerState
from tangle_drake.pick.outcome import Outcome
from tangle_drake.pick.payload import PayloadEstimate, PayloadPhase, PayloadRequest
from tangle_drake.pick.recovery import (
    Disposition,
    Recovery,
    Verdict,
    after_put_back,
    after_weighing,
    judge,
)
from tangle_drake.planning.motion import PlanningError

FALLBACK = {Mode.SHAKE: Mode.WEIGH, Mode.SHAKE_OFF: Mode.WEIGH_OPEN, Mode.PUT_BACK: Mode.OPEN,
             Mode.RAISE: Mode.RETREAT}
"""Where a recovery move that cannot be planned goes instead: a shake is skipped, a put-back
releases where the tool is."""


class ClosedLoop:
    """TARE, WEIGH, WEIGH_OPEN and the recovery moves."""

    def _request(self, s: PlannerState, phase: PayloadPhase) -> PlannerState:
        """Ask the estimator for ``phase`` (a new request, unless idle; the same state
        object when nothing changes)."""
        if phase is PayloadPhase.IDLE and s.loop.request.phase is PayloadPhase.IDLE:
            return s
        serial = s.loop.request.serial + (phase is not PayloadPhase.IDLE)
        return replace(s, loop=replace(s.loop, request=PayloadRequest(phase, serial)))

    def _estimate(self, context: Context) -> PayloadEstimate:
        return self._payload.Eval(context) if self._payload.HasValue(context) \
            else PayloadEstimate()

    def _weighing(self, context: Context, s: PlannerState, elapsed: float) -> PlannerState:
        """TARE, WEIGH, WEIGH_OPEN: wait for the estimator (or the timeout), then act."""
        t = context.get_time()
        recovery = self._recovery
        estimate = self._estimate(context)
        if s.mode is Mode.TARE:
            if estimate.tared or elapsed >= recovery.tare_timeout:
                return self._enter(Mode.DESCEND, s, t)
            return s
        width = float(self._gripper.Eval(context)[0])
        closed_empty = s.mode is Mode.WEIGH and width < self._settings.empty_width
        if not (estimate.ready or closed_empty) and elapsed < recovery.weigh_timeout:
            return s  # (fingers closed on nothing need no weighing)
        verdict = judge(width, estimate if estimate.ready else None, self._settings.empty_width)
        loop = replace(s.loop, support=estimate.support)
        record = s.record
        if s.mode is Mode.WEIGH_OPEN:
            step = after_put_back(verdict, loop.shakes_off, recovery)
            if step is Recovery.SHAKE_OFF:
                record = replace(record, recoveries=[*record.recoveries, step])
                return self._enter(Mode.SHAKE_OFF, replace(s, record=record, loop=replace(
                    loop, shakes_off=loop.shakes_off + 1)), t)
            return self._enter(Mode.RAISE, replace(s, record=replace(record, disposition=step),
                                                   loop=loop), t)
        if record.verdict is None:  # the first weighing: what came up
            record = self._check(context, record)
            if record.lifted is None:  # hardware: the weighing is all there is
                record = replace(record, outcome={Verdict.NONE: Outcome.NONE,
                                                  Verdict.ONE: Outcome.ONE,
                                                  Verdict.SEVERAL: Outcome.SEVERAL}.get(
                                                      verdict, Outcome.HELD))
            record = replace(record, estimate=estimate, verdict=verdict)
        step = after_weighing(verdict, loop.reweighs, loop.shakes, recovery)
        if isinstance(step, Disposition):
            record = replace(record, disposition=step)
            s = replace(s, record=record, loop=loop)
            if step is Disposition.DELIVERED:
                return self._enter(Mode.TRANSFER, s, t)
            return self._enter(Mode.RETREAT, replace(
                s, empty_grasps=(*s.empty_grasps, self._empty(record))), t)
        record = replace(record, recoveries=[*record.recoveries, step])
        if step is Recovery.REWEIGH:
            return self._enter(Mode.WEIGH, replace(s, record=record, loop=replace(
                loop, reweighs=loop.reweighs + 1)), t)
        if step is Recovery.SHAKE:
            return self._enter(Mode.SHAKE, replace(s, record=record, loop=replace(
                loop, shakes=loop.shakes + 1)), t)
        return self._enter(Mode.PUT_BACK, replace(s, record=record, loop=loop), t)

    def _plan_recovery(self, mode: Mode, s: PlannerState) -> PiecewisePolynomial | None:
        """The trajectory of a recovery move, planned from where the tool is; ``None`` if it
        cannot be (the planner then goes where :data:`FALLBACK` says)."""
        try:
            if mode in (Mode.SHAKE, Mode.SHAKE_OFF):
                return self._motion.plan_shake(s.hold)
            if mode is Mode.PUT_BACK:
                return self._motion.plan_lower(s.hold, s.plan.X_WT,
                                               self._recovery.put_back_clearance)
            top = s.plan.lift.value(s.plan.lift.end_time()).ravel()
            return self._motion.plan_line(s.hold, top)
        except PlanningError:
            return None

    def _put_back(self, context: Context, s: PlannerState) -> PlannerState:
        """During the put-back: stop and open once the load rests on the pile, that is once
        the wrist has carried ``recovery.put_back_force`` part weights less than at the
        weighing for ``recovery.put_back_samples`` looks in a row (one noisy sample is not
        contact)."""
        estimate = s.record.estimate
        if not self._wrench.HasValue(context) or not np.isfinite(s.loop.support) \
                or estimate is None or not np.isfinite(estimate.part_weight):
            return s
        limit = s.loop.support - self._recovery.put_back_force * estimate.part_weight
        resting = s.loop.resting + 1 if self._wrench.Eval(context)[2] < limit else 0
        if resting < self._recovery.put_back_samples:
            return s if resting == s.loop.resting else replace(
                s, loop=replace(s.loop, resting=resting))
        hold = self._motion.hold_command(self._measured.Eval(context))
        return self._enter(Mode.OPEN, replace(s, trajectory=None, hold=hold,
                                              loop=replace(s.loop, resting=0)),
                           context.get_time())
