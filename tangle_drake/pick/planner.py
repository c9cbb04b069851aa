"""``PickPlanner``: the pick state machine as a Drake system.

Open loop (the paper's; ``PickSettings.recovery`` is ``None``)::

    SETTLE -> PERCEIVE -> APPROACH -> DESCEND -> CLOSE -> LIFT -> CHECK -> TRANSFER
           -> RELEASE -> HOME -> SETTLE ... -> DONE

Closed loop (``recovery`` set; :mod:`.recovery` says what follows a weighing)::

    ... APPROACH -> TARE -> DESCEND -> CLOSE -> LIFT -> WEIGH -+-> TRANSFER -> RELEASE -> HOME
                                                 |             +-> RETREAT (nothing came up)
                                                 +-> RETREAT, backing out (fingers closed early)
                        WEIGH again <- SHAKE <-----------------+
                        PUT_BACK -> OPEN -> WEIGH_OPEN (-> SHAKE_OFF) -> RAISE -> RETREAT
    PERCEIVE -> STIR -> SETTLE   (nothing to pick, or max_attempts grasps without a delivery)

SETTLE waits for the pile to come to rest (after the start, or the last pick). PERCEIVE reads
the perception inputs (so the camera renders, the graspability index and the CNN run, only
then), takes the candidates in the selection's order and asks the ``Motion`` to plan each until
one can be done (:mod:`.choose`); the others are recorded as rejected. The moving modes play
the planned trajectories; CLOSE waits for the arm to settle, then for the fingers, RELEASE for
the fingers. Open loop, CHECK holds the part up and classifies the pick as a robot can: fingers
closed past ``empty_width`` hold nothing, else they hold something. The planner never reads the
simulation's truth; its records say when they judged a pick, and in simulation the episode adds
what truly came up then (:mod:`.truth`). Closed loop, TARE has the wrist sensor tared at the
pre-grasp and WEIGH has the load weighed at the top of the lift (``payload.request`` to the
:class:`~tangle_drake.pick.payload.PayloadEstimator`, ``payload`` back); one part is delivered
to the tray, nothing is left for a fresh look, several are shaken and, if that does not help,
put back on the pile: lowered slowly until ``wrist.force_torque`` shows the load resting on the
pile, released, weighed again for a part hooked on a finger. Fingers that close on nothing
while the lift still retraces the descent (the part slid out of the grip as it came up) back
out the way the pick came, with no weighing. A grasp that came up empty is not tried again
while the pile there is unchanged. Open loop, after ``max_picks`` picks the planner is DONE;
closed loop, after ``max_picks`` deliveries, or ``recovery.max_attempts`` grasps in a row
without one (it gives up). When nothing can be picked (no candidate, none reachable: the next
look would see the same pile) it is DONE too, and holds still; closed loop, with the
``bin_contents`` input connected, it first stirs the bin (STIR: the closed fingers sweep
through what is left, :mod:`.stir`) if the bin does not look empty, and so it does after
``recovery.max_attempts`` grasps in a row without a delivery; after ``recovery.max_stirs``
stirs without a delivery it gives up.

On hardware the station's ``safety.fault`` may stop the robot at any time (stale status, a
command past a limit): the planner records the pick in progress as failed, STOPPED, and holds
the measured pose. When the fault clears (the station was reset), it carries on from the
measured state with a fresh look at the pile, as after a restart.

Everything lives in one abstract state value, updated by a periodic unrestricted event; the
commands are computed from it and the time, so a plan is played smoothly between events.

============================ ====== ===================================================
port                         dir    value
============================ ====== ===================================================
``{motion.measured_port}``   in     the manipulator's measured state (``nextage.state_measured``)
``gripper.state_measured``   in     [width, width rate]
``candidates``               in     grasp candidates, best first (``GraspabilitySystem``)
``scored_candidates``        in     optional: ``TangleCnnSystem``'s scored candidates, in
                                    its rule's order (best first); when connected, the
                                    planner tries them in that order
``selected_grasp``           in     optional, with ``scored_candidates``: the rule's choice,
                                    tried first
``payload``                  in     closed loop: the ``PayloadEstimator``'s estimate
``wrist.force_torque``       in     closed loop: the wrist sensor (the put-back's force limit)
``safety.fault``             in     optional, hardware: 1 after the station's safety stop
``bin_contents``             in     optional, closed loop: what the camera sees left in the
                                    bin (:class:`~tangle_drake.pick.bin_contents.BinContents`);
                                    when connected, the planner stirs a bin it cannot pick
                                    from instead of stopping
``depth_image``              in     optional, with ``settings.record_crop`` or
                                    ``record_view``: the camera's depth image, cropped into
                                    (or kept in) each record
``camera.image_time``        in     optional: when the camera's last image arrived
                                    (station time); a look waits for one newer than the
                                    arm's last motion
``{motion.command_port}``    out    the manipulator's command (``nextage.position``)
``gripper.position``         out    commanded opening, m
``payload.request``          out    what the ``PayloadEstimator`` should do now
``mode``                     out    the current :class:`Mode`
``picks``                    out    ``list[PickRecord]`` of the finished picks (grasps)
``current_pick``             out    the ``PickRecord`` of the grasp in progress (its
                                    candidate and, with ``record_view``, the look), or ``None``
============================ ====== ===================================================
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.common.failures import FailureKind
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.pick.choose import EmptyGrasp, rank_scored
from tangle_drake.pick.closed_loop import FALLBACK, ClosedLoop, with_reason
from tangle_drake.pick.modes import Mode, PickSettings, PlannerState
from tangle_drake.pick.outcome import (
    Outcome,
    PickRecord,
    classify_lift,
)
from tangle_drake.pick.payload import PayloadEstimate, PayloadPhase, PayloadRequest
from tangle_drake.pick.perception import Perception
from tangle_drake.pick.recovery import Disposition
from tangle_drake.pick.truth import CHECK
from tangle_drake.planning.motion import Motion

__all__ = ["Mode", "PickPlanner", "PickSettings", "rank_scored"]

_PLANNED = {Mode.APPROACH: "approach", Mode.DESCEND: "descend", Mode.LIFT: "lift",
            Mode.TRANSFER: "transfer", Mode.HOME: "home", Mode.RETREAT: "retreat"}
"""Moving modes that play a trajectory of the pick's ``PickMotion``."""
_MOVING = (*_PLANNED, Mode.SHAKE, Mode.PUT_BACK, Mode.SHAKE_OFF, Mode.RAISE)
"""Every mode that plays a trajectory (the others are planned when they begin), but STIR,
which the closed loop watches itself."""


