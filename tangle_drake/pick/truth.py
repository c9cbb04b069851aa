"""Simulation only: what a pick truly brought up, recorded beside the planner, never read by it.

The planner judges a pick as a robot must (the fingers' opening; closed loop, the weighing)
and marks in its record when it judged (``PickRecord.truth_at``: ``check`` when it looked at
what came up, ``decided`` when it chose what to do with the load). :class:`PickTruth` samples
the lift and load-path monitors at every planner tick, from the same context the planner's
tick reads, and keeps the sample of each tick a record names: the truth at the very instant of
the judgement. :func:`with_truth` puts it into the record for the episode's result.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from tangle_drake.pick.outcome import PickRecord, classify_lift

CHECK = "check"
"""When the planner looked at what came up: parts lifted, held, and held but resting."""
DECIDED = "decided"
"""When the planner chose what to do with the load: parts held then."""


@dataclass(frozen=True)
class Sample:
    time: float
    lifted: int
    held: int
    resting: int


@dataclass(frozen=True)
class TruthState:
    last: Sample | None = None
    """The sample of the latest tick (a request made at that tick is seen one tick later)."""
    found: dict[tuple[int, str], Sample] = field(default_factory=dict)
    """The samples the records asked for, by (pick index, kind)."""


class PickTruth(LeafSystem):
    """Inputs ``lifted_count`` (:class:`~.outcome.LiftMonitor`), ``held_count``
    (:class:`~.load_path.LoadPathMonitor`) and the planner's ``current_pick`` and ``picks``;
    output ``truth``: a :class:`TruthState`. Updated at the planner's ``period``."""

    def __init__(self, period: float) -> None:
        super().__init__()
        self._lifted = self.DeclareVectorInputPort("lifted_count", 1)
        self._held = self.DeclareVectorInputPort("held_count", 2)
        self._current = self.DeclareAbstractInputPort("current_pick", AbstractValue.Make(None))
        self._picks = self.DeclareAbstractInputPort("picks", AbstractValue.Make([]))
        self._state = self.DeclareAbstractState(AbstractValue.Make(TruthState()))
        self.DeclareAbstractOutputPort(
            "truth", lambda: AbstractValue.Make(TruthState()),
            lambda context, value: value.set_value(
                context.get_abstract_state(self._state).get_value()),
            {self.abstract_state_ticket(self._state)})
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)

    def _update(self, context: Context, state: State) -> None:
        truth: TruthState = context.get_abstract_state(self._state).get_value()
        found = truth.found
        if truth.last is not None:
            records = [self._current.Eval(context), *self._picks.Eval(context)[-1:]]
            asked = {(record.index, kind) for record in records if record is not None
                     for kind, time in record.truth_at if time == truth.last.time}
            if asked - found.keys():
                found = {**found, **dict.fromkeys(asked - found.keys(), truth.last)}
        held, resting = (round(n) for n in self._held.Eval(context))
        sample = Sample(context.get_time(), round(self._lifted.Eval(context)[0]), held, resting)
        state.get_mutable_abstract_state(self._state).set_value(TruthState(sample, found))


def with_truth(record: PickRecord, truth: TruthState, empty_width: float) -> PickRecord:
    """``record`` with the simulation's counts at the moments it names, and its outcome judged
    by them (fingers closed past ``empty_width`` hold nothing; else the parts lifted)."""
    def sample(kind: str) -> Sample | None:
        time = dict(record.truth_at).get(kind)
        if time is None:
            return None
        if (record.index, kind) in truth.found:
            return truth.found[(record.index, kind)]
        return truth.last if truth.last is not None and truth.last.time == time else None

    checked, decided = sample(CHECK), sample(DECIDED)
    if checked is not None:
        record = replace(record, truth=replace(record.truth, lifted=checked.lifted,
                                               held=checked.held, resting=checked.resting),
                         outcome=classify_lift(record.width, checked.lifted, empty_width))
    if decided is not None:
        record = replace(record, truth=replace(record.truth, held_decided=decided.held))
    return record
