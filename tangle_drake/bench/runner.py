"""Drive a benchmark: check the arguments, resume the results, farm trials out, report.

Trials are handed out part by part, lowest unfinished index first, to local processes or Ray
actors (:mod:`tangle_drake.common.workers`); each finished trial is appended to ``results.jsonl`` at
once, so Ctrl-C or a kill loses only the trials in flight, and running the same command again
redoes just those. The report is written from whatever is on disk, interrupted or not.
"""

from __future__ import annotations

import datetime
import hashlib
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path

from tangle_drake.bench.clear_report import summarize_clearing, write_clear_report
from tangle_drake.bench.clearing import ClearWorker
from tangle_drake.bench.gallery import save_tiles, write_index
from tangle_drake.bench.report import summarize_run, write_report
from tangle_drake.bench.results import ResultStore
from tangle_drake.bench.trials import (
    MODE_SCENARIOS,
    MODES,
    BenchConfig,
    PartSpec,
    TrialWorker,
    part_scenario,
    pile_seed,
)
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.common.progress import LINE_INTERVAL_S, Progress
from tangle_drake.common.provenance import made_by
from tangle_drake.common.workers import start_workers
from tangle_drake.parts import BUILTIN_PARTS, load_part
from tangle_drake.parts.library import part_digest
from tangle_drake.pick.diagram import (
    closed_loop_settings,
    default_graspability_params,
    weighing_warning,
)
from tangle_drake.planning.motions import scenario_mode
from tangle_drake.scenario.files import ScenarioSource, scenario_source
from tangle_drake.selection.choice import model_part_notice
from tangle_drake.selection.methods import Method, file_digest, parse_method
from tangle_drake.selection.registry import DEFAULT_METHODS
from tangle_drake.station.perturb import PhysicsSpread
from tangle_drake.station.pile import check_pile

DEFAULT_TRIALS = 50
DEFAULT_OUT = Path("results/bench")
QUICK_PARTS = ("u_hook",)
QUICK_METHODS = ("random", "graspability")
QUICK_TRIALS = 2
QUICK_PILE_SIZE = 6
"""``--quick``: one part, two methods, two trials, small piles (CI runs it end to end)."""
CLEAR_METHODS = ("graspability", "harmonic")
"""``--clear``'s default methods (each bin takes minutes: the index alone and the paper's)."""
QUICK_CLEAR = {"methods": ("graspability",), "trials": 1, "pile_size": 2}
"""``--clear --quick``: one bin of two U-hooks, the index alone."""


@dataclass(frozen=True)
class BenchOptions:
    """What ``tangle-drake bench`` was asked for (``None``: the default, or the quick one)."""

    methods: Sequence[str] | None = None
    parts: Sequence[str] | None = None
    mesh_scale: float = 1.0
    trials: int | None = None
    workers: int | None = None
    ray: str | None = None
    out: Path = DEFAULT_OUT
    mode: str | None = None
    """``floating`` or ``arm``; ``None``: the scenario's carrier (``floating`` without one)."""
    seed: int = 0
    scenario: ScenarioSource | str | Path | None = None
    quick: bool = False
    clear: bool = False
    """Clear whole bins (closed loop unless ``open_loop``) instead of one pick per method."""
    open_loop: bool = False
    gallery: bool = False
    """Write a tile of each failed pick into ``out/gallery`` (:mod:`.gallery`)."""
    perturb: bool = False
    """Pick under perturbed physics (:class:`~tangle_drake.station.perturb.PhysicsSpread`,
    one draw per pile)."""
    show_progress: bool | None = None
    command: str = "tangle-drake bench"
    """The command line, written into the report."""


@dataclass
class BenchOutcome:
    directory: Path
    summary: dict
    files: list[Path]
    new_trials: int
    interrupted: bool
    notices: list[str] = field(default_factory=list)