class PickPlanner(Perception, ClosedLoop, LeafSystem):
    """The pick state machine (see the module docstring), driving ``motion``'s manipulator."""

    def __init__(self, motion: Motion, settings: PickSettings | None = None,
                 intrinsics: CameraIntrinsics | None = None) -> None:
        super().__init__()
        self._motion = motion
        self._settings = settings or PickSettings()
        if self._settings.record_crop is not None and intrinsics is None:
            raise ValueError("PickSettings.record_crop needs the camera's intrinsics")
        self._intrinsics = intrinsics
        self._recovery = self._settings.recovery
        self._measured = self.DeclareVectorInputPort(motion.measured_port,
                                                     motion.measured_size)
        self._gripper = self.DeclareVectorInputPort("gripper.state_measured", 2)
        self._candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        self._scored = self.DeclareAbstractInputPort("scored_candidates",
                                                     AbstractValue.Make([]))
        self._selected = self.DeclareAbstractInputPort("selected_grasp",
                                                       AbstractValue.Make(None))
        self._payload = self.DeclareAbstractInputPort("payload",
                                                      AbstractValue.Make(PayloadEstimate()))
        self._wrench = self.DeclareVectorInputPort("wrist.force_torque", 6)
        self._fault = self.DeclareVectorInputPort("safety.fault", 1)
        self._depth = self.DeclareAbstractInputPort("depth_image",
                                                    AbstractValue.Make(ImageDepth32F()))
        self._image_time = self.DeclareVectorInputPort("camera.image_time", 1)
        self._contents = self.DeclareAbstractInputPort("bin_contents",
                                                       AbstractValue.Make(None))
        self._state = self.DeclareAbstractState(AbstractValue.Make(
            PlannerState(Mode.SETTLE, 0.0, np.zeros(motion.command_size),
                         self._settings.open_width)))
        depends = {self.time_ticket(), self.abstract_state_ticket(self._state)}
        self.DeclareVectorOutputPort(motion.command_port, motion.command_size,
                                     self._calc_command, depends)
        self.DeclareVectorOutputPort("gripper.position", 1, self._calc_width, depends)
        self.DeclareAbstractOutputPort(
            "payload.request", lambda: AbstractValue.Make(PayloadRequest()),
            lambda context, value: value.set_value(self._get(context).loop.request), depends)
        self.DeclareAbstractOutputPort(
            "mode", lambda: AbstractValue.Make(Mode.SETTLE),
            lambda context, value: value.set_value(self._get(context).mode), depends)
        self.DeclareAbstractOutputPort(
            "picks", lambda: AbstractValue.Make([]),
            lambda context, value: value.set_value(list(self._get(context).picks)), depends)
        self.DeclareAbstractOutputPort(
            "current_pick", lambda: AbstractValue.Make(None),
            lambda context, value: value.set_value(self._get(context).record), depends)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._settings.update_period, 0.0,
                                                    self._update)

    @property
    def settings(self) -> PickSettings:
        return self._settings

    # --- outputs -----------------------------------------------------------------------------

    def _get(self, context: Context) -> PlannerState:
        return context.get_abstract_state(self._state).get_value()

    def _calc_command(self, context: Context, output: BasicVector) -> None:
        state = self._get(context)
        if state.trajectory is None:
            output.SetFromVector(state.hold)
        else:
            t = min(context.get_time() - state.since, state.trajectory.end_time())
            output.SetFromVector(state.trajectory.value(t).ravel())

    def _calc_width(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self._get(context).width)

    # --- events ------------------------------------------------------------------------------

    def _initialize(self, context: Context, state: State) -> None:
        hold = self._motion.hold_command(self._measured.Eval(context))
        s = self._get(context)
        can_stir = self._recovery is not None and self._recovery.max_stirs > 0 \
            and self._contents.HasValue(context)
        self._set(state, replace(s, since=context.get_time(), hold=hold,
                                 loop=replace(s.loop, can_stir=can_stir)))

    def _set(self, state: State, value: PlannerState) -> None:
        state.get_mutable_abstract_state(self._state).set_value(value)

    def _update(self, context: Context, state: State) -> None:
        current = self._get(context)
        new = self._next(context, current)
        if new is not current:
            self._set(state, new)

    def _next(self, context: Context, s: PlannerState) -> PlannerState:
        """The state after one update: the same object when nothing changes."""
        t = context.get_time()
        elapsed = t - s.since
        settings = self._settings
        fault = self._fault.HasValue(context) and self._fault.Eval(context)[0] > 0.5
        if fault or s.mode is Mode.STOPPED:
            return self._safety(context, s, fault)
        if s.mode is Mode.SETTLE and elapsed >= settings.settle_time:
            return self._look(context, s, t)
        if s.mode is Mode.PERCEIVE:
            return self._perceive(context, s)
        if s.mode is Mode.PUT_BACK and (stopped := self._put_back(context, s)) is not s:
            return stopped
        if s.mode is Mode.STIR:
            return self._stirring(context, s, t)
        if s.mode is Mode.LIFT and self._recovery is not None \
                and (backing := self._closed_on_nothing(context, s, t)) is not s:
            return backing
        if s.mode in _MOVING and elapsed >= s.trajectory.end_time():
            return self._enter(self._after_move(s.mode), s, t)
        if s.mode is Mode.CLOSE and elapsed >= settings.close_delay and s.width > 0:
            return replace(s, width=0.0)
        if s.mode is Mode.CLOSE and elapsed >= settings.close_delay + settings.close_time:
            return self._enter(Mode.LIFT, s, t)
        if s.mode is Mode.CHECK and elapsed >= settings.check_time:
            record = self._check(context, s.record)
            empty = (*s.empty_grasps, self._empty(record)) if record.outcome is Outcome.NONE \
                else s.empty_grasps
            return self._enter(Mode.TRANSFER, replace(s, record=record, empty_grasps=empty), t)
        # Closed loop, the arm settles over the tray before the fingers open (it lags its
        # command, and a part let go while it still moves is flung past the tray).
        settle = settings.close_delay if self._recovery is not None else 0.0
        if s.mode is Mode.RELEASE and elapsed >= settle and s.width < settings.open_width:
            return replace(s, width=settings.open_width)
        if s.mode is Mode.RELEASE and elapsed >= settle + settings.release_time:
            return self._enter(Mode.HOME, s, t)
        if s.mode is Mode.OPEN and elapsed >= settings.release_time:
            return self._enter(Mode.WEIGH_OPEN, s, t)
        if s.mode in (Mode.TARE, Mode.WEIGH, Mode.WEIGH_OPEN):
            return self._weighing(context, s, elapsed)
        return s

    def _after_move(self, mode: Mode) -> Mode:
        """The mode that follows a finished move."""
        closed = self._recovery is not None
        return {Mode.APPROACH: Mode.TARE if closed else Mode.DESCEND, Mode.DESCEND: Mode.CLOSE,
                Mode.LIFT: Mode.WEIGH if closed else Mode.CHECK, Mode.TRANSFER: Mode.RELEASE,
                Mode.HOME: Mode.SETTLE, Mode.RETREAT: Mode.SETTLE, Mode.SHAKE: Mode.WEIGH,
                Mode.PUT_BACK: Mode.OPEN, Mode.SHAKE_OFF: Mode.WEIGH_OPEN,
                Mode.RAISE: Mode.RETREAT}[mode]

    def _enter(self, mode: Mode, s: PlannerState, t: float) -> PlannerState:
        """Switch to ``mode`` at time ``t``, holding where the last trajectory ended."""
        hold = s.hold if s.trajectory is None else s.trajectory.value(
            s.trajectory.end_time()).ravel()
        s = replace(s, mode=mode, since=t, hold=hold, trajectory=None)
        if mode in _PLANNED:
            s = replace(s, trajectory=getattr(s.plan, _PLANNED[mode]))
        # The estimator tares or weighs in these modes only (a stop at the grasp, pressing
        # into the pile, must not be taken for the empty gripper's weight).
        s = self._request(s, {Mode.TARE: PayloadPhase.TARE, Mode.WEIGH: PayloadPhase.WEIGH,
                              Mode.WEIGH_OPEN: PayloadPhase.WEIGH}.get(mode, PayloadPhase.IDLE))
        if mode in (Mode.SHAKE, Mode.SHAKE_OFF, Mode.PUT_BACK, Mode.RAISE):
            trajectory = self._plan_recovery(mode, s)
            if trajectory is None:
                return self._enter(FALLBACK[mode], s, t)
            s = replace(s, trajectory=trajectory)
        if mode is Mode.OPEN or (mode is Mode.RELEASE and self._recovery is None):
            s = replace(s, width=self._settings.open_width)
        if mode is Mode.SETTLE:  # back home: the pick is over
            record = replace(s.record, timing=replace(s.record.timing, execution_s=t - s.started,
                                                      started_at=s.started))
            s = self._finish(replace(s, plan=None, record=None), record, t)
        return s

    def _safety(self, context: Context, s: PlannerState, fault: bool) -> PlannerState:
        """Stop on a fault (the pick in progress fails), resume from the measured state once
        it clears; DONE stays DONE."""
        t = context.get_time()
        hold = self._motion.hold_command(self._measured.Eval(context))
        if fault and s.mode not in (Mode.STOPPED, Mode.DONE):
            stopped = replace(s, mode=Mode.STOPPED, since=t, hold=hold, trajectory=None,
                              plan=None, record=None)
            if s.record is None:
                return stopped
            stirring = s.mode is Mode.STIR or s.loop.stir_due  # the grasp itself is over
            record = with_reason(s.record, "a safety stop came before the stir's end") \
                if stirring else replace(
                    s.record, outcome=Outcome.FAILED, failure=FailureKind.SAFETY_STOP,
                    timing=replace(s.record.timing, execution_s=t - s.started,
                                   started_at=s.started),
                    reason=f"safety stop during {s.mode.value}")
            return replace(stopped, picks=(*s.picks, record))
        if not fault and s.mode is Mode.STOPPED:
            return replace(s, mode=Mode.DONE if self._done(s) else Mode.SETTLE, since=t,
                           hold=hold)
        return s

    def _done(self, s: PlannerState) -> bool:
        if self._recovery is None:
            return len(s.picks) >= self._settings.max_picks
        return s.loop.deliveries >= self._settings.max_picks

    def _finish(self, s: PlannerState, record: PickRecord, t: float) -> PlannerState:
        loop = s.loop
        if self._recovery is not None and record.outcome is not Outcome.FAILED:
            delivered = record.disposition is Disposition.DELIVERED
            loop = replace(loop, deliveries=loop.deliveries + delivered,
                           attempts=0 if delivered else loop.attempts + 1,
                           stirs=0 if delivered else loop.stirs)
            if loop.attempts >= self._recovery.max_attempts:
                if self._may_stir(loop):  # the next look stirs; the record waits for it
                    return replace(s, record=record, since=t, loop=replace(
                        loop, stir_due=True, reweighs=0, shakes=0, shakes_off=0))
                s = replace(s, picks=(*s.picks, record))
                record = self._gave_up(len(s.picks) + 1, loop)
        picks = (*s.picks, record)
        s = replace(s, picks=picks, loop=replace(loop, reweighs=0, shakes=0, shakes_off=0))
        done = self._done(s) or picks[-1].outcome is Outcome.FAILED
        return replace(s, mode=Mode.DONE if done else s.mode, since=t)

    # --- perceive, select, plan --------------------------------------------------------------

    @staticmethod
    def _empty(record: PickRecord) -> EmptyGrasp:
        return EmptyGrasp(record.candidate.pose, float(record.candidate.depth_m))

    def _check(self, context: Context, record: PickRecord) -> PickRecord:
        """Classify the pick at the top of the lift as a robot can: fingers closed past
        ``empty_width`` hold nothing, else they hold something (open loop nothing tells how
        much). The record marks the instant, where the simulation's truth is taken."""
        width = float(self._gripper.Eval(context)[0])
        outcome = classify_lift(width, None, self._settings.empty_width)
        return replace(record, outcome=outcome, width=width,
                       truth_at=(*record.truth_at, (CHECK, context.get_time())))

