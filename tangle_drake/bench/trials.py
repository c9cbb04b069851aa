"""One trial: a fresh settled pile of one part, and one pick per method on that same pile.

A trial is (part, trial index); its pile seed derives from (run seed, part, index) alone, so
every method sees the same piles (the comparison is paired), whichever worker runs the trial
and whenever (a resumed run redoes exactly the missing trials). The pile is dropped once in a
bare copy of the station; its settled plant state is restored into the pick diagram before each
method's pick (:meth:`tangle_drake.episode.episode.Episode.single_pick`). The worker
(:class:`TrialWorker`) builds a part's episode once and reuses it for every trial of that part.
"""

from __future__ import annotations

import hashlib
import time
import zlib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tangle_drake.bench.gallery import TILE_KEY, caption, failure_kind, timed_tile
from tangle_drake.common.failures import FailureKind
from tangle_drake.episode.episode import Episode
from tangle_drake.pick.outcome import Outcome, PickRecord
from tangle_drake.scenario import Scenario, parse_scenario
from tangle_drake.selection.methods import Method, MethodRun
from tangle_drake.station.perturb import PhysicsSpread, PickPhysics

MODE_SCENARIOS = {"floating": "floating_gripper.yaml", "arm": "pick_demo.yaml"}
"""The shipped scenario of each ``--mode``: the gripper on the gantry, or on the Nextage."""
MODES = tuple(MODE_SCENARIOS)
RESULTS = ("success", "tangled", "empty", "failure")
"""A pick's result: exactly one part came up, several, none, or nothing was attempted."""
FAILURES = tuple(kind.value for kind in FailureKind)
"""Why a pick failed (:class:`~tangle_drake.common.failures.FailureKind`): no grasp candidate, none
the robot could reach or reach without a collision, ..., or the pick did not finish within the
simulated time allowed."""

_PILE, _RANDOM, _PHYSICS = 0, 1, 2


@dataclass(frozen=True)
class PartSpec:
    """A part of the run: a built-in name or a mesh file, and its scale."""

    part: str
    name: str
    """The built-in name or the mesh file's stem: the part's name in results and seeds."""
    mesh_scale: float = 1.0


@dataclass(frozen=True)
class BenchConfig:
    """Everything a worker needs to run any trial of the run (picklable)."""

    scenario_text: str
    parts: tuple[PartSpec, ...]
    methods: dict[str, tuple[Method, ...]]
    """The methods run on each part, by part name (a default method whose model a part
    lacks is left out there)."""
    mode: str = "floating"
    seed: int = 0
    pile_size: int | None = None
    """Parts per pile; ``None``: the scenario's (``PileConfig.alone``)."""
    clear: bool = False
    """Clear whole bins (:mod:`.clearing`) instead of one pick per method and pile."""
    open_loop: bool = False
    """With ``clear``: the paper's open loop instead of the closed one."""
    gallery: bool = False
    """Draw a tile of each failed pick (:mod:`.gallery`); not part of the run's identity."""
    physics: PhysicsSpread | None = None
    """Pick under perturbed physics, one draw per pile for every method (``--perturb``)."""


def _stream(seed: int, part: str, trial: int, purpose: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, zlib.crc32(part.encode()), trial, purpose])


def pile_seed(seed: int, part: str, trial: int) -> int:
    """The pile seed of trial ``trial`` of ``part``: the same for every method."""
    return int(_stream(seed, part, trial, _PILE).generate_state(1, np.uint32)[0])


def method_seed(seed: int, part: str, trial: int) -> int:
    """The seed of the trial's random choices (the ``random`` method's draw)."""
    return int(_stream(seed, part, trial, _RANDOM).generate_state(1, np.uint32)[0])


def trial_physics(config: BenchConfig, part: str, trial: int) -> PickPhysics | None:
    """The physics of trial ``trial`` of ``part`` under ``--perturb`` (else ``None``)."""
    if config.physics is None:
        return None
    rng = np.random.default_rng(_stream(config.seed, part, trial, _PHYSICS))
    return PickPhysics.draw(config.physics, rng)


def part_scenario(config: BenchConfig, spec: PartSpec) -> Scenario:
    """The run's scenario with its pile made of ``spec`` only."""
    scenario = parse_scenario(config.scenario_text, source="the benchmark scenario")
    return replace(scenario, pile=scenario.pile.alone(spec.part, spec.mesh_scale,
                                                      config.pile_size))


