"""The closed loop's modes of the pick planner: tare, weigh, shake, put back, stir the bin
(:mod:`.recovery` decides; this carries it out). A mixin of
:class:`~tangle_drake.pick.planner.PickPlanner`, which gives it its ports, settings, motion and
``_enter`` / ``_check`` / ``_finish``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from pydrake.systems.framework import Context
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.common.failures import FailureKind
from tangle_drake.pick.modes import Loop, Mode, PlannerState
from tangle_drake.pick.outcome import Outcome, PickRecord
from tangle_drake.pick.payload import PayloadEstimate, PayloadPhase, PayloadRequest
from tangle_drake.pick.recovery import (
    Disposition,
    Recovery,
    Verdict,
    after_put_back,
    after_weighing,
    judge,
)
from tangle_drake.pick.stir import looks_empty, stir_line, stir_poses
from tangle_drake.pick.truth import DECIDED
from tangle_drake.planning.motion import PlanningError
from tangle_drake.planning.trajectory import chain

RETRACE_TOLERANCE = 1e-9
"""How near (rad or m) the back-out's command must be to the lift's for the planner to switch
to it: they are the same leg while the lift retraces the descent."""

FALLBACK = {Mode.SHAKE: Mode.WEIGH, Mode.SHAKE_OFF: Mode.WEIGH_OPEN, Mode.PUT_BACK: Mode.OPEN,
             Mode.RAISE: Mode.RETREAT}
"""Where a recovery move that cannot be planned goes instead: a shake is skipped, a put-back
releases where the tool is."""


def with_reason(record: PickRecord, words: str) -> PickRecord:
    """``record`` with ``words`` added to its reason."""
    return replace(record, reason=words if not record.reason else f"{record.reason}; {words}")


class ClosedLoop:
    """TARE, WEIGH, WEIGH_OPEN, the recovery moves and the stir."""

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
            record = self._came_up(context, record, verdict, estimate)
        step = after_weighing(verdict, loop.reweighs, loop.shakes, recovery)
        if isinstance(step, Disposition):
            s = replace(s, record=self._decided(context, record, step), loop=loop)
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

    def _came_up(self, context: Context, record: PickRecord, verdict: Verdict,
                 estimate: PayloadEstimate | None) -> PickRecord:
        """``record`` with what the first look at the load said came up: the weighing is all
        a robot has (in simulation the episode adds what did, taken at this instant)."""
        record = self._check(context, record)
        outcome = {Verdict.NONE: Outcome.NONE, Verdict.ONE: Outcome.ONE,
                   Verdict.SEVERAL: Outcome.SEVERAL}.get(verdict, Outcome.HELD)
        return replace(record, outcome=outcome, estimate=estimate, verdict=verdict)

    def _decided(self, context: Context, record: PickRecord,
                 disposition: Disposition) -> PickRecord:
        """``record`` with where the load goes, and the instant it was decided (where the
        simulation's count of what the gripper held is taken)."""
        return replace(record, disposition=disposition,
                       truth_at=(*record.truth_at, (DECIDED, context.get_time())))

    def _closed_on_nothing(self, context: Context, s: PlannerState, t: float) -> PlannerState:
        """During the lift: fingers closed past ``empty_width`` hold nothing (the part slid
        out of the grip as it came up, or there was none). While the lift still retraces the
        descent, go back out the way the pick came in (``PickMotion.back_out``) rather than up
        to the weighing and over to home; past that, lift on (the weighing needs no wait)."""
        width = float(self._gripper.Eval(context)[0])
        if judge(width, None, self._settings.empty_width) is not Verdict.NONE:
            return s
        played = t - s.since
        back_out, lift = s.plan.back_out, s.plan.lift
        if played > back_out.end_time() or not np.allclose(
                back_out.value(played), lift.value(played), rtol=0.0, atol=RETRACE_TOLERANCE):
            return s
        record = self._came_up(context, s.record, Verdict.NONE, None)
        record = with_reason(self._decided(context, replace(
            record, recoveries=[*record.recoveries, Recovery.BACK_OUT]), Disposition.EMPTY),
            f"the fingers closed on nothing {played:.2f} s into the lift: backed out the way "
            "the pick came")
        # RETREAT, playing the back-out from where the lift has got to.
        return replace(s, mode=Mode.RETREAT, since=t - played, trajectory=back_out,
                       record=record, empty_grasps=(*s.empty_grasps, self._empty(record)))

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

    # --- stirring the bin -------------------------------------------------------------------

    def _may_stir(self, loop: Loop) -> bool:
        return loop.can_stir and loop.stirs < self._recovery.max_stirs

    def _nothing_to_pick(self, context: Context, s: PlannerState, record: PickRecord,
                         t: float) -> PlannerState:
        """A look that found nothing to pick (``record``, failed): stir the bin where stirs
        are left, else the run ends."""
        if self._may_stir(s.loop):
            return self._stir(context, s, t, record)
        return self._finish(replace(s, mode=Mode.SETTLE), record, t)

    def _stir(self, context: Context, s: PlannerState, t: float,
              record: PickRecord) -> PlannerState:
        """Sweep the closed fingers through what is left in the bin (:mod:`.stir`), then look
        again. ``record`` asked for it: a look that found nothing to pick, or (``stir_due``)
        the last of ``max_attempts`` grasps without a delivery; it is reported once the stir
        is over. Where the bin looks empty or the sweep cannot be planned, the run ends as it
        would have without stirring."""
        settings = self._recovery.stir
        contents = self._contents.Eval(context)
        line = stir_line(contents, settings)
        why = None
        if line is None:
            why = "the bin looks empty" if looks_empty(contents, settings) else \
                "the bin is too small to stir"
        else:
            rim = contents.bin.floor_height + contents.bin.wall_height
            try:
                stir = self._motion.plan_stir(s.hold, stir_poses(line, rim), settings.speed)
            except PlanningError as error:
                why = f"the stir cannot be planned ({error})"
        looked = not s.loop.stir_due  # else the grasps that came up empty asked for it
        loop = replace(s.loop, stir_due=False)
        if why is not None:
            s = replace(s, mode=Mode.SETTLE, record=None, loop=loop)
            if looked:
                return self._finish(s, with_reason(record, why), t)
            s = replace(s, picks=(*s.picks, record))
            return self._finish(s, self._gave_up(len(s.picks) + 1, loop, why), t)
        record = replace(record, recoveries=[*record.recoveries, Recovery.STIR])
        begins = stir.approach.end_time()
        return replace(s, mode=Mode.STIR, since=t, width=0.0, record=record, empty_grasps=(),
                       trajectory=chain([stir.approach, stir.sweep, stir.home]),
                       loop=replace(loop, stirs=loop.stirs + 1, attempts=0, backing_out=False,
                                    sweep=(begins, begins + stir.sweep.end_time())))

    def _stirring(self, context: Context, s: PlannerState, t: float) -> PlannerState:
        """During the stir: once it is over, report the record that asked for it and look
        again; if the wrist feels more than ``stir.force_limit`` across, the sweep has met
        something it must not push: go back the way it came."""
        played = t - s.since
        if played >= s.trajectory.end_time():
            hold = s.trajectory.value(s.trajectory.end_time()).ravel()
            return replace(s, mode=Mode.SETTLE, since=t, hold=hold, trajectory=None,
                           record=None, picks=(*s.picks, s.record))
        # Only in the bin: a fast free move on the way there shakes the wrist's reading too.
        in_bin = s.loop.sweep[0] <= played <= s.loop.sweep[1]
        if s.loop.backing_out or not in_bin or not self._wrench.HasValue(context):
            return s
        force = float(np.hypot(*self._wrench.Eval(context)[:2]))
        if force <= self._recovery.stir.force_limit:
            return s
        return replace(s, since=t, trajectory=_back(s.trajectory, played),
                       record=with_reason(s.record, f"the stir met {force:.0f} N and backed out"),
                       loop=replace(s.loop, backing_out=True))

    @staticmethod
    def _gave_up(index: int, loop: Loop, why: str | None = None) -> PickRecord:
        """The record of giving up on the bin."""
        reason = f"{loop.attempts} grasps in a row delivered nothing"
        if loop.stirs:
            reason += f", {loop.stirs} stir{'s' * (loop.stirs > 1)} since the last delivery"
        return PickRecord(index=index, failure=FailureKind.GAVE_UP,
                          reason=reason if why is None else f"{reason}; {why}")


BACK_STEP = 0.02
"""Sampling of a move played backwards, s."""


def _back(trajectory: PiecewisePolynomial, played: float) -> PiecewisePolynomial:
    """The first ``played`` seconds of ``trajectory`` played backwards, at the same pace: the
    way it came, which was clear, back to where it began."""
    times = np.linspace(0.0, played, max(2, int(np.ceil(played / BACK_STEP)) + 1))
    values = np.column_stack([trajectory.value(played - time).ravel() for time in times])
    return PiecewisePolynomial.FirstOrderHold(times, values)
