"""Where tasks run: in this process, in local worker processes, or on a Ray cluster.

Shared by ``collect`` and ``bench``. A backend is made from a worker factory and its
arguments (both picklable: a module-level class or function, plain data): each worker calls
``factory(*args)`` once, building its station, and reuses the result's ``run_task(task)`` for
every task it gets. Each backend hands out ``concurrent.futures.Future`` objects, so a
driver's loop is the same for all three. Workers only compute: they return each task's
result to the driver, which alone writes to disk.

Local processes use the ``spawn`` start method (Drake and VTK are not fork-safe), ignore
Ctrl-C (the driver stops them), and exit on their own if the driver dies (``kill -9``).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any, Protocol

from tangle_drake.common.errors import TangleDrakeError


class Worker(Protocol):
    """What a factory makes: something that runs one task at a time."""

    def run_task(self, task: Any) -> Any:
        """The task's result (picklable)."""


WorkerFactory = Callable[..., Worker]

_WORKER: Worker | None = None
_ORPHAN_CHECK_S = 1.0


class InlineWorker:
    """Runs each task in this process when it is submitted (``--workers 1``)."""

    def __init__(self, factory: WorkerFactory, args: Sequence[Any]) -> None:
        self.worker = factory(*args)
        self.capacity = 1

    def submit(self, task: Any) -> Future:
        future: Future = Future()
        future.set_result(self.worker.run_task(task))
        return future

    def close(self) -> None:
        """Nothing to stop."""


class ProcessWorkers:
    """``count`` local worker processes (spawned), one worker each."""

    def __init__(self, factory: WorkerFactory, args: Sequence[Any], count: int) -> None:
        self.capacity = count
        self.pool = ProcessPoolExecutor(
            max_workers=count, mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_process, initargs=(factory, tuple(args), os.getpid()))

    def submit(self, task: Any) -> Future:
        return self.pool.submit(_run_in_process, task)

    def close(self) -> None:
        """Stop the workers now, dropping the tasks they were running."""
        self.pool.shutdown(wait=False, cancel_futures=True)
        for child in multiprocessing.active_children():
            child.kill()
            child.join()


def _init_process(factory: WorkerFactory, args: tuple, driver_pid: int) -> None:
    global _WORKER
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_when_orphaned, args=(driver_pid,), daemon=True).start()
    _WORKER = factory(*args)


def _exit_when_orphaned(driver_pid: int) -> None:
    while os.getppid() == driver_pid:
        time.sleep(_ORPHAN_CHECK_S)
    os._exit(1)


def _run_in_process(task: Any) -> Any:
    assert _WORKER is not None, "worker process was not initialised"
    return _WORKER.run_task(task)


RAY_RETRIES = 3
"""How often Ray restarts an actor whose process died (a node lost, a worker killed) and
runs its task again; tasks are pure functions of their seeds, so a retry changes nothing."""


class RayWorkers:
    """``count`` Ray actors on the cluster at ``address`` (``auto`` = the local cluster)."""

    def __init__(self, factory: WorkerFactory, args: Sequence[Any], count: int | None,
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
        actor = ray.remote(num_cpus=1, max_restarts=RAY_RETRIES,
                           max_task_retries=RAY_RETRIES)(_RayWorker)
        self.actors = [actor.remote(factory, tuple(args)) for _ in range(self.capacity)]
        self.idle = list(self.actors)
        self.busy: dict[Future, object] = {}

    def submit(self, task: Any) -> Future:
        for done in [future for future in self.busy if future.done()]:
            self.idle.append(self.busy.pop(done))
        actor = self.idle.pop()
        future: Future = Future()
        self.busy[future] = actor
        actor.run_task.remote(task).future().add_done_callback(
            lambda ray_future: self._settle(future, ray_future, task))
        return future

    def _settle(self, future: Future, ray_future: Future, task: Any) -> None:
        """Pass the task's result or error on; an actor that kept dying becomes a clear
        error (a task's own exception reaches the driver as its type, as locally)."""
        error = ray_future.exception()
        if isinstance(error, self.ray.exceptions.RayActorError):
            error = TangleDrakeError(f"the Ray worker running task {task!r} died "
                                     f"{RAY_RETRIES + 1} times (out of memory, or a node "
                                     f"lost?): {str(error).splitlines()[0]}")
        if error is None:
            future.set_result(ray_future.result())
        else:
            future.set_exception(error)

    def close(self) -> None:
        for actor in self.actors:
            self.ray.kill(actor, no_restart=True)


class _RayWorker:
    """A Ray actor holding one worker (wrapped with ``ray.remote`` lazily)."""

    def __init__(self, factory: WorkerFactory, args: tuple) -> None:
        self.worker = factory(*args)

    def run_task(self, task: Any) -> Any:
        return self.worker.run_task(task)


Backend = InlineWorker | ProcessWorkers | RayWorkers


def start_workers(factory: WorkerFactory, args: Sequence[Any], workers: int | None,
                  ray_address: str | None) -> Backend:
    """The backend for ``--workers`` / ``--ray``: ``workers`` processes or actors (default:
    one per CPU core, or the cluster's CPUs), each running ``factory(*args)``'s tasks."""
    if ray_address is not None:
        return RayWorkers(factory, args, workers, ray_address)
    count = workers or os.cpu_count() or 1
    if count == 1:
        return InlineWorker(factory, args)
    return ProcessWorkers(factory, args, count)


def add_worker_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    """``--workers`` and ``--ray``, for a command whose units of work are ``what``."""
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="local worker processes (default: one per CPU core); with "
                             "--ray, the number of Ray actors (default: the cluster's CPUs)")
    parser.add_argument("--ray", metavar="ADDRESS", default=None,
                        help=f"run the {what} on an existing Ray cluster (e.g. auto, or "
                             "ray://head:10001); needs pip install 'tangle_drake[ray]'")
