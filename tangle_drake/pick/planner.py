"""``PickPlanner``: the pick state machine as a Drake system.

    SETTLE -> PERCEIVE -> APPROACH -> DESCEND -> CLOSE -> LIFT -> CHECK -> TRANSFER
           -> RELEASE -> HOME -> SETTLE ... -> DONE

SETTLE waits for the pile to come to rest (after the start, or the last pick). PERCEIVE reads
the perception inputs (so the camera renders, the graspability index and the CNN run, only
then), takes the candidates in the selection's order and asks the ``Motion`` to plan each
until one can be done; the others are recorded as rejected. The moving modes play the planned
trajectories; CLOSE waits for the arm to settle, then for the fingers, RELEASE for the
fingers; CHECK holds the part up and classifies
the pick: fingers closed past ``empty_width`` hold nothing (all a robot can tell), else the
``lifted_count`` input, where connected, says one or several. A grasp that came up empty is
not tried again (it left the pile as it was). After ``max_picks`` picks, or when nothing can
be picked (no candidate, none reachable: the next look would see the same pile), the planner
is DONE and holds still.

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
``lifted_count``             in     optional, simulation: parts brought up (``LiftMonitor``)
``safety.fault``             in     optional, hardware: 1 after the station's safety stop
``{motion.command_port}``    out    the manipulator's command (``nextage.position``)
``gripper.position``         out    commanded opening, m
``mode``                     out    the current :class:`Mode`
``picks``                    out    ``list[PickRecord]`` of the finished picks
============================ ====== ===================================================
"""

from __future__ import annotations

import enum
import time
from collections import Counter
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State
from pydrake.trajectories import PiecewisePolynomial

from tangle_drake.drivers.parallel_jaw import empty_grasp_width
from tangle_drake.failures import FailureKind, pick_failure
from tangle_drake.gripper import DEFAULT_GRIPPER
from tangle_drake.pick.outcome import Outcome, PickRecord, Rejection, classify_lift
from tangle_drake.planning.motion import Motion, PickMotion, PlanningError


class Mode(enum.Enum):
    """The state machine's modes, in the order one pick passes them."""

    SETTLE = "settle"
    PERCEIVE = "perceive"
    APPROACH = "approach"
    DESCEND = "descend"
    CLOSE = "close"
    LIFT = "lift"
    CHECK = "check"
    TRANSFER = "transfer"
    RELEASE = "release"
    HOME = "home"
    STOPPED = "stopped"
    """The station reported a safety stop: the pick in progress was abandoned."""
    DONE = "done"


# Moving modes: the PickMotion field each plays, and the mode that follows.
_MOVES = {Mode.APPROACH: ("approach", Mode.DESCEND), Mode.DESCEND: ("descend", Mode.CLOSE),
          Mode.LIFT: ("lift", Mode.CHECK), Mode.TRANSFER: ("transfer", Mode.RELEASE),
          Mode.HOME: ("home", Mode.SETTLE)}


@dataclass(frozen=True)
class PickSettings:
    """Timing and thresholds of the state machine (SI units)."""

    max_picks: int = 5
    settle_time: float = 0.3
    """Wait before each look, for the pile (and a part just dropped) to come to rest, s."""
    close_delay: float = 0.2
    """Wait at the bottom of the descent before closing, s: the arm tracks its command with a
    lag (servos, and on hardware the drivers' latency), and closing while it is still a few
    millimetres up closes on the top of the wire, which then slips out under the fingertips."""
    close_time: float = 0.4
    """From the close command to the lift, s (the fingers close in ~0.1 s, then squeeze)."""
    check_time: float = 0.3
    """Hold at the top of the lift before judging, so a loose part has time to drop, s."""
    release_time: float = 0.3
    """From the open command to the return home, s."""
    empty_width: float = empty_grasp_width(None)
    """Fingers closed further than this hold nothing, m (the rule of
    :func:`~tangle_drake.drivers.parallel_jaw.empty_grasp_width`; ``pick.diagram.pick_settings``
    gives it for the pile's own wire)."""
    open_width: float = DEFAULT_GRIPPER.max_opening
    """Opening for the approach, m."""
    update_period: float = 0.02
    """Period of the state machine's updates, s."""
    repeat_distance: float = 0.01
    """A candidate within this distance (m) of a grasp that came up empty, closing within
    ``repeat_angle_deg`` of it, repeats it and is skipped: an empty grasp leaves the pile much
    as it was, so the same candidate would come back, and fail again."""
    repeat_angle_deg: float = 20.0

    def __post_init__(self) -> None:
        if self.max_picks < 1:
            raise ValueError("PickSettings.max_picks must be at least 1")
        if self.close_delay < 0:
            raise ValueError("PickSettings.close_delay must be >= 0")
        for name in ("settle_time", "close_time", "check_time", "release_time",
                     "empty_width", "open_width", "update_period", "repeat_distance"):
            if not getattr(self, name) > 0:
                raise ValueError(f"PickSettings.{name} must be positive")


