"""The pick episode: a pick diagram started from a settled pile, run until its picks are done.

:func:`run_picks` is the one run-until-done loop: the demo, the benchmark, the hardware loop
and the example all drive the pick diagram through it. :class:`PickEpisode` holds a pick
diagram's simulator and restarts it from any settled pile (the benchmark runs every method
on the same pile that way).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context

from tangle_drake.pick.diagram import PickDiagram
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.pick.planner import Mode
from tangle_drake.pick.truth import with_truth

POLL = 0.5
"""Simulated seconds between looks at the planner, s (picks are reported as they end)."""

SIM_TIME_PER_PICK = 60.0
"""Simulated seconds a pick may take before a run gives up, s (several times what a pick
takes; closed loop, a delivery may take several grasps, each with its weighing: twice this)."""


class Clock(Protocol):
    """What :func:`run_picks` drives: a ``Simulator``, or a ``HardwareInTheLoop``."""

    def get_context(self) -> Context: ...

    def AdvanceTo(self, time: float) -> None: ...


class RunEnd(enum.Enum):
    """Why :func:`run_picks` returned."""

    DONE = "done"
    """The planner finished: its picks were made, or nothing could be picked."""
    STOPPED = "safety stop"
    """The hardware station's safety supervisor stopped the robot."""
    TIMEOUT = "timeout"
    """The simulated time allowed ran out first."""
    PAUSED = "paused"
    """The planner entered the caller's ``pause_at`` mode; running again goes on from there."""


@dataclass(frozen=True)
class PickRun:
    """What one run of the pick diagram did."""

    records: list[PickRecord]
    end: RunEnd
    time: float
    """Simulated (or, on hardware, the controller's) time at the end, s."""
    safety_message: str | None = None
    """The supervisor's reason, for ``STOPPED``."""


def run_picks(clock: Clock, pick: PickDiagram, time_limit: float, *,
              on_pick: Callable[[PickRecord], None] | None = None,
              step: Callable[[Mode], float] | None = None,
              pause_at: Mode | None = None) -> PickRun:
    """Advance the pick diagram until its planner is done, the station's safety stops it,
    ``time_limit`` simulated seconds have passed, or it enters ``pause_at``.

    ``on_pick`` is called with each pick as it ends; ``step`` says how far to advance next
    given the planner's mode (default :data:`POLL`). The mode is looked at only between
    steps, so to pause at a mode that can be shorter than a step (a weighing), pass a
    shorter ``step``.
    """
    context = clock.get_context()
    mode_port = pick.diagram.GetOutputPort("mode")
    picks_port = pick.diagram.GetOutputPort("picks")

    def records() -> list[PickRecord]:
        """The planner's records; in simulation with what truly came up at each judgement."""
        found = list(picks_port.Eval(context))
        if pick.truth is None:
            return found
        truth = pick.diagram.GetOutputPort("truth").Eval(context)
        empty_width = pick.planner.settings.empty_width
        return [with_truth(record, truth, empty_width) for record in found]

    limit = context.get_time() + time_limit
    reported = 0
    end, message = RunEnd.DONE, None
    while (mode := mode_port.Eval(context)) is not Mode.DONE:
        if mode is Mode.STOPPED:
            end = RunEnd.STOPPED
            message = pick.station.GetOutputPort("safety.report").Eval(
                pick.station.GetMyContextFromRoot(context)).message
            break
        if mode is pause_at:
            end = RunEnd.PAUSED
            break
        if context.get_time() >= limit:
            end = RunEnd.TIMEOUT
            break
        clock.AdvanceTo(context.get_time() + (POLL if step is None else step(mode)))
        if on_pick is not None:
            done = records()
            for record in done[reported:]:
                on_pick(record)
            reported = len(done)
    return PickRun(records(), end, context.get_time(), message)


class PickEpisode:
    """A pick diagram's simulator, started from a settled pile as often as needed, each time
    from the diagram's initial state (so a run depends on its pile alone)."""

    def __init__(self, pick: PickDiagram) -> None:
        self.pick = pick
        self.simulator = Simulator(pick.diagram)
        self._initial = self.simulator.get_context().Clone()
        # Render once now: the renderer's first image costs more than the next ones
        # (VTK sets up its pipeline), which the first pick's perception would pay.
        station = pick.station
        station.GetOutputPort("camera.depth_image").Eval(
            station.GetMyContextFromRoot(self.simulator.get_context()))

    @property
    def context(self) -> Context:
        return self.simulator.get_mutable_context()

    def start(self, plant_state: np.ndarray,
              prepare: Callable[[Context], None] | None = None) -> None:
        """Reset to the initial state with the station's plant in ``plant_state`` (a
        ``SettledPile.state``); ``prepare`` may set inputs before the diagram initializes."""
        context = self.simulator.get_mutable_context()
        context.SetTimeStateAndParametersFrom(self._initial)
        self.pick.station.set_plant_state(context, plant_state)
        if prepare is not None:
            prepare(context)
        self.simulator.Initialize()

    def run(self, time_limit: float, **options) -> PickRun:
        """:func:`run_picks` on this episode's simulator."""
        return run_picks(self.simulator, self.pick, time_limit, **options)
