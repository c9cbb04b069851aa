"""``--ray`` for real, on a local Ray head on 127.0.0.1: the same dataset and the same
benchmark rows as local workers, and a worker killed mid-task retried without loss or
duplication. The README's test command installs Ray (the dev extra), so this runs in CI."""

import json
import os
import sys
from pathlib import Path

import pytest
from cli_run import run_command

from tangle_drake.bench.results import RESULTS_FILE
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.workers import RAY_RETRIES
from tangle_drake.dataset import finished_tasks
from tangle_drake.tangle_data import collect as collect_module
from tangle_drake.tangle_data.collect import collect
from tangle_drake.tangle_data.settings import CollectSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator

ray = pytest.importorskip("ray", reason="pip install 'ray>=2.9' (the dev extra has it)")

SETTINGS = CollectSettings(part="c_ring", parts_per_pile=6, lifts_per_pile=2)
SAMPLES = 5  # three piles


@pytest.fixture(scope="module")
def local_head():
    """A one-node Ray cluster on this machine; ``--ray auto`` finds it."""
    ray.init(address="local", num_cpus=2, object_store_memory=80 * 2**20,
             include_dashboard=False, log_to_driver=False)
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # for DiesOnce
    yield "auto"
    ray.shutdown()


def shard_bytes(directory: Path) -> dict[int, bytes]:
    return {task: (directory / f"shard_{task:07d}.npz").read_bytes()
            for task in finished_tasks(directory)}


class DiesOnce:
    """The simulator, but its worker process dies in the middle of task 1, the first time."""

    marker = ""

    def __init__(self, *args) -> None:
        self.inner = TangleDataSimulator(*args)

    def run_task(self, task: int):
        if task == 1 and not os.path.exists(self.marker):
            Path(self.marker).touch()
            os._exit(1)  # as a kill -9 or a lost node would: no exception, no result
        return self.inner.run_task(task)


def test_collect_on_ray_makes_the_local_dataset_and_survives_a_killed_worker(
        local_head, tmp_path, monkeypatch):
    local = tmp_path / "local"
    collect(SETTINGS, local, SAMPLES, workers=1, show_progress=False)
    on_ray = tmp_path / "ray"
    collect(SETTINGS, on_ray, SAMPLES, workers=2, ray_address=local_head, show_progress=False)
    assert shard_bytes(on_ray) == shard_bytes(local)

    DiesOnce.marker = str(tmp_path / "died")
    monkeypatch.setattr(collect_module, "TangleDataSimulator", DiesOnce)
    killed = tmp_path / "killed"
    result = collect(SETTINGS, killed, SAMPLES, workers=2, ray_address=local_head,
                     show_progress=False)
    assert Path(DiesOnce.marker).exists(), "the worker was never killed"
    assert RAY_RETRIES >= 1 and not result.interrupted
    assert shard_bytes(killed) == shard_bytes(local)  # nothing lost, nothing twice


def test_bench_on_ray_gives_the_local_rows(local_head, tmp_path):
    rows = {}
    for name, backend in (("local", ["--workers", "1"]), ("ray", ["--ray", local_head])):
        out = tmp_path / name
        assert run_command("bench", "--quick", "--methods", "graspability", "--trials", "2",
                           "--out", str(out), *backend) == 0
        rows[name] = sorted((_without_timings(json.loads(line)) for line in
                             (out / RESULTS_FILE).read_text().splitlines()),
                            key=lambda row: json.dumps(row, sort_keys=True))
    assert len(rows["ray"]) == 2 and rows["ray"] == rows["local"]


def _without_timings(value):
    """A result row without the seconds each stage took (they differ run to run)."""
    if isinstance(value, dict):
        return {key: _without_timings(item) for key, item in value.items()
                if not key.endswith("_s") or key in ("sim_s", "settle_s", "execution_s")}
    if isinstance(value, list):
        return [_without_timings(item) for item in value]
    return value


class AlwaysDies:
    """A worker whose process dies on every task (a pile that crashes the simulator)."""

    def __init__(self, *args) -> None:
        pass

    def run_task(self, task: int):
        os._exit(1)


def test_a_worker_that_keeps_dying_is_a_clear_error(local_head, tmp_path, monkeypatch):
    monkeypatch.setattr(collect_module, "TangleDataSimulator", AlwaysDies)
    with pytest.raises(TangleDrakeError, match=rf"task 0 died {RAY_RETRIES + 1} times"):
        collect(SETTINGS, tmp_path / "never", SAMPLES, workers=1, ray_address=local_head,
                show_progress=False)
    assert not finished_tasks(tmp_path / "never")
