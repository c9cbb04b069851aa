"""How long each pick keeps the bin busy: the hand inside it, and the look before it.

A second arm can work the same bin only while the first is neither in it nor in the camera's
way, so these two times bound what two arms can deliver (about 3600 ÷ (hand in the bin + look)
parts per hour). :class:`BinTime` measures them from what the robot reports, so it reads the
same on hardware: at every planner tick, the fingertips' height from the carrier's measured
state (below the rim: in the bin) and the planner's mode (settling or perceiving: a look).
Time is booked to the pick in progress (a stir to the pick that asked for it), or, while none
is, to the next one (the look that chooses it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from tangle_drake.pick.modes import Mode
from tangle_drake.planning.motion import Motion
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.scenario import BinConfig

LOOK_MODES = (Mode.SETTLE, Mode.PERCEIVE)
"""The planner's modes of a look: waiting for the pile to rest, then the image and the choice."""


@dataclass(frozen=True)
class BinTimes:
    """Simulated (or controller) seconds per pick index: ``in_bin`` (the fingertips below the
    rim) and ``look`` (settling and perceiving); ``pending``: the same, booked so far to the
    pick that has not begun yet."""

    in_bin: dict[int, float] = field(default_factory=dict)
    look: dict[int, float] = field(default_factory=dict)
    pending: tuple[float, float] = (0.0, 0.0)


class BinTime(LeafSystem):
    """Inputs: the carrier's measured state (``motion.measured_port``), the planner's ``mode``
    and ``current_pick``; output ``bin_times``: a :class:`BinTimes`. Updated every ``period``
    (the planner's)."""

    def __init__(self, motion: Motion, bin_config: BinConfig, period: float,
                 spec: GripperSpec = DEFAULT_GRIPPER) -> None:
        super().__init__()
        self._motion, self._period = motion, period
        self._rim = bin_config.floor_height + bin_config.wall_height
        self._tips_below_tcp = spec.reach - spec.tcp_offset
        self._measured = self.DeclareVectorInputPort(motion.measured_port,
                                                     motion.measured_size)
        self._mode = self.DeclareAbstractInputPort("mode", AbstractValue.Make(Mode.SETTLE))
        self._current = self.DeclareAbstractInputPort("current_pick", AbstractValue.Make(None))
        self._state = self.DeclareAbstractState(AbstractValue.Make(BinTimes()))
        self.DeclareAbstractOutputPort(
            "bin_times", lambda: AbstractValue.Make(BinTimes()),
            lambda context, value: value.set_value(
                context.get_abstract_state(self._state).get_value()),
            {self.abstract_state_ticket(self._state)})
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)

    def _update(self, context: Context, state: State) -> None:
        times: BinTimes = context.get_abstract_state(self._state).get_value()
        tips = self._motion.tool_height(self._measured.Eval(context)) - self._tips_below_tcp
        in_bin = self._period if tips < self._rim else 0.0
        look = self._period if self._mode.Eval(context) in LOOK_MODES else 0.0
        if not in_bin and not look:
            return
        record = self._current.Eval(context)
        if record is None:
            times = BinTimes(times.in_bin, times.look,
                             (times.pending[0] + in_bin, times.pending[1] + look))
        else:
            index = record.index
            if index in times.in_bin:  # booked before: the pending time went to it then
                before, pending = (times.in_bin[index], times.look[index]), times.pending
            else:  # its first tick: what was booked to the next pick is its
                before, pending = times.pending, (0.0, 0.0)
            times = BinTimes({**times.in_bin, index: before[0] + in_bin},
                             {**times.look, index: before[1] + look}, pending)
        state.get_mutable_abstract_state(self._state).set_value(times)