def plan(options: BenchOptions) -> tuple[BenchConfig, int, list[str]]:
    """The run's configuration and trial count, and notices (methods left out for want of a
    model); raises ``TangleDrakeError`` for anything that cannot run."""
    if options.open_loop and not options.clear:
        raise TangleDrakeError("--open-loop goes with --clear (the pick benchmark is open "
                               "loop already)")
    quick_trials = QUICK_CLEAR["trials"] if options.clear else QUICK_TRIALS
    trials = options.trials if options.trials is not None else (
        quick_trials if options.quick else DEFAULT_TRIALS)
    if trials < 1:
        raise TangleDrakeError(f"--trials must be at least 1, got {trials}")
    if options.workers is not None and options.workers < 1:
        raise TangleDrakeError(f"--workers must be at least 1, got {options.workers}")
    if options.mode is not None and options.mode not in MODES:
        raise TangleDrakeError(f"unknown --mode {options.mode!r}; choose {' or '.join(MODES)}")
    source = scenario_source(options.scenario).with_default(
        MODE_SCENARIOS[options.mode or "floating"])
    text, scenario = source.read()  # a clear error now, not in every worker
    path = source.name
    if scenario.pile.total_count == 0 and not options.quick:
        raise TangleDrakeError(f"{path}: the scenario's pile has no parts: there is nothing "
                               "to pick")
    notices = []
    parts = []
    if options.parts is None and source.files and not options.quick:
        names = list(dict.fromkeys((e.part, e.mesh_scale) for e in scenario.pile.parts))
        notices.append(f"notice: parts from the scenario {path}: "
                       f"{', '.join(part for part, _ in names)} (pass --parts for others)")
        parts = [PartSpec(part, load_part(part, mesh_scale=scale).name, scale)
                 for part, scale in names]
    for part in [] if parts else (options.parts or (QUICK_PARTS if options.quick
                                                    else BUILTIN_PARTS)):
        scale = 1.0 if part in BUILTIN_PARTS else options.mesh_scale
        parts.append(PartSpec(part, load_part(part, mesh_scale=scale).name, scale))
    _unique([p.name for p in parts], "part")
    explicit = options.methods is not None
    default_methods = (QUICK_CLEAR["methods"] if options.quick else CLEAR_METHODS) \
        if options.clear else (QUICK_METHODS if options.quick else DEFAULT_METHODS)
    methods = [parse_method(m) for m in options.methods or default_methods]
    _unique([m.name for m in methods], "method")
    per_part: dict[str, tuple[Method, ...]] = {}
    quick_pile = QUICK_CLEAR["pile_size"] if options.clear else QUICK_PILE_SIZE
    pile_size = quick_pile if options.quick else None
    for spec in parts:
        notices += check_pile(part_scenario(BenchConfig(text, (spec,), {},
                                                        pile_size=pile_size), spec))
        missing = [m for m in methods if m.needs_model and not m.model_for(spec.name).is_file()]
        if missing and explicit:
            objective = missing[0].objective
            raise TangleDrakeError(
                f"method {missing[0].name!r} needs a model of {objective.probability} for part "
                f"{spec.name!r}, and {missing[0].model_for(spec.name)} does not exist: train "
                f"one (data from {objective.data}, then `tangle-drake train --objective "
                f"{objective.name}`) and install it there, or pass model:PATH")
        if missing:
            paths = dict.fromkeys(shown_path(m.model_for(spec.name)) for m in missing)
            notices.append(f"notice: no trained model for part {spec.name!r} "
                           f"({', '.join(paths)}): methods "
                           f"{', '.join(m.name for m in missing)} skipped on it")
        per_part[spec.name] = tuple(m for m in methods if m not in missing)
        notices += [note for m in per_part[spec.name] if m.model is not None
                    and (note := model_part_notice(m.model, spec.name))]
    mode = scenario_mode(scenario, path)
    if options.mode is not None and options.mode != mode:
        raise TangleDrakeError(
            f"--mode {options.mode} disagrees with --scenario {path}, whose carrier makes it "
            f"{mode} mode: drop --mode, or pass the {MODE_SCENARIOS[options.mode]} scenario")
    if options.gallery and options.clear:
        raise TangleDrakeError("--gallery draws single picks; with --clear, use demo --pictures")
    if options.perturb and options.clear:
        raise TangleDrakeError("--perturb perturbs single picks; bin clearing runs the model's "
                               "physics")
    open_loop = options.clear and (options.open_loop or not scenario.pick.closed_loop)
    config = BenchConfig(text, tuple(parts), per_part, mode, options.seed, pile_size,
                         options.clear, open_loop, options.gallery,
                         PhysicsSpread() if options.perturb else None)
    if options.clear and not open_loop:
        closed_loop_settings(scenario)  # a tray and a wrist sensor, or a clear error now
        notices += [warning for spec in parts if (warning := weighing_warning(
            part_scenario(config, spec)))]
    notices += overlap_warnings(config, trials)
    return config, trials, notices


def overlap_warnings(config: BenchConfig, trials: int) -> list[str]:
    """A warning for each model that was trained on piles this run tests on (its checkpoint
    lists its piles' seeds; older checkpoints do not, and are not checked)."""
    warnings = []
    for spec in config.parts:
        tested = {pile_seed(config.seed, spec.name, t) for t in range(trials)}
        for method in config.methods[spec.name]:
            if not method.needs_model:
                continue
            from tangle_drake.tangle_cnn.checkpoint import read_checkpoint  # imports torch

            path = method.model_for(spec.name)
            trained = set((read_checkpoint(path).get("data") or {}).get("pile_seeds") or ())
            if shared := tested & trained:
                warnings.append(f"warning: {shown_path(path)} was trained on {len(shared)} of the "
                                f"{len(tested)} {spec.name} piles this run tests {method.name} "
                                "on: its figures there are not a test; collect its data with "
                                "another --seed")
    return warnings


def _unique(names: list[str], what: str) -> None:
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise TangleDrakeError(f"{what} {repeated[0]!r} is given twice")


