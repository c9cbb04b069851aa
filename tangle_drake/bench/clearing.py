"""Bin clearing: each method empties the same full pile into the tray, as a factory would.

A bin is (part, trial index), its pile seed the same as the pick benchmark's trial of that
index, so every method clears the same piles. Each method runs closed loop (weigh, shake, put
back; ``--open-loop``: the paper's one look, one grasp) from the full settled pile until the
planner is done: the bin is empty, nothing can be picked, or ``max_attempts`` grasps in a row
delivered nothing (each clearing records why it ended). Every grasp is recorded with what
the simulation saw land in the tray (the tray's count before and after it, not the
estimator's word), so deliveries of several parts, and several read as one, are counted by
the truth.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable

import numpy as np
from pydrake.systems.framework import Context

from tangle_drake.bench.trials import BenchConfig, PartSpec, method_seed, part_scenario, pile_seed
from tangle_drake.episode.episode import Episode
from tangle_drake.episode.run import POLL, PickRun, RunEnd
from tangle_drake.pick.bin_time import BinTimes
from tangle_drake.pick.diagram import PickDiagram
from tangle_drake.pick.modes import Mode
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.scenario import BinConfig
from tangle_drake.selection.methods import MethodRun
from tangle_drake.station.bin_model import inside_bin

SIM_TIME_PER_PART = 40.0
"""Simulated seconds allowed per part in the pile before a clearing is stopped, s."""


class ClearWorker:
    """Clears bins (``(part index, trial index)``) for a :class:`BenchConfig` with ``clear``
    set; keeps each part's episode once built. With ``progress_interval_s``, says where a bin
    stands at most that often (wall time): a full bin takes the best part of an hour."""

    def __init__(self, config: BenchConfig, progress_interval_s: float | None = None) -> None:
        self.config = config
        self.progress_interval_s = progress_interval_s
        self._rigs: dict[str, Episode] = {}

    def run_task(self, task: tuple[int, int]) -> dict:
        part_index, trial = task
        spec = self.config.parts[part_index]
        start, cpu = time.perf_counter(), time.process_time()
        rig = self._rig_for(spec)
        seed = pile_seed(self.config.seed, spec.name, trial)
        settled = rig.settle(seed)
        pile = {"seed": seed, "parts": settled.report.num_parts,
                "in_bin": settled.report.num_in_bin,
                "digest": hashlib.sha256(settled.state.tobytes()).hexdigest()[:16]}
        random_seed = method_seed(self.config.seed, spec.name, trial)
        runs = [self._clear(rig, settled.state, MethodRun(name, random_seed), pile["in_bin"],
                            f"{spec.name} bin {trial}")
                for name in rig.methods]
        return {"part": spec.name, "trial": trial, "pile": pile, "runs": runs,
                "wall_s": time.perf_counter() - start, "cpu_s": time.process_time() - cpu}

    def _rig_for(self, spec: PartSpec) -> Episode:
        if spec.name not in self._rigs:
            self._rigs[spec.name] = Episode.clearing(
                part_scenario(self.config, spec), self.config.methods[spec.name], spec.name,
                self.config.open_loop)
        return self._rigs[spec.name]

    def _clear(self, rig: Episode, state, run: MethodRun, in_bin: int, name: str) -> dict:
        start, cpu = time.perf_counter(), time.process_time()
        episode = rig.episode
        pick = episode.pick
        rows: list[dict] = []
        tray = [0]
        watch = EscapeWatch(pick, rig.scenario.bin, episode.simulator.get_context(), rows)
        progress = BinProgress(f"{name} ({run.name})", in_bin, self.progress_interval_s)

        def grasp(record: PickRecord) -> None:
            context = episode.simulator.get_context()
            now = tray_count(pick, context)
            rows.append(grasp_row(record, now - tray[0],
                                  pick.diagram.GetOutputPort("bin_times").Eval(context)))
            tray[0] = now
            progress.grasp(rows, context.get_time(), int(watch.in_bin.sum()))

        rig.start(state, run)
        time_limit = SIM_TIME_PER_PART * max(in_bin, 1)
        result = rig.run(time_limit, on_pick=grasp, step=watch)
        # Parts still falling into the tray after the last grasp was recorded come to rest.
        episode.simulator.AdvanceTo(episode.simulator.get_context().get_time() + 1.0)
        watch(Mode.DONE)  # the last look: where every part came to rest
        final = tray_count(pick, episode.simulator.get_context())
        if rows:  # what landed after the last record belongs to it
            rows[-1]["landed"] += final - tray[0]
        left = int(watch.in_bin.sum())
        lost = set(np.flatnonzero(~watch.in_bin & ~watch.in_tray).tolist())
        return {"method": run.name, "end": result.end.value,
                "end_reason": end_reason(result, left, time_limit),
                "sim_s": round(result.time, 3),
                "compute_s": sum(r["compute_s"] for r in rows), "grasps": rows,
                "delivered": final, "left_in_bin": left, "lost": in_bin - left - final,
                "escapes": [e for e in watch.escapes if e["part"] in lost],
                "wall_s": time.perf_counter() - start, "cpu_s": time.process_time() - cpu}


def end_reason(result: PickRun, left_in_bin: int, time_limit: float) -> str:
    """Why a clearing ended, in words: the bin emptied, the time allowed ran out, a safety
    stop, or the planner's reason for stopping with parts left (its last record's: grasps in
    a row that delivered nothing and the stirs since the last delivery, or nothing left that
    it could pick)."""
    if result.end is RunEnd.TIMEOUT:
        return f"out of time: {time_limit:.0f} simulated s allowed"
    if result.end is RunEnd.STOPPED:
        return f"safety stop: {result.safety_message}"
    if left_in_bin == 0:
        return "the bin is empty"
    last = result.records[-1] if result.records else None
    if last is None or last.failure is None:
        return f"the planner stopped with {left_in_bin} parts in the bin"
    return f"{last.failure.value}: {last.reason}" if last.reason else last.failure.value


class BinProgress:
    """Where one clearing stands, a line at most every ``interval_s`` of wall time (``None``:
    silent): parts delivered and left, grasps, the rate so far (simulated time plus
    computation, as the report counts it) and the wall time left at the pace so far."""

    def __init__(self, name: str, parts: int, interval_s: float | None,
                 say: Callable[[str], None] = lambda line: print(line, flush=True)) -> None:
        self.name, self.parts, self.interval_s, self.say = name, parts, interval_s, say
        self._start = self._last = time.perf_counter()

    def grasp(self, rows: list[dict], sim_time: float, left_in_bin: int) -> None:
        now = time.perf_counter()
        if self.interval_s is None or now - self._last < self.interval_s:
            return
        self._last = now
        delivered = sum(row["landed"] for row in rows)
        hours = (sim_time + sum(row["compute_s"] for row in rows)) / 3600
        rate = f", {delivered / hours:.0f} parts per hour so far" if hours > 0 else ""
        left = f", about {(now - self._start) / delivered * left_in_bin / 60:.0f} min left" \
            if delivered else ""
        self.say(f"  {self.name}: {delivered} of {self.parts} parts delivered, {left_in_bin} "
                 f"in the bin, {len(rows)} grasps{rate}{left}")


class EscapeWatch:
    """Between the run's looks at the planner (a ``step`` of :func:`run_picks`), notes each
    part that has left the bin for somewhere other than the tray, and the planner's mode at
    the look before: where a clearing's lost parts go.

    A part counts once it is outside the bin's footprint, not in the tray, and below the bin's
    floor (falling past it to the ground: a part in the gripper is above the bin, one being
    released over the tray is the tray's). Where it was at the look before says where it came
    from: the bin, the tray (delivered, then out again), or neither (in the gripper, or in
    flight).
    """

    def __init__(self, pick: PickDiagram, bin_config: BinConfig, context: Context,
                 grasps: list[dict]) -> None:
        self._pick, self._bin, self._context, self._grasps = pick, bin_config, context, grasps
        self._seen: set[int] = set()
        self._mode: Mode | None = None
        self.in_bin: np.ndarray | None = None
        """Per part, whether it was in the bin at the last look (``in_tray``: in the tray)."""
        self.in_tray: np.ndarray | None = None
        self.escapes: list[dict] = []
        """One per escaped part: ``grasp`` (the index of the grasp in progress, that is the
        number recorded before it), ``mode`` (the planner's mode when it left), ``part``,
        ``source`` (``bin``, ``tray`` or ``gripper``, where it was at the look before)."""

    def __call__(self, mode: Mode) -> float:
        positions = self._pick.station.part_poses(self._context)[:, :3, 3]
        in_bin, in_tray = inside_bin(self._bin, positions), self._pick.tray.in_tray(positions)
        out = ~in_bin & ~in_tray & (positions[:, 2] < self._bin.floor_height)
        if self._mode is None:  # the first look: nothing has moved yet
            self._mode, self.in_bin, self.in_tray = mode, in_bin, in_tray
        for part in np.flatnonzero(out):
            if int(part) not in self._seen:
                self._seen.add(int(part))
                source = "bin" if self.in_bin[part] else "tray" if self.in_tray[part] \
                    else "gripper"
                self.escapes.append({"grasp": len(self._grasps), "mode": self._mode.value,
                                     "part": int(part), "source": source})
        self._mode, self.in_bin, self.in_tray = mode, in_bin, in_tray
        return POLL


def tray_count(pick: PickDiagram, context: Context) -> int:
    """The parts lying in the tray now, by the simulation (``context``: the diagram's)."""
    return round(pick.tray.GetOutputPort("tray_count").Eval(
        pick.tray.GetMyContextFromRoot(context))[0])


def grasp_row(record: PickRecord, landed: int, times: BinTimes) -> dict:
    """One grasp of a clearing as plain data: what it did, what landed in the tray, and how
    long it kept the bin busy (``times``: the pick diagram's ``bin_times``)."""
    return {"index": record.index, "outcome": record.outcome.name,
            "failure": None if record.failure is None else record.failure.value,
            "lifted": record.truth.lifted, "held": record.truth.held,
            "resting": record.truth.resting, "held_decided": record.truth.held_decided,
            "weighed": None if record.estimate is None or not record.estimate.ready
            else round(record.estimate.parts, 3),
            "verdict": None if record.verdict is None else record.verdict.name,
            "recoveries": [r.name for r in record.recoveries],
            "disposition": None if record.disposition is None else record.disposition.name,
            "landed": landed, "started_at": record.timing.started_at,
            "in_bin_s": round(times.in_bin.get(record.index, 0.0), 3),
            "look_s": round(times.look.get(record.index, 0.0), 3),
            "execution_s": round(record.timing.execution_s, 3),
            "compute_s": record.timing.compute_s}

