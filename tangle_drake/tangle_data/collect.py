"""Drive a collection: resume the dataset, farm tasks out, write each finished task.

Task ``i`` is one pile made from (seed, i) (:mod:`.seeds`); tasks are handed out lowest
unfinished index first, and no more are started once the samples on disk plus those the
running tasks will likely add reach the target. Finished tasks are stored in the order they
were handed out, and the first of them that together hold ``samples`` end the run (a later
task that finished early is dropped). So a run collects the first tasks that reach
``samples``, the same with any number of workers, and an interrupted run, run again, redoes
exactly the tasks that were lost.
"""

from __future__ import annotations

import collections
import itertools
import sys
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from tangle_drake import __version__
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.common.workers import start_workers
from tangle_drake.dataset.store import DatasetStore, TaskResult
from tangle_drake.parts import BUILTIN_PARTS, PartModel, load_part
from tangle_drake.parts.library import part_digest
from tangle_drake.planning.motions import scenario_mode
from tangle_drake.scenario import Scenario
from tangle_drake.station import camera_model
from tangle_drake.station.pile import check_pile
from tangle_drake.tangle_data.collect_progress import LIFT_SHARES, CollectProgress
from tangle_drake.tangle_data.physical import (
    PICK_SCENARIO,
    PICK_SHARES,
    PhysicalPickSimulator,
    PickDataSettings,
    pick_data_scenario,
)
from tangle_drake.tangle_data.settings import CollectSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator, data_scenario

DATA_SCENARIO = "tangle_data.yaml"


@dataclass(frozen=True)
class CollectionResult:
    directory: Path
    counts: dict
    new_tasks: int
    interrupted: bool
    per_minute_per_worker: float


def default_scenario_text() -> str:
    """The shipped data scenario (``diagrams/tangle_data.yaml``)."""
    return (diagrams_dir() / DATA_SCENARIO).read_text()


def collection_identity(settings: CollectSettings | PickDataSettings, scenario: Scenario,
                        part: PartModel) -> dict:
    """What the manifest binds a dataset to: settings, part (by content for a mesh file),
    the station's bin, camera and physics, and the format version of the tool."""
    identity = settings.identity()
    if settings.part not in BUILTIN_PARTS:
        identity["part"] = part.name
        identity["part_sha256"] = part_digest(settings.part)
    camera = camera_model(scenario)
    identity["scenario"] = {
        "bin": asdict(scenario.bin),
        "camera": {**asdict(camera.intrinsics), "X_WC": camera.X_WC.round(9).tolist()},
        "time_step": scenario.plant_config.time_step,
        "contact": scenario.plant_config.discrete_contact_approximation,
        "pile": {name: getattr(scenario.pile, name) for name in
                 ("settle_speed", "settle_time_max", "max_penetration", "max_redraws")},
    }
    identity["part_mass_kg"] = round(part.mass, 9)
    identity["made_by"] = f"tangle_drake {__version__}"
    return identity


def collect(settings: CollectSettings, out: Path, samples: int, workers: int | None = None,
            ray_address: str | None = None, scenario_text: str | None = None,
            show_progress: bool | None = None) -> CollectionResult:
    """Collect until ``out`` holds at least ``samples`` samples (Ctrl-C keeps what is done)."""
    _check_counts(samples, workers)
    scenario_text = default_scenario_text() if scenario_text is None else scenario_text
    scenario = data_scenario(scenario_text, settings)
    return _collect_into(out, settings, scenario, TangleDataSimulator, scenario_text,
                         settings.lifts_per_pile, samples, workers, ray_address, show_progress)


def collect_picks(settings: PickDataSettings, out: Path, samples: int,
                  workers: int | None = None, ray_address: str | None = None,
                  scenario_text: str | None = None,
                  show_progress: bool | None = None) -> CollectionResult:
    """Collect physical-pick data (:mod:`.physical`) until ``out`` holds at least ``samples``
    picks with an outcome (Ctrl-C keeps what is done)."""
    _check_counts(samples, workers)
    if scenario_text is None:
        scenario_text = (diagrams_dir() / PICK_SCENARIO).read_text()
    scenario = pick_data_scenario(scenario_text, settings)
    scenario_mode(scenario, "the pick-data scenario")  # a gripper to pick with, or say so
    settings = replace(settings, parts_per_pile=scenario.pile.total_count)
    return _collect_into(out, settings, scenario, PhysicalPickSimulator, scenario_text,
                         settings.top_k, samples, workers, ray_address, show_progress,
                         PICK_SHARES)


