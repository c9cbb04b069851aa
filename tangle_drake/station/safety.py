"""The controller side's safety rules, between the pick diagram's commands and the robot.

- No command goes out before a fresh arm and gripper status has arrived; the first one is the
  measured pose, so a (re)started controller never makes the robot jump.
- A command past a joint's position or speed limit (read from the robot model) or the
  gripper's stroke is a fault: the arm is commanded to its last measured pose from then on, the
  gripper keeps its last command (a stop must not drop a held part), ``safety.fault`` turns 1
  so the planner stops its pick sequence, and the reason is logged and reported.
- Status older than ``hardware.status_timeout`` is a fault too, but no command goes out after
  it: the last measured pose is old, and the robot side's command watchdog holds the arm where
  it is and keeps the gripper's last command (``docs/hardware.md``).
- A fault stays until ``safety.reset`` rises; then the supervisor waits for fresh status again
  and restarts from the measured pose.
"""

from __future__ import annotations

import enum
import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, State

from tangle_drake.drivers.limits import RobotLimits
from tangle_drake.lcm_io.messages import Received
from tangle_drake.scenario.hardware import HardwareConfig

log = logging.getLogger(__name__)

_SLACK = 1e-9  # absolute tolerance on limits, for rounding in the planner's arithmetic


class Mode(enum.Enum):
    WAITING = "waiting"
    """No fresh status yet (or re-armed after a fault): nothing is sent."""
    RUNNING = "running"
    """Commands pass through, checked."""
    FAULT = "fault"
    """Holding: the arm at its measured pose, the gripper at its last command."""


@dataclass(frozen=True)
class SafetyReport:
    """What the supervisor last decided, for the planner, logs and people."""

    mode: Mode = Mode.WAITING
    message: str = ""
    """Why it stopped; empty unless ``mode`` is FAULT."""
    status_age: tuple[float, ...] = (math.inf, math.inf)
    """Seconds since the last fresh message of each status channel (arm, gripper, then the
    sensors), in the supervisor's ``status`` order."""
    rejected: tuple[int, ...] = (0, 0)
    """Messages refused so far on each status channel."""


@dataclass(frozen=True)
class _State:
    report: SafetyReport = SafetyReport()
    arm_command: np.ndarray = field(default_factory=lambda: np.zeros(0))
    gripper_command: float = 0.0
    seen: tuple[int, ...] = (0, 0)
    """Fresh message counts of each status channel at the last tick."""
    fresh_at: tuple[float, ...] = (-math.inf, -math.inf)
    """Times the counts last changed."""
    reset_input: float = 0.0
    lagging_since: float | None = None
    """Since when the arm has trailed its command by more than the tracking bound, s."""
    hold_by_command: bool = True
    """In a fault, whether the hold is commanded: not when status went stale, since the last
    measured pose is old then (the robot side's watchdog holds the arm instead)."""


