"""A scripted controller for checking a station end to end without the pick planner.

It waits for ``safety.ready``, then, starting from the measured pose, moves the carrier a
little with a smooth profile (the Nextage's left arm part of the way to ``init_rtm``, the
gantry down and round), closes the gripper, and opens it fully. On
``safety.fault`` it stops; when ``safety.ready`` comes back (after ``safety.reset``) it starts
again from the then measured pose. ``tangle-drake hardware-sim --check`` and the tests use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    LeafSystem,
    State,
)

from tangle_drake.drivers.joint_position import home_positions
from tangle_drake.drivers.registry import carrier
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import HOME, INIT_RTM
from tangle_drake.scenario import Scenario
from tangle_drake.scenario.drivers import NextageDriver

PEAK_SPEED = 0.5 * math.pi / 2
"""Fastest joint speed of the scripted move, rad/s: well under every joint's limit."""
GRIPPER_TIME = 0.4
"""Seconds to close, and to open, the gripper."""
HOLD_TIME = 0.2
"""Seconds the gripper stays closed."""


GANTRY_MOVE = np.array([0.0, 0.0, -0.05, 0.3])
"""The gantry's scripted move from home: 5 cm down, 0.3 rad round (m, m, m, rad)."""


def default_target() -> np.ndarray:
    """HOME with the left arm 40 % of the way to ``init_rtm``: a move in free space."""
    return HOME + 0.4 * (INIT_RTM - HOME)


def scripted_target(scenario: Scenario) -> np.ndarray:
    """Where the scripted move takes the scenario's carrier: a move in free space."""
    _, config = carrier(scenario.model_drivers)
    if isinstance(config, NextageDriver):
        return default_target()
    return home_positions(config, scenario) + GANTRY_MOVE


@dataclass(frozen=True)
class _Run:
    start: float
    q0: np.ndarray
    width0: float


class ScriptedMotion(LeafSystem):
    """Arm move, gripper close, gripper open; see the module docstring.

    Inputs: ``position_measured`` (n, the target's size), ``gripper_state`` (2), ``ready``
    (1), ``fault`` (1). Outputs: ``position`` (n), ``gripper_position`` (1), ``done`` (1).
    """

    def __init__(self, target: np.ndarray, open_width: float, period: float) -> None:
        super().__init__()
        n = len(target)
        self._target = np.asarray(target, dtype=float)
        self._open_width = open_width
        self._measured = self.DeclareVectorInputPort("position_measured", n)
        self._gripper = self.DeclareVectorInputPort("gripper_state", 2)
        self._ready = self.DeclareVectorInputPort("ready", 1)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self._run = self.DeclareAbstractState(AbstractValue.Make(None))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("position", n, self._calc_position)
        self.DeclareVectorOutputPort("gripper_position", 1, self._calc_gripper)
        self.DeclareVectorOutputPort("done", 1, self._calc_done)

    def _update(self, context: Context, state: State) -> None:
        run = context.get_abstract_state(self._run).get_value()
        if self._fault.Eval(context)[0] > 0.5:
            run = None
        elif run is None and self._ready.Eval(context)[0] > 0.5:
            run = _Run(context.get_time(), self._measured.Eval(context).copy(),
                       float(self._gripper.Eval(context)[0]))
        state.get_mutable_abstract_state(self._run).set_value(run)

    def _move_time(self, run: _Run) -> float:
        # A cosine profile peaks at pi/2 times the mean speed.
        return max(0.5, float(np.max(np.abs(self._target - run.q0))) * math.pi / 2 / PEAK_SPEED)

    def _times(self, context: Context) -> tuple[_Run | None, float]:
        run = context.get_abstract_state(self._run).get_value()
        return run, (context.get_time() - run.start if run else 0.0)

    def _calc_position(self, context: Context, out: BasicVector) -> None:
        run, tau = self._times(context)
        if run is None:
            out.SetFromVector(self._measured.Eval(context))
            return
        s = min(tau / self._move_time(run), 1.0)
        out.SetFromVector(run.q0 + (self._target - run.q0) * (1 - math.cos(math.pi * s)) / 2)

    def _calc_gripper(self, context: Context, out: BasicVector) -> None:
        run, tau = self._times(context)
        if run is None:
            out.SetAtIndex(0, self._gripper.Eval(context)[0])
            return
        t = tau - self._move_time(run)
        closing = min(max(t / GRIPPER_TIME, 0.0), 1.0)
        opening = min(max((t - GRIPPER_TIME - HOLD_TIME) / GRIPPER_TIME, 0.0), 1.0)
        width = run.width0 * (1 - closing) if opening == 0.0 else self._open_width * opening
        out.SetAtIndex(0, width)

    def _calc_done(self, context: Context, out: BasicVector) -> None:
        run, tau = self._times(context)
        end = self._move_time(run) + 2 * GRIPPER_TIME + HOLD_TIME if run else math.inf
        out.SetAtIndex(0, float(tau >= end))


def scripted_controller(station: Diagram, target: np.ndarray | None = None,
                        open_width: float | None = None, period: float = 0.005) -> Diagram:
    """The root diagram: ``station`` (a hardware station) driven by :class:`ScriptedMotion`;
    ``target`` defaults to :func:`scripted_target` of the station's scenario."""
    builder = DiagramBuilder()
    builder.AddSystem(station)
    name, _ = carrier(station.scenario.model_drivers)
    script = builder.AddNamedSystem("script", ScriptedMotion(
        scripted_target(station.scenario) if target is None else target,
        DEFAULT_GRIPPER.max_opening if open_width is None else open_width, period))
    for source, sink in ((f"{name}.position_measured", "position_measured"),
                         ("gripper.state_measured", "gripper_state"),
                         ("safety.ready", "ready"), ("safety.fault", "fault")):
        builder.Connect(station.GetOutputPort(source), script.GetInputPort(sink))
    builder.Connect(script.GetOutputPort("position"), station.GetInputPort(f"{name}.position"))
    builder.Connect(script.GetOutputPort("gripper_position"),
                    station.GetInputPort("gripper.position"))
    builder.ExportOutput(script.GetOutputPort("done"), "script.done")
    diagram = builder.Build()
    diagram.set_name("scripted_controller")
    return diagram