def _collect_into(out: Path, settings: CollectSettings | PickDataSettings, scenario: Scenario,
                  factory: type, scenario_text: str, per_task: int, samples: int,
                  workers: int | None, ray_address: str | None,
                  show_progress: bool | None,
                  shares: tuple[tuple[str, str], ...] = LIFT_SHARES) -> CollectionResult:
    """Check the part and its pile, open (or resume) the dataset at ``out`` and run
    ``factory``'s tasks into it."""
    part = load_part(settings.part, mesh_scale=settings.mesh_scale)  # builds the cache once
    for warning in check_pile(scenario):  # refuses a pile that cannot be made
        print(warning, file=sys.stderr)
    store = DatasetStore(out, collection_identity(settings, scenario, part))
    for notice in store.notices:
        print(f"notice: {notice}", file=sys.stderr)
    try:
        return _run(store, factory, (scenario_text, settings), per_task, settings.seed,
                    samples, workers, ray_address, part.name, show_progress, shares)
    finally:
        store.close()


def _check_counts(samples: int, workers: int | None) -> None:
    if samples < 1:
        raise TangleDrakeError(f"--samples must be at least 1, got {samples}")
    if workers is not None and workers < 1:
        raise TangleDrakeError(f"--workers must be at least 1, got {workers}")


def _run(store: DatasetStore, factory: type, args: tuple, per_task: int, seed: int,
         samples: int, workers: int | None, ray_address: str | None, name: str,
         show_progress: bool | None,
         shares: tuple[tuple[str, str], ...] = LIFT_SHARES) -> CollectionResult:
    """Run ``factory(*args)``'s tasks until the store holds ``samples`` (a task makes about
    ``per_task`` before any has finished).

    Tasks are stored in the order they were handed out, and the first run of them that holds
    ``samples`` ends the collection: a later task that finished early is dropped, so the
    dataset is the one a single worker makes, whatever the number of workers.
    """
    if store.totals["samples"] >= samples:
        return CollectionResult(store.directory, store.counts(), 0, False, 0.0)
    backend = start_workers(factory, args, workers, ray_address)
    progress = CollectProgress(name, samples, store.counts(), show_progress, shares=shares)
    pending: dict[Future, int] = {}
    handed_out: collections.deque[int] = collections.deque()  # not yet stored, in order
    early: dict[int, TaskResult] = {}  # finished, waiting for an earlier task
    unfinished = (task for task in itertools.count() if task not in store.finished)
    new_tasks = 0
    interrupted = False
    try:
        while store.totals["samples"] < samples:
            while len(pending) < backend.capacity and \
                    _expected(store, len(handed_out), per_task) < samples:
                task = next(unfinished)
                pending[backend.submit(task)] = task
                handed_out.append(task)
            progress.running(len(pending))
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                task = pending.pop(future)
                early[task] = _result(future, task, seed)
            while handed_out and handed_out[0] in early and \
                    store.totals["samples"] < samples:
                result = early.pop(handed_out.popleft())
                store.add(result)
                progress.task_done(result.stats)
                new_tasks += 1
    except KeyboardInterrupt:
        interrupted = True
    finally:
        backend.close()
        progress.close()
    return CollectionResult(store.directory, store.counts(), new_tasks, interrupted,
                            progress.per_minute_per_worker())


def _expected(store: DatasetStore, running: int, per_task: int) -> float:
    """Samples on disk plus those ``running`` tasks will likely add."""
    done = store.totals["tasks"]
    likely = store.totals["samples"] / done if done else per_task
    return store.totals["samples"] + running * likely


def _result(future: Future, task: int, seed: int) -> TaskResult:
    try:
        return future.result()
    except RuntimeError as error:  # Drake gave up (solver, geometry): say how to reproduce it
        raise TangleDrakeError(f"task {task} (seed {seed}) failed: {error}") from error