class SafetySupervisor(LeafSystem):
    """Checks every command against fresh status and the robot's limits, at the command rate.

    The arm is the gripper's carrier, with ``len(limits.joint_names)`` joints. ``status`` maps
    each status input's name to its channel: ``arm`` and ``gripper`` first, then any sensor
    that must stay fresh (``wrist``); each is an input ``{name}_status``.

    Inputs: ``position_desired`` (n), ``gripper_desired`` (1), ``position_measured`` (n),
    ``gripper_measured`` ([width, rate]), ``{name}_status`` (:class:`Received` records),
    ``reset`` (optional, 1). Outputs: ``position_command``,
    ``gripper_command``, ``send`` (1 while commands may go out), ``fault``, ``ready`` (1 while
    commands pass through) and ``report`` (:class:`SafetyReport`).
    """

    def __init__(self, limits: RobotLimits, config: HardwareConfig,
                 status: dict[str, str]) -> None:
        super().__init__()
        n = len(limits.joint_names)
        self._limits = limits
        self._config = config
        self._period = config.command_period
        self._timeout = config.status_timeout
        self._channels = tuple(status.values())
        self._desired = self.DeclareVectorInputPort("position_desired", n)
        self._gripper_desired = self.DeclareVectorInputPort("gripper_desired", 1)
        self._measured = self.DeclareVectorInputPort("position_measured", n)
        self._gripper_measured = self.DeclareVectorInputPort("gripper_measured", 2)
        self._status = tuple(
            self.DeclareAbstractInputPort(f"{name}_status", AbstractValue.Make(Received()))
            for name in status)
        self._reset = self.DeclareVectorInputPort("reset", 1)
        k = len(status)
        self._state = self.DeclareAbstractState(AbstractValue.Make(_State(
            report=SafetyReport(status_age=(math.inf,) * k, rejected=(0,) * k),
            arm_command=np.zeros(n), seen=(0,) * k, fresh_at=(-math.inf,) * k)))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._update)

        ticket = {self.all_state_ticket()}
        self.DeclareVectorOutputPort(
            "position_command", n, lambda c, out: out.SetFromVector(self._get(c).arm_command),
            prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort(
            "gripper_command", 1, lambda c, out: out.SetAtIndex(0, self._get(c).gripper_command),
            prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort("send", 1, self._send, prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort(
            "fault", 1, lambda c, out: out.SetAtIndex(0, self._mode(c) is Mode.FAULT),
            prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort(
            "ready", 1, lambda c, out: out.SetAtIndex(0, self._mode(c) is Mode.RUNNING),
            prerequisites_of_calc=ticket)
        self.DeclareAbstractOutputPort(
            "report", lambda: AbstractValue.Make(SafetyReport()),
            lambda c, out: out.set_value(self._get(c).report), prerequisites_of_calc=ticket)

    def _get(self, context: Context) -> _State:
        return context.get_abstract_state(self._state).get_value()

    def _mode(self, context: Context) -> Mode:
        return self._get(context).report.mode

    def _send(self, context: Context, out) -> None:
        state = self._get(context)
        mode = state.report.mode
        out.SetAtIndex(0, mode is Mode.RUNNING or (mode is Mode.FAULT and state.hold_by_command))

    def _update(self, context: Context, state: State) -> None:
        old = self._get(context)
        t = context.get_time()
        records: list[Received] = [port.Eval(context) for port in self._status]
        seen = tuple(r.valid for r in records)
        fresh_at = tuple(t if now != before else at
                         for now, before, at in zip(seen, old.seen, old.fresh_at, strict=True))
        ages = tuple(t - at for at in fresh_at)
        reset = self._reset.Eval(context)[0] if self._reset.HasValue(context) else 0.0
        q_measured = self._measured.Eval(context)
        new = replace(old, seen=seen, fresh_at=fresh_at, reset_input=reset,
                      report=replace(old.report, status_age=ages,
                                     rejected=tuple(r.rejected for r in records)))
        mode = old.report.mode
        if mode is Mode.FAULT and reset > 0.5 >= old.reset_input:
            log.warning("safety: re-armed at t=%.3f s; waiting for fresh status", t)
            mode = Mode.WAITING
            new = replace(new, hold_by_command=True,
                          report=replace(new.report, mode=mode, message=""))
        if mode is Mode.WAITING:
            if min(seen) > 0 and max(ages) <= self._timeout:
                log.info("safety: status is fresh at t=%.3f s; commanding from the measured "
                         "pose", t)
                new = replace(new, arm_command=q_measured.copy(),
                              gripper_command=float(self._gripper_measured.Eval(context)[0]),
                              report=replace(new.report, mode=Mode.RUNNING))
        elif mode is Mode.RUNNING:
            q, width = self._desired_commands(context, old)
            lagging, new = self._tracking(new, old, q, q_measured, t)
            stale = self._stale(ages)
            problem = stale or self._arm_problem(q, old.arm_command) or \
                self._gripper_problem(width) or lagging
            if problem:
                log.error("safety stop at t=%.3f s: %s; %s, the pick sequence must stop", t,
                          problem, "sending no more commands" if stale
                          else "holding the measured pose")
                new = replace(new, arm_command=q_measured.copy(), hold_by_command=not stale,
                              report=replace(new.report, mode=Mode.FAULT, message=problem))
            else:
                new = replace(new, arm_command=q, gripper_command=width)
        state.get_mutable_abstract_state(self._state).set_value(new)

    def _tracking(self, new: _State, old: _State, q: np.ndarray, q_measured: np.ndarray,
                  t: float) -> tuple[str | None, _State]:
        """A problem if the arm has trailed its last command by more than
        max(``tracking_tolerance``, speed x ``tracking_lag``) on some joint for longer than
        ``tracking_time``: the normal servo lag never is (a blocked or dropped arm is)."""
        config = self._config
        speed = np.abs(q - old.arm_command) / self._period
        error = np.abs(old.arm_command - q_measured)
        bound = np.maximum(config.tracking_tolerance, speed * config.tracking_lag)
        over = error > bound
        if not over.any():
            return None, replace(new, lagging_since=None)
        since = t if old.lagging_since is None else old.lagging_since
        new = replace(new, lagging_since=since)
        if t - since < config.tracking_time:
            return None, new
        j = int(np.argmax(error - bound))
        return (f"{self._limits.joint_names[j]} trails its command by {error[j]:.4f} "
                f"{self._limits.units[j]} for {t - since:.2f} s (bound {bound[j]:.4f})"), new

    def _desired_commands(self, context: Context, old: _State) -> tuple[np.ndarray, float]:
        """The planner's commands; an unconnected input holds the last command."""
        q = self._desired.Eval(context).copy() if self._desired.HasValue(context) \
            else old.arm_command
        width = float(self._gripper_desired.Eval(context)[0]) \
            if self._gripper_desired.HasValue(context) else old.gripper_command
        return q, width

    def _stale(self, ages: tuple[float, ...]) -> str | None:
        for channel, age in zip(self._channels, ages, strict=True):
            if age > self._timeout:
                return (f"no valid {channel} for {age * 1e3:.0f} ms (timeout "
                        f"{self._timeout * 1e3:.0f} ms)")
        return None

    def _arm_problem(self, q: np.ndarray, previous: np.ndarray) -> str | None:
        limits = self._limits
        if not np.all(np.isfinite(q)):
            return f"non-finite arm command for {self._names(~np.isfinite(q))}"
        outside = (q < limits.position_lower - _SLACK) | (q > limits.position_upper + _SLACK)
        if outside.any():
            j = int(np.argmax(outside))
            return (f"command {q[j]:.4f} {limits.units[j]} for {limits.joint_names[j]} is "
                    "outside its limits "
                    f"[{limits.position_lower[j]:.4f}, {limits.position_upper[j]:.4f}]")
        speed = np.abs(q - previous) / self._period
        too_fast = speed > limits.velocity + _SLACK / self._period
        if too_fast.any():
            j = int(np.argmax(speed / limits.velocity))
            unit = f"{limits.units[j]}/s"
            return (f"command would move {limits.joint_names[j]} at {speed[j]:.2f} {unit}, "
                    f"above its limit {limits.velocity[j]:.2f} {unit}")
        return None

    def _gripper_problem(self, width: float) -> str | None:
        if not 0.0 <= width <= self._limits.gripper_max_width + _SLACK:
            return (f"gripper width command {width!r} m outside [0, "
                    f"{self._limits.gripper_max_width:g}]")
        return None

    def _names(self, mask: np.ndarray) -> str:
        return ", ".join(name for name, bad in zip(self._limits.joint_names, mask, strict=True)
                         if bad)
