"""Collections: a killed run resumes to exactly the uninterrupted dataset, a seed always makes
the same samples, the command line works end to end, and bad input is a clear error."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import Future
from dataclasses import replace
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import SAMPLE_FIELDS, finished_tasks, load_samples, read_manifest
from tangle_drake.tangle_data import collect as collect_module
from tangle_drake.tangle_data.collect import collect, default_scenario_text
from tangle_drake.tangle_data.settings import CollectSettings
from tangle_drake.tangle_data.simulator import TangleDataSimulator

SETTINGS = CollectSettings(part="c_ring", parts_per_pile=6, lifts_per_pile=3)
SAMPLES = 8  # three or four piles
CLI_ARGS = ["--part", "c_ring", "--parts-per-pile", "6", "--lifts-per-pile", "3",
            "--samples", str(SAMPLES)]
REPO = Path(__file__).resolve().parents[1]
RUN_CLI = ("import sys, argparse\n"
           "from tangle_drake.commands import collect\n"
           "if __name__ == '__main__':\n"
           "    parser = argparse.ArgumentParser()\n"
           "    collect.register(parser.add_subparsers())\n"
           "    args = parser.parse_args(['collect', *sys.argv[1:]])\n"
           "    sys.exit(args.func(args))\n")


run_cli = partial(run_command, "collect")


def shards(directory: Path) -> dict[int, dict[str, bytes]]:
    """Every shard's arrays as raw bytes (with dtype and shape), by task."""
    out = {}
    for task in finished_tasks(directory):
        with np.load(directory / f"shard_{task:07d}.npz") as shard:
            out[task] = {name: (shard[name].dtype.str, shard[name].shape,
                                shard[name].tobytes()) for name in shard.files}
    return out


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("uninterrupted")
    result = collect(SETTINGS, out, SAMPLES, workers=1, show_progress=False)
    assert not result.interrupted and result.counts["samples"] >= SAMPLES
    return out