def classify(record: PickRecord | None) -> tuple[str, str | None]:
    """A pick's result (one of :data:`RESULTS`) and, for a failure, why (:data:`FAILURES`,
    the record's ``FailureKind``); ``None`` is a pick that did not finish in time."""
    if record is None:
        return "failure", FailureKind.TIMEOUT.value
    if record.outcome is Outcome.FAILED:
        return "failure", record.failure.value
    results = {Outcome.ONE: "success", Outcome.SEVERAL: "tangled", Outcome.NONE: "empty"}
    if record.outcome not in results:
        raise ValueError(f"a benchmark pick must be counted by the simulation, not "
                         f"{record.outcome.value!r}")
    return results[record.outcome], None


class TrialWorker:
    """Runs trials (``(part index, trial index)``) for a :class:`BenchConfig`; keeps each
    part's rig (~100 MB) once built, as trials come round-robin across the parts."""

    def __init__(self, config: BenchConfig) -> None:
        self.config = config
        self._rigs: dict[str, Episode] = {}

    def run_task(self, task: tuple[int, int]) -> dict:
        """One trial's result: the pile, and one pick per method (see ``results``)."""
        part_index, trial = task
        spec = self.config.parts[part_index]
        start, cpu = time.perf_counter(), time.process_time()
        rig = self._rig_for(spec)
        seed = pile_seed(self.config.seed, spec.name, trial)
        drop_start, drop_cpu = time.perf_counter(), time.process_time()
        settled = rig.settle(seed)
        report = settled.report
        pile = {"seed": seed, "parts": report.num_parts, "in_bin": report.num_in_bin,
                "settled": report.settled, "settle_s": round(report.settle_time, 3),
                "digest": hashlib.sha256(settled.state.tobytes()).hexdigest()[:16],
                "wall_s": time.perf_counter() - drop_start,
                "cpu_s": time.process_time() - drop_cpu}
        random_seed = method_seed(self.config.seed, spec.name, trial)
        physics = trial_physics(self.config, spec.name, trial)
        picks = [self._pick(rig, settled.state, MethodRun(name, random_seed), spec.name, trial,
                            physics) for name in rig.methods]
        return {"part": spec.name, "trial": trial, "pile": pile, "picks": picks,
                **({"physics": physics.to_dict()} if physics is not None else {}),
                "wall_s": time.perf_counter() - start, "cpu_s": time.process_time() - cpu}

    def _rig_for(self, spec: PartSpec) -> Episode:
        if spec.name not in self._rigs:
            self._rigs[spec.name] = Episode.single_pick(part_scenario(self.config, spec),
                                            self.config.methods[spec.name], spec.name,
                                            floating=self.config.mode == "floating")
        return self._rigs[spec.name]

    def _pick(self, rig: Episode, state: np.ndarray, run: MethodRun, part: str,
              trial: int, physics: PickPhysics | None = None) -> dict:
        start, cpu = time.perf_counter(), time.process_time()
        pick = rig.pick(state, run, physics)
        row = pick_row(run.name, pick.record, {
            "sim_s": round(pick.sim_s, 3), "wall_s": time.perf_counter() - start,
            "cpu_s": time.process_time() - cpu,
            "depth_digest": hashlib.sha256(pick.depth.tobytes()).hexdigest()[:16]})
        if self.config.gallery and failure_kind(row) is not None:
            row[TILE_KEY], row["gallery_s"] = timed_tile(
                pick.depth, pick.record, rig.intrinsics, caption(run.name, part, trial, row))
        return row


def pick_row(method: str, record: PickRecord | None, extra: dict) -> dict:
    """One pick as plain data (a row of ``results.csv``)."""
    result, failure = classify(record)
    row: dict[str, Any] = {"method": method, "result": result, "failure": failure}
    if record is not None:
        candidate = record.candidate
        row.update(
            outcome=record.outcome.name, reason=record.reason, lifted=record.truth.lifted,
            width=record.width, rank=record.rank, p_model=record.p_model,
            rejected=len(record.rejected), perception_s=record.timing.perception_s,
            cnn_s=record.timing.cnn_s, planning_s=record.timing.planning_s,
            execution_s=record.timing.execution_s,
            candidate=None if candidate is None else {
                "u": float(candidate.u), "v": float(candidate.v),
                "angle_deg": float(candidate.angle_deg), "score": float(candidate.score)})
    return {**row, **extra}
