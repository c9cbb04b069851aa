"""Where tasks run: in this process, in local worker processes, or on a Ray cluster.

Each backend hands out ``concurrent.futures.Future`` objects, so the driver loop in
:mod:`.collect` is the same for all three. Every worker builds its station once and reuses
it for all its tasks. Workers only compute: they return each task's samples to the driver,
which alone writes the dataset.

Local processes use the ``spawn`` start method (Drake and VTK are not fork-safe), ignore
Ctrl-C (the driver stops them), and exit on their own if the driver dies (``kill -9``).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor

from tangle_drake.errors import TangleDrakeError
from tangle_drake.tangle_data.settings import CollectSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator, TaskResult

_WORKER: TangleDataSimulator | None = None
_ORPHAN_CHECK_S = 1.0


class InlineWorker:
    """Runs each task in this process when it is submitted (``--workers 1``)."""

    def __init__(self, scenario_text: str, settings: CollectSettings) -> None:
        self.simulator = TangleDataSimulator(scenario_text, settings)
        self.capacity = 1

    def submit(self, task: int) -> Future:
        future: Future = Future()
        future.set_result(self.simulator.run_task(task))
        return future

    def close(self) -> None:
        """Nothing to stop."""


class ProcessWorkers:
    """``count`` local worker processes (spawned), one station each."""

    def __init__(self, scenario_text: str, settings: CollectSettings, count: int) -> None:
        self.capacity = count
        self.pool = ProcessPoolExecutor(
            max_workers=count, mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_process, initargs=(scenario_text, settings, os.getpid()))

    def submit(self, task: int) -> Future:
        return self.pool.submit(_run_in_process, task)

    def close(self) -> None:
        """Stop the workers now, dropping the tasks they were running."""
        self.pool.shutdown(wait=False, cancel_futures=True)
        for child in multiprocessing.active_children():
            child.kill()
            child.join()


def _init_process(scenario_text: str, settings: CollectSettings, driver_pid: int) -> None:
    global _WORKER
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_when_orphaned, args=(driver_pid,), daemon=True).start()
    _WORKER = TangleDataSimulator(scenario_text, settings)


def _exit_when_orphaned(driver_pid: int) -> None:
    while os.getppid() == driver_pid:
        time.sleep(_ORPHAN_CHECK_S)
    os._exit(1)


def _run_in_process(task: int) -> TaskResult:
    assert _WORKER is not None, "worker process was not initialised"
    return _WORKER.run_task(task)


class RayWorkers:
    """``count`` Ray actors on the cluster at ``address`` (``auto`` = the local cluster)."""

    def __init__(self, scenario_text: str, settings: CollectSettings, count: int | None,
                 address: str) -> None:
        try:
            import ray
        except ImportError as error:
            raise TangleDrakeError("--ray needs Ray: pip install 'tangle_drake[ray]' (or "
                                   "pip install 'ray>=2.9') on this machine and every node "
                                   "of the cluster") from error
        try:
            ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as error:
            raise TangleDrakeError(f"cannot connect to the Ray cluster at {address!r}: "
                                   f"{error}") from error
        self.ray = ray
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.capacity = count or cpus
        actor = ray.remote(num_cpus=1)(_RayWorker)
        self.actors = [actor.remote(scenario_text, settings) for _ in range(self.capacity)]
        self.idle = list(self.actors)
        self.busy: dict[Future, object] = {}

    def submit(self, task: int) -> Future:
        for done in [future for future in self.busy if future.done()]:
            self.idle.append(self.busy.pop(done))
        actor = self.idle.pop()
        future = actor.run_task.remote(task).future()
        self.busy[future] = actor
        return future

    def close(self) -> None:
        for actor in self.actors:
            self.ray.kill(actor)


class _RayWorker:
    """A Ray actor holding one station (wrapped with ``ray.remote`` lazily)."""

    def __init__(self, scenario_text: str, settings: CollectSettings) -> None:
        self.simulator = TangleDataSimulator(scenario_text, settings)

    def run_task(self, task: int) -> TaskResult:
        return self.simulator.run_task(task)


def start_workers(scenario_text: str, settings: CollectSettings, workers: int | None,
                  ray_address: str | None) -> InlineWorker | ProcessWorkers | RayWorkers:
    """The backend for ``--workers`` / ``--ray``."""
    if ray_address is not None:
        return RayWorkers(scenario_text, settings, workers, ray_address)
    count = workers or os.cpu_count() or 1
    if count == 1:
        return InlineWorker(scenario_text, settings)
    return ProcessWorkers(scenario_text, settings, count)