def identity(config: BenchConfig) -> dict:
    """What ``bench.json`` binds the results to (all but the trial count): models and meshes
    by content, and each part's graspability settings, so changing one is a new run."""
    return {
        "format": 1, "mode": config.mode, "seed": config.seed, "pile_size": config.pile_size,
        "scenario_sha256": hashlib.sha256(config.scenario_text.encode()).hexdigest(),
        "parts": [{"name": p.name, "part": shown_path(p.part), "mesh_scale": p.mesh_scale,
                   "sha256": part_digest(p.part)}
                  for p in config.parts],
        "methods": {part: [{"name": m.name, "rule": m.rule,
                            "model_sha256": file_digest(m.model_for(part))
                            if m.needs_model else None} for m in methods]
                    for part, methods in config.methods.items()},
        "graspability": {p.name: asdict(default_graspability_params(part_scenario(config, p)))
                         for p in config.parts},
        **({"clear": {"open_loop": config.open_loop}} if config.clear else {}),
        **({"physics": asdict(config.physics)} if config.physics is not None else {}),
    }


def run_bench(options: BenchOptions, say: Callable[[str], None] = print) -> BenchOutcome:
    """Run (or resume) the benchmark and write its report into ``options.out``."""
    config, trials, notices = plan(options)
    for notice in notices:
        say(notice)
    run_identity = identity(config)
    store = ResultStore(Path(options.out), run_identity)
    store.keep_scenario(config.scenario_text)
    for notice in store.notices:
        say(notice)
    # Trial by trial across the parts, so a run stopped early covers every part alike.
    todo = [(i, t) for t in range(trials) for i, spec in enumerate(config.parts)
            if (spec.name, t) not in store.trials]
    total = len(config.parts) * trials
    say(f"benchmark: {len(config.parts)} part(s) x {trials} trial(s), {config.mode} mode, "
        f"into {store.directory}; {total - len(todo)} trial(s) done before, {len(todo)} to run")
    start = time.perf_counter()
    interrupted, workers, new = _run_trials(config, store, todo, total, options)
    names = [spec.name for spec in config.parts]
    done = [store.trials[(name, t)] for name in names for t in range(trials)
            if (name, t) in store.trials]
    if len(done) < total:
        notices.append(f"{total - len(done)} of {total} trials not run yet: run the same "
                       "command again to finish")
    methods = list(dict.fromkeys(m.name for ms in config.methods.values() for m in ms))
    meta = {"command": options.command, "mode": config.mode, **made_by(),
            "date": datetime.date.today().isoformat(), "workers": workers,
            "elapsed_s": time.perf_counter() - start, "trials_per_part": trials,
            "new_trials": new, "earlier_trials": len(done) - new,
            "config": run_identity, "notes": notices}
    if config.clear:
        summary = summarize_clearing(done, names, methods,
                                     {**meta, "open_loop": config.open_loop})
        files = write_clear_report(store.directory, done, summary, names, methods)
    else:
        if config.gallery:
            index = write_index(store.directory, done, methods)
            meta["gallery"] = {"index": index.relative_to(store.directory).as_posix(),
                               "seconds": sum(row.get("gallery_s", 0.0) for trial in done
                                              for row in trial["picks"])}
        summary = summarize_run(done, names, methods, meta)
        files = write_report(store.directory, done, summary, names, methods)
    return BenchOutcome(store.directory, summary, files, new, interrupted, notices)


def _run_trials(config: BenchConfig, store: ResultStore, todo: list[tuple[int, int]],
                total: int, options: BenchOptions) -> tuple[bool, int, int]:
    """Run ``todo``, adding each result to ``store``; (interrupted, workers used, trials
    finished)."""
    if not todo:
        return False, 0, 0
    count = options.workers or (None if options.ray else os.cpu_count() or 1)
    if count is not None:
        count = min(count, len(todo))
    interval = None if options.show_progress is False else LINE_INTERVAL_S
    backend = start_workers(ClearWorker, (config, interval), count, options.ray) \
        if config.clear else start_workers(TrialWorker, (config,), count, options.ray)
    progress = Progress(total, total - len(todo), "trial", "bench", options.show_progress)
    pending: dict[Future, tuple[int, int]] = {}
    queue = iter(todo)
    successes = picks = new = 0
    interrupted = False
    try:
        while True:
            while len(pending) < backend.capacity and (task := next(queue, None)) is not None:
                pending[backend.submit(task)] = task
            if not pending:
                break
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                task = pending.pop(future)
                try:
                    result = future.result()
                except RuntimeError as error:  # Drake gave up: say how to reproduce it
                    spec = config.parts[task[0]]
                    raise TangleDrakeError(f"trial {task[1]} of {spec.name} (seed "
                                           f"{config.seed}) failed: {error}") from error
                if config.gallery:
                    save_tiles(store.directory, result)
                store.add(result)
                new += 1
                if config.clear:
                    picks += sum(run["delivered"] for run in result["runs"])
                    successes += sum(g["landed"] == 1 for run in result["runs"]
                                     for g in run["grasps"])
                    postfix = f"{picks} parts delivered, {successes} deliveries of one"
                else:
                    picks += len(result["picks"])
                    successes += sum(p["result"] == "success" for p in result["picks"])
                    postfix = f"success {100 * successes / max(picks, 1):.0f}% of {picks} " \
                        "new picks"
                progress.update(1, postfix)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        backend.close()
        progress.close()
    return interrupted, backend.capacity, new