def test_a_killed_run_resumes_with_every_sample_exactly_once(uninterrupted, tmp_path):
    out = tmp_path / "killed"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    process = subprocess.Popen([sys.executable, "-c", RUN_CLI, *CLI_ARGS, "--out", str(out),
                                "--workers", "2"], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not list(out.glob("shard_*.npz")):
        assert process.poll() is None, process.stderr.read().decode()
        assert time.monotonic() < deadline, "no shard within two minutes"
        time.sleep(0.05)
    workers = _children(process.pid)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert len(finished_tasks(out)) < len(finished_tasks(uninterrupted))
    _wait_gone(workers)  # orphaned workers notice and exit

    result = collect(SETTINGS, out, SAMPLES, workers=1, show_progress=False)
    assert result.counts["samples"] >= SAMPLES
    resumed, reference = shards(out), shards(uninterrupted)
    for task in reference:
        assert resumed[task] == reference[task], f"task {task} differs"
    assert set(resumed) - set(reference) <= {max(reference) + 1}  # 2 workers: one extra pile
    samples = load_samples(out)
    keys = list(zip(samples["task"].tolist(), samples["rank"].tolist(), strict=True))
    assert len(keys) == len(set(keys))  # no sample twice
    assert not list(out.glob(".tmp_*"))
    counts = read_manifest(out)["counts"]
    assert counts["samples"] == len(samples["label"])


def test_the_same_seed_makes_byte_identical_samples_on_a_fresh_or_reused_station():
    fresh = TangleDataSimulator(default_scenario_text(), SETTINGS).run_task(3)
    reused = TangleDataSimulator(default_scenario_text(), SETTINGS)
    reused.run_task(0)
    again = reused.run_task(3)
    assert fresh.samples.keys() == again.samples.keys()
    for name, array in fresh.samples.items():
        assert array.dtype == again.samples[name].dtype
        assert array.tobytes() == again.samples[name].tobytes(), name
    other_seed = TangleDataSimulator(default_scenario_text(), replace(SETTINGS, seed=1))
    assert other_seed.run_task(3).samples["pile_seed"][0] != fresh.samples["pile_seed"][0]


def test_command_line_collects_continues_and_refuses_other_settings(tmp_path, capsys):
    out = tmp_path / "data"
    assert run_cli("--part", "c_ring", "--parts-per-pile", "4", "--lifts-per-pile", "2",
                   "--samples", "2", "--workers", "1", "--out", str(out)) == 0
    printed = capsys.readouterr().out
    assert "samples from" in printed
    first = load_samples(out)
    assert len(first["label"]) >= 2 and set(SAMPLE_FIELDS) <= set(first)
    assert first["crop"].shape[1:] == (96, 96) and np.isfinite(first["crop"]).all()
    manifest = read_manifest(out)
    assert manifest["part"] == "c_ring" and manifest["crop"]["size_px"] == 96
    assert manifest["labels"]["rise_threshold_m"] == 0.03
    assert manifest["lift"]["height_m"] == 0.12
    assert manifest["gripper"]["max_opening"] > 0 and "bin" in manifest["scenario"]
    assert manifest["counts"]["samples"] == len(first["label"])

    assert run_cli("--part", "c_ring", "--parts-per-pile", "4", "--lifts-per-pile", "2",
                   "--samples", str(len(first["label"]) + 1), "--workers", "1",
                   "--out", str(out)) == 0
    more = load_samples(out)
    assert len(more["label"]) > len(first["label"])
    assert more["crop"][: len(first["label"])].tobytes() == first["crop"].tobytes()

    with pytest.raises(TangleDrakeError, match="rise_threshold_m"):
        run_cli("--part", "c_ring", "--parts-per-pile", "4", "--lifts-per-pile", "2",
                "--rise-threshold", "0.05", "--samples", "50", "--out", str(out))
    with pytest.raises(TangleDrakeError, match="part"):
        run_cli("--part", "s_hook", "--parts-per-pile", "4", "--lifts-per-pile", "2",
                "--samples", "50", "--out", str(out))


def test_a_mesh_file_part_collects_and_is_bound_by_content(tmp_path):
    mesh = tmp_path / "plate.obj"
    mesh.write_text(_box_obj(40.0, 25.0, 6.0))  # millimetres
    out = tmp_path / "plates"
    assert run_cli("--part", str(mesh), "--mesh-scale", "0.001", "--parts-per-pile", "3",
                   "--lifts-per-pile", "2", "--samples", "1", "--workers", "1",
                   "--full-depth", "--crop-size", "0.15", "--out", str(out)) == 0
    manifest = read_manifest(out)
    assert manifest["part"] == "plate" and len(manifest["part_sha256"]) == 64
    assert manifest["full_depth"] is True
    assert manifest["crop"] == {"size_m": 0.15, "size_px": 96}
    samples = load_samples(out, ("part", "full_depth", "u", "v"))
    assert set(samples["part"].tolist()) == {"plate"}
    assert samples["full_depth"].shape[1:] == (480, 640)
    assert samples["full_depth"].shape[0] == len(samples["u"]) >= 1

    mesh.write_text(_box_obj(40.0, 25.0, 8.0))  # another part under the same file name
    with pytest.raises(TangleDrakeError, match="part_sha256"):
        run_cli("--part", str(mesh), "--mesh-scale", "0.001", "--parts-per-pile", "3",
                "--lifts-per-pile", "2", "--samples", "5", "--workers", "1", "--full-depth",
                "--crop-size", "0.15", "--out", str(out))


@pytest.mark.parametrize(("argv", "message"), [
    (["--part", "no_such_part"], "unknown part"),
    (["--part", "missing.ply"], "not found"),
    (["--part", "c_ring", "--samples", "0"], "--samples"),
    (["--part", "c_ring", "--workers", "0"], "--workers"),
    (["--part", "c_ring", "--lifts-per-pile", "0"], "--lifts-per-pile"),
    (["--part", "c_ring", "--parts-per-pile", "0"], "--parts-per-pile"),
    (["--part", "c_ring", "--mesh-scale", "-1"], "mesh_scale"),
    (["--part", "c_ring", "--repeat", "0"], "--repeat"),
    (["--part", "c_ring", "--crop-size", "0"], "--crop-size"),
])
def test_bad_input_is_a_clear_error(argv, message, tmp_path):
    with pytest.raises(TangleDrakeError, match=message):
        run_cli(*argv, "--out", str(tmp_path / "d"))


def test_a_directory_that_is_not_a_dataset_is_refused(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(TangleDrakeError, match="not a tangle dataset"):
        collect(SETTINGS, tmp_path, 1, workers=1, show_progress=False)


def test_ray_without_ray_installed_says_how_to_get_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as where Ray is not installed
    with pytest.raises(TangleDrakeError, match=r"tangle_drake\[ray\]"):
        collect(SETTINGS, tmp_path / "d", 1, ray_address="auto", show_progress=False)


def _children(pid: int) -> list[int]:
    children = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            children.append(int(stat.parent.name))
    return children


def _wait_gone(pids: list[int], timeout: float = 15.0) -> None:
    deadline = time.monotonic() + timeout
    for pid in pids:
        while time.monotonic() < deadline:
            try:
                state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                break
            if state == "Z":
                break
            time.sleep(0.1)
        else:
            raise AssertionError(f"worker {pid} outlived the killed driver")


def _box_obj(x: float, y: float, z: float) -> str:
    corners = [(sx * x / 2, sy * y / 2, sz * z / 2)
               for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    lines = [f"v {a} {b} {c}" for a, b, c in corners]
    lines += ["f " + " ".join(str(i) for i in face) for face in faces]
    return "\n".join(lines) + "\n"


def test_manifest_counts_are_json(uninterrupted):
    counts = json.loads((uninterrupted / "manifest.json").read_text())["counts"]
    assert counts["tasks"] == len(finished_tasks(uninterrupted))
    assert counts["tangled"] + counts["not_tangled"] == counts["samples"]


def test_damaged_shards_are_skipped_by_readers_and_collected_again(uninterrupted, tmp_path,
                                                                   capsys):
    out = tmp_path / "damaged"
    shutil.copytree(uninterrupted, out)
    first, second = sorted(finished_tasks(out))[:2]
    truncated, flipped = out / f"shard_{first:07d}.npz", out / f"shard_{second:07d}.npz"
    truncated.write_bytes(truncated.read_bytes()[:1000])  # a full disk, a broken copy
    data = bytearray(flipped.read_bytes())
    data[len(data) // 2] ^= 0xFF  # one bad byte inside the crops: the zip's CRC fails
    flipped.write_bytes(bytes(data))

    notices: list[str] = []
    samples = load_samples(out, notice=notices.append)
    assert len(notices) == 2 and all("collect" in n and "--out" in n for n in notices)
    assert str(truncated) in notices[0] and str(flipped) in notices[1]
    whole = load_samples(uninterrupted)
    assert len(samples["label"]) < len(whole["label"])
    assert set(samples["task"].tolist()) == set(whole["task"].tolist()) - {first, second}

    collect(SETTINGS, out, SAMPLES, workers=1, show_progress=False)
    assert "moved aside" in capsys.readouterr().err
    assert (out / (truncated.name + ".damaged")).exists()
    repaired = shards(out)
    reference = shards(uninterrupted)
    for task in reference:
        assert repaired[task] == reference[task], f"task {task} differs"
    assert read_manifest(out)["counts"] == read_manifest(uninterrupted)["counts"] | {
        "cpu_s": read_manifest(out)["counts"]["cpu_s"]}


def test_shards_are_readable_by_others_as_the_umask_allows(uninterrupted):
    umask = os.umask(0)
    os.umask(umask)
    for path in uninterrupted.glob("shard_*.npz"):
        assert path.stat().st_mode & 0o777 == 0o666 & ~umask, path


class _OutOfOrderWorkers:
    """A backend of ``capacity`` workers whose tasks finish latest-first; task 1 of each
    collection makes one sample, every other task two."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity

    def submit(self, task: int) -> Future:
        future: Future = Future()
        samples = 1 if task == 1 else 2
        future.task = task  # for the order below
        future.set_result(SimpleNamespace(task=task, stats={"samples": samples, "tangled": 0}))
        return future

    def close(self) -> None:
        pass


class _Store:
    def __init__(self, directory: Path) -> None:
        self.directory, self.finished, self.tasks = directory, set(), []
        self.totals = {"samples": 0, "tasks": 0}

    def add(self, result) -> None:
        self.tasks.append(result.task)
        self.totals["samples"] += result.stats["samples"]
        self.totals["tasks"] += 1

    def counts(self) -> dict:
        return {"samples": self.totals["samples"], "tangled": 0}


@pytest.mark.parametrize("workers", [1, 2, 4])
def test_the_tasks_kept_do_not_depend_on_the_number_of_workers(workers, tmp_path,
                                                                monkeypatch):
    def latest_first(futures, return_when):
        return {max(futures, key=lambda future: future.task)}, set()

    monkeypatch.setattr(collect_module, "start_workers",
                        lambda *args: _OutOfOrderWorkers(workers))
    monkeypatch.setattr(collect_module, "wait", latest_first)
    store = _Store(tmp_path)
    collect_module._run(store, object, (), 2, 0, 5, workers, None, "part", False)
    assert store.tasks == [0, 1, 2]  # 2 + 1 + 2 samples: what one worker keeps


def test_the_rate_is_per_worker_that_ran_not_per_worker_asked_for(tmp_path, monkeypatch):
    # --workers 1000 --samples 3: two tasks of two samples each are all there is to run.
    made = []

    class Recorded(collect_module.CollectProgress):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(collect_module, "start_workers", lambda *args: _OutOfOrderWorkers(1000))
    monkeypatch.setattr(collect_module, "CollectProgress", Recorded)
    collect_module._run(_Store(tmp_path), object, (), 2, 0, 3, 1000, None, "part", False)
    assert made[0].workers == 2  # the rate's divisor
