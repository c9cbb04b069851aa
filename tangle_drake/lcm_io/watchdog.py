"""The robot side's command watchdog: a controller that stops sending must not leave the arm
running to its last command.

A real robot's driver does this (the bridge contract in ``docs/hardware.md``); the hardware
simulator plays it. Once commands have begun, a command channel silent for longer than
``hardware.command_timeout`` makes the arm hold the pose it measures at that moment, and says
so; fresh commands resume it (a restarted controller starts from the measured pose, as its
safety supervisor does). The gripper needs none: it keeps its last command, so a held part is
not dropped.
"""

from __future__ import annotations

import logging

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from tangle_drake.lcm_io.messages import Received

log = logging.getLogger(__name__)

_SEEN, _FRESH_AT, _HOLDING = 0, 1, 2
_HELD = 3  # the held pose starts here


class CommandWatchdog(LeafSystem):
    """Passes ``commanded`` to ``position`` while commands are fresh; holds the measured pose
    from the moment they are not.

    Inputs: ``received`` (the command subscriber's :class:`Received` record), ``commanded``
    (n), ``measured`` (n). Output: ``position`` (n).
    """

    def __init__(self, n: int, channel: str, timeout: float, period: float) -> None:
        super().__init__()
        self._channel = channel
        self._timeout = timeout
        self.DeclareAbstractInputPort("received", AbstractValue.Make(Received()))
        self.DeclareVectorInputPort("commanded", n)
        self.DeclareVectorInputPort("measured", n)
        self._state = self.DeclareDiscreteState(_HELD + n)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("position", n, self._position,
                                     prerequisites_of_calc={self.all_sources_ticket()})

    def holding(self, context: Context) -> bool:
        """Whether the arm is held because the commands stopped."""
        return context.get_discrete_state(self._state).GetAtIndex(_HOLDING) > 0.5

    def _update(self, context: Context, discrete: DiscreteValues) -> None:
        old = context.get_discrete_state(self._state).get_value()
        new = old.copy()
        t = context.get_time()
        seen = self.get_input_port(0).Eval(context).valid
        if seen != old[_SEEN]:
            new[_SEEN], new[_FRESH_AT] = seen, t
        stale = seen > 0 and t - new[_FRESH_AT] > self._timeout
        if stale and not old[_HOLDING]:
            new[_HOLDING] = 1.0
            new[_HELD:] = self.get_input_port(2).Eval(context)
            log.warning("robot side: no command on %s for %.2f s at t=%.3f s: holding the "
                        "measured pose until commands come again", self._channel,
                        t - new[_FRESH_AT], t)
        elif not stale and old[_HOLDING]:
            new[_HOLDING] = 0.0
            log.warning("robot side: commands on %s again at t=%.3f s: following them",
                        self._channel, t)
        discrete.get_mutable_vector(self._state).SetFromVector(new)

    def _position(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state).get_value()
        output.SetFromVector(state[_HELD:] if state[_HOLDING] > 0.5
                             else self.get_input_port(1).Eval(context))