@dataclass(frozen=True)
class _State:
    """Everything the planner remembers (one abstract state value)."""

    mode: Mode
    since: float
    """Time the mode began, s."""
    hold: np.ndarray
    """The manipulator's command while no trajectory plays."""
    width: float
    """The gripper's command, m."""
    trajectory: PiecewisePolynomial | None = None
    """The mode's motion, played from ``since``."""
    plan: PickMotion | None = None
    record: PickRecord | None = None
    """The pick in progress."""
    started: float = 0.0
    """Time the pick in progress began to move, s."""
    picks: tuple[PickRecord, ...] = ()
    empty_grasps: tuple[np.ndarray, ...] = ()
    """Candidates' poses (X_WT) whose grasps came up empty: later looks skip repeats."""


class PickPlanner(LeafSystem):
    """The pick state machine (see the module docstring), driving ``motion``'s manipulator."""

    def __init__(self, motion: Motion, settings: PickSettings | None = None) -> None:
        super().__init__()
        self._motion = motion
        self._settings = settings or PickSettings()
        self._measured = self.DeclareVectorInputPort(motion.measured_port,
                                                     motion.measured_size)
        self._gripper = self.DeclareVectorInputPort("gripper.state_measured", 2)
        self._candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        self._scored = self.DeclareAbstractInputPort("scored_candidates",
                                                     AbstractValue.Make([]))
        self._selected = self.DeclareAbstractInputPort("selected_grasp",
                                                       AbstractValue.Make(None))
        self._lifted = self.DeclareVectorInputPort("lifted_count", 1)
        self._fault = self.DeclareVectorInputPort("safety.fault", 1)
        self._state = self.DeclareAbstractState(AbstractValue.Make(
            _State(Mode.SETTLE, 0.0, np.zeros(motion.command_size), self._settings.open_width)))
        depends = {self.time_ticket(), self.abstract_state_ticket(self._state)}
        self.DeclareVectorOutputPort(motion.command_port, motion.command_size,
                                     self._calc_command, depends)
        self.DeclareVectorOutputPort("gripper.position", 1, self._calc_width, depends)
        self.DeclareAbstractOutputPort(
            "mode", lambda: AbstractValue.Make(Mode.SETTLE),
            lambda context, value: value.set_value(self._get(context).mode), depends)
        self.DeclareAbstractOutputPort(
            "picks", lambda: AbstractValue.Make([]),
            lambda context, value: value.set_value(list(self._get(context).picks)), depends)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._settings.update_period, 0.0,
                                                    self._update)

    # --- outputs -----------------------------------------------------------------------------

    def _get(self, context: Context) -> _State:
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
        self._set(state, replace(self._get(context), since=context.get_time(), hold=hold))

    def _set(self, state: State, value: _State) -> None:
        state.get_mutable_abstract_state(self._state).set_value(value)

    def _update(self, context: Context, state: State) -> None:
        current = self._get(context)
        new = self._next(context, current)
        if new is not current:
            self._set(state, new)

    def _next(self, context: Context, s: _State) -> _State:
        """The state after one update: the same object when nothing changes."""
        t = context.get_time()
        elapsed = t - s.since
        settings = self._settings
        fault = self._fault.HasValue(context) and self._fault.Eval(context)[0] > 0.5
        if fault or s.mode is Mode.STOPPED:
            return self._safety(context, s, fault)
        if s.mode is Mode.SETTLE and elapsed >= settings.settle_time:
            return replace(s, mode=Mode.PERCEIVE, since=t)
        if s.mode is Mode.PERCEIVE:
            return self._perceive(context, s)
        if s.mode in _MOVES and elapsed >= s.trajectory.end_time():
            return self._enter(_MOVES[s.mode][1], s, t)
        if s.mode is Mode.CLOSE and elapsed >= settings.close_delay and s.width > 0:
            return replace(s, width=0.0)
        if s.mode is Mode.CLOSE and elapsed >= settings.close_delay + settings.close_time:
            return self._enter(Mode.LIFT, s, t)
        if s.mode is Mode.CHECK and elapsed >= settings.check_time:
            record = self._check(context, s.record)
            empty = s.empty_grasps + (
                (record.candidate.pose,) if record.outcome is Outcome.NONE else ())
            return self._enter(Mode.TRANSFER, replace(s, record=record, empty_grasps=empty), t)
        if s.mode is Mode.RELEASE and elapsed >= settings.release_time:
            return self._enter(Mode.HOME, s, t)
        return s

    def _enter(self, mode: Mode, s: _State, t: float) -> _State:
        """Switch to ``mode`` at time ``t``, holding where the last trajectory ended."""
        hold = s.hold if s.trajectory is None else s.trajectory.value(
            s.trajectory.end_time()).ravel()
        s = replace(s, mode=mode, since=t, hold=hold, trajectory=None)
        if mode in _MOVES:
            s = replace(s, trajectory=getattr(s.plan, _MOVES[mode][0]))
        if mode is Mode.RELEASE:
            s = replace(s, width=self._settings.open_width)
        if mode is Mode.SETTLE:  # back home: the pick is over
            record = replace(s.record, execution_s=t - s.started)
            s = self._finish(replace(s, plan=None, record=None), record, t)
        return s

    def _safety(self, context: Context, s: _State, fault: bool) -> _State:
        """Stop on a fault (the pick in progress fails), resume from the measured state once
        it clears; DONE stays DONE."""
        t = context.get_time()
        hold = self._motion.hold_command(self._measured.Eval(context))
        if fault and s.mode not in (Mode.STOPPED, Mode.DONE):
            stopped = replace(s, mode=Mode.STOPPED, since=t, hold=hold, trajectory=None,
                              plan=None, record=None)
            if s.record is None:
                return stopped
            record = replace(s.record, outcome=Outcome.FAILED, execution_s=t - s.started,
                             failure=FailureKind.SAFETY_STOP,
                             reason=f"safety stop during {s.mode.value}")
            return replace(stopped, picks=(*s.picks, record))
        if not fault and s.mode is Mode.STOPPED:
            done = len(s.picks) >= self._settings.max_picks
            return replace(s, mode=Mode.DONE if done else Mode.SETTLE, since=t, hold=hold)
        return s

    def _finish(self, s: _State, record: PickRecord, t: float) -> _State:
        picks = (*s.picks, record)
        done = len(picks) >= self._settings.max_picks or record.outcome is Outcome.FAILED
        return replace(s, picks=picks, mode=Mode.DONE if done else s.mode, since=t)

    # --- perceive, select, plan --------------------------------------------------------------

    def _perceive(self, context: Context, s: _State) -> _State:
        t = context.get_time()
        record = PickRecord(index=len(s.picks) + 1)
        start = time.perf_counter()
        candidates = list(self._candidates.Eval(context))
        record.perception_s = time.perf_counter() - start
        ranked: list[tuple[Any, float | None]] = [(c, None) for c in candidates]
        start = time.perf_counter()  # HasValue evaluates a connected port: the CNN runs here
        if self._scored.HasValue(context):
            selected = self._selected.Eval(context) if self._selected.HasValue(context) else None
            ranked = rank_scored(list(self._scored.Eval(context)), selected)
            record.cnn_s = time.perf_counter() - start
        if not ranked:
            record.failure = FailureKind.NO_CANDIDATE
            record.reason = "no grasp candidate in the bin"
            return self._finish(replace(s, mode=Mode.SETTLE), record, t)

        measured = self._measured.Eval(context)
        start = time.perf_counter()
        plan = None
        for rank, (candidate, p_not_tangled) in enumerate(ranked):
            if candidate.pose is None:
                record.rejected.append(Rejection(rank, FailureKind.NO_POSE,
                                                 "the candidate has no X_WT"))
                continue
            if self._repeats_empty_grasp(candidate.pose, s.empty_grasps):
                record.rejected.append(Rejection(rank, FailureKind.REPEAT,
                                                 "a grasp there came up empty"))
                continue
            try:
                plan = self._motion.plan_pick(candidate.pose, measured)
            except PlanningError as error:
                record.rejected.append(Rejection(rank, error.kind, error.detail))
                continue
            record.candidate, record.rank, record.p_not_tangled = candidate, rank, p_not_tangled
            break
        record.planning_s = time.perf_counter() - start
        if plan is None:
            kinds = Counter(r.kind for r in record.rejected)
            record.failure = pick_failure(kinds)
            record.reason = "no candidate can be picked (" + ", ".join(
                f"{n} {kind.value}" for kind, n in kinds.items()) + ")"
            return self._finish(replace(s, mode=Mode.SETTLE), record, t)
        s = replace(s, plan=plan, record=record, started=t, width=self._settings.open_width)
        return self._enter(Mode.APPROACH, s, t)

    def _repeats_empty_grasp(self, X_WT: np.ndarray, empty: tuple[np.ndarray, ...]) -> bool:
        cos_limit = np.cos(np.radians(self._settings.repeat_angle_deg))
        return any(np.linalg.norm(X_WT[:3, 3] - X[:3, 3]) < self._settings.repeat_distance
                   and abs(float(X_WT[:3, 1] @ X[:3, 1])) > cos_limit for X in empty)

    def _check(self, context: Context, record: PickRecord) -> PickRecord:
        """Classify the pick at the top of the lift: the fingers' opening first, then the
        simulation's count where it is connected."""
        width = float(self._gripper.Eval(context)[0])
        lifted = round(self._lifted.Eval(context)[0]) if self._lifted.HasValue(
            context) else None
        outcome = classify_lift(width, lifted, self._settings.empty_width)
        return replace(record, outcome=outcome, width=width, lifted=lifted)


def rank_scored(scored: list[Any], selected: Any = None) -> list[tuple[Any, float | None]]:
    """``(candidate, P(not tangled))`` in the selection's order (``scored_candidates`` are
    best first, :func:`~tangle_drake.tangle_cnn.selection.rank`), with ``selected`` at the
    front."""
    ranked = [(s.candidate, s.p_not_tangled) for s in scored]
    if selected is not None:
        key = (selected.u, selected.v, selected.angle_deg)
        front = [item for item in ranked if (item[0].u, item[0].v, item[0].angle_deg) == key]
        ranked = front + [item for item in ranked if item not in front]
    return ranked
