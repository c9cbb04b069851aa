"""``tangle-drake bench``: outcomes classified from hand-made end states, paired piles, a
resumed run that redoes nothing finished, the command end to end, and bad input refused."""

import hashlib
import json
import os
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import torch
from pydrake.math import RigidTransform

from tangle_drake.bench.clear_report import figures
from tangle_drake.bench.clearing import BinProgress, EscapeWatch, end_reason
from tangle_drake.bench.gallery import GALLERY, INDEX, TILE_KEY, tile_path
from tangle_drake.bench.report import terminal_summary
from tangle_drake.bench.results import IDENTITY_FILE, RESULTS_FILE
from tangle_drake.bench.runner import BenchOptions, plan, run_bench
from tangle_drake.bench.trials import classify, method_seed, pile_seed
from tangle_drake.cli import main
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.failures import FailureKind
from tangle_drake.common.paths import diagrams_dir, shown_path
from tangle_drake.episode.run import PickRun, RunEnd
from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.modes import Mode
from tangle_drake.pick.outcome import LiftMonitor, Outcome, PickRecord, TrueCount, classify_lift
from tangle_drake.scenario import BinConfig, PartCount
from tangle_drake.scenario.files import resolve_scenario, scenario_source
from tangle_drake.selection.choice import trained_model_path
from tangle_drake.selection.methods import GraspSelector, MethodRun, parse_method
from tangle_drake.selection.registry import MODEL_PREFIX, REGISTRY
from tangle_drake.station import build_station, part_bodies
from tangle_drake.station.pile import PileSettler
from tangle_drake.tangle_cnn.checkpoint import model_checkpoint, save_atomic
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION

QUICK = BenchOptions(quick=True, workers=1, show_progress=False)


@pytest.fixture(scope="module")
def untrained_model(tmp_path_factory) -> Path:
    """A tiny untrained tangle CNN: what the wiring needs, not what a benchmark measures."""
    torch.manual_seed(0)
    config = NetworkConfig(input_size=32)
    path = tmp_path_factory.mktemp("model") / "untrained.pt"
    save_atomic(model_checkpoint(config, CropSpec(0.05, 32), DEFAULT_NORMALISATION,
                                 TangleNet(config).state_dict(), part="u_hook"), path)
    return path


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory, untrained_model):
    """The quick benchmark through the command line, with a user checkpoint as a method."""
    out = tmp_path_factory.mktemp("bench") / "quick"
    code = main(["bench", "--quick", "--workers", "1", "--out", str(out), "--methods",
                 "random", "graspability", f"model:{untrained_model}"])
    return code, out


def test_the_gallery_holds_a_tile_of_exactly_each_failed_pick(tmp_path):
    out = tmp_path / "gallery_run"  # E-shapes: graspability's first grasp comes up empty
    assert main(["bench", "--quick", "--parts", "e_shape", "--methods", "graspability",
                 "random", "--trials", "2", "--workers", "1", "--gallery",
                 "--out", str(out)]) == 0
    failed = [(trial["part"], trial["trial"], row) for trial in trials_in(out)
              for row in trial["picks"] if row["result"] != "success"]
    tiles = sorted((out / GALLERY).rglob("*.png"))
    assert failed and sorted(tile_path(out, part, t, row) for part, t, row in failed) == tiles
    for part, t, row in failed:
        image = cv2.imread(str(tile_path(out, part, t, row)))
        assert image is not None and image.shape[0] > 100
        assert TILE_KEY not in row  # the tile went to disk, not into the results
    index = (out / GALLERY / INDEX).read_text()
    assert index.count("![") == len(failed)
    for method in {row["method"] for _, _, row in failed}:
        assert f"## {method}: " in index
    report = (out / "report.md").read_text()
    assert f"[{GALLERY}/{INDEX}]({GALLERY}/{INDEX})" in report


def trials_in(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / RESULTS_FILE).read_text().splitlines()]


# --- outcomes -----------------------------------------------------------------------------


def test_a_lift_is_judged_by_the_fingers_then_by_the_count():
    wire = 0.006
    assert classify_lift(0.003, 1, wire / 4) is Outcome.ONE
    assert classify_lift(0.003, 3, wire / 4) is Outcome.SEVERAL
    assert classify_lift(0.0005, 1, wire / 4) is Outcome.NONE  # closed: holds nothing
    assert classify_lift(0.003, 0, wire / 4) is Outcome.NONE
    assert classify_lift(0.003, None, wire / 4) is Outcome.HELD  # hardware: no count


@pytest.mark.parametrize(("record", "expected"), [
    (PickRecord(1, Outcome.ONE), ("success", None)),
    (PickRecord(1, Outcome.SEVERAL, truth=TrueCount(lifted=2)), ("tangled", None)),
    (PickRecord(1, Outcome.NONE), ("empty", None)),
    (None, ("failure", "timeout")),
    *[(PickRecord(1, failure=kind, reason="(words only for people)"), ("failure", kind.value))
      for kind in FailureKind],
])
def test_pick_results_and_failure_causes_come_from_the_record_kinds(record, expected):
    assert classify(record) == expected


def test_a_held_grasp_is_no_benchmark_result():
    with pytest.raises(ValueError, match="counted by the simulation"):
        classify(PickRecord(1, Outcome.HELD))


def test_hand_made_end_states_count_the_parts_hanging_from_the_gripper():
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario = replace(scenario, pile=replace(scenario.pile, parts=[PartCount("u_hook", 3)]))
    station = build_station(scenario)
    plant = station.plant
    monitor = LiftMonitor(plant, scenario.bin)
    context = station.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    monitor_context = monitor.CreateDefaultContext()
    x, y = scenario.bin.center
    rim = scenario.bin.floor_height + scenario.bin.wall_height
    plant.SetPositions(plant_context, plant.GetModelInstanceByName("gantry"),
                       [x, y, rim + 0.15, 0.0])
    bodies = part_bodies(plant)
    hanging = RigidTransform([x, y, rim + 0.08])
    in_bin = RigidTransform([x, y, scenario.bin.floor_height + 0.01])
    flung = RigidTransform([x + 0.5, y, rim + 0.08])

    def end_state(*poses) -> tuple[str, str | None]:
        for body, pose in zip(bodies, poses, strict=True):
            plant.SetFreeBodyPose(plant_context, body, pose)
        monitor.get_input_port().FixValue(
            monitor_context, station.GetOutputPort("sim.body_poses").Eval(context))
        lifted = monitor.lifted_parts(monitor_context)
        width = 0.003 if lifted else 0.0005  # fingers on a wire, or closed on nothing
        outcome = classify_lift(width, len(lifted), 0.25 * 0.006)
        return classify(PickRecord(1, outcome, truth=TrueCount(lifted=len(lifted))))[0]

    assert end_state(hanging, in_bin, in_bin) == "success"
    assert end_state(hanging, hanging, in_bin) == "tangled"
    assert end_state(in_bin, in_bin, in_bin) == "empty"
    assert end_state(hanging, in_bin, flung) == "success"  # thrown clear: not lifted


# --- pairing ------------------------------------------------------------------------------


def test_a_trial_seed_depends_on_the_run_seed_part_and_index_only():
    seeds = {pile_seed(0, part, trial) for part in ("u_hook", "c_ring") for trial in range(3)}
    assert len(seeds) == 6
    assert pile_seed(0, "u_hook", 1) != pile_seed(1, "u_hook", 1)
    assert method_seed(0, "u_hook", 1) != pile_seed(0, "u_hook", 1)
    # Another process (another string-hash salt, as a worker has) derives the same seeds.
    probe = ("from tangle_drake.bench.trials import pile_seed, method_seed; "
             "print(pile_seed(0, 'u_hook', 1), method_seed(0, 'u_hook', 1))")
    other = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                           check=True, env={**os.environ, "PYTHONHASHSEED": "123"})
    assert other.stdout.split() == [str(pile_seed(0, "u_hook", 1)),
                                    str(method_seed(0, "u_hook", 1))]


def test_a_pile_depends_on_its_seed_alone():
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario = replace(scenario, pile=replace(scenario.pile, parts=[PartCount("u_hook", 4)]))
    settler = PileSettler(build_station(scenario), scenario)
    first = settler.settle(7).state
    other = settler.settle(8).state
    again = settler.settle(7).state
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)


def test_every_method_sees_the_same_piles(quick_run):
    code, out = quick_run
    assert code == 0
    trials = trials_in(out)
    assert sorted(t["trial"] for t in trials) == [0, 1]
    for trial in trials:
        assert trial["pile"]["seed"] == pile_seed(0, "u_hook", trial["trial"])
        assert [p["method"] for p in trial["picks"]] == ["random", "graspability",
                                                         trials[0]["picks"][2]["method"]]
        digests = {p["depth_digest"] for p in trial["picks"]}
        assert len(digests) == 1, "the methods saw different depth images"
    assert trials[0]["picks"][0]["depth_digest"] != trials[1]["picks"][0]["depth_digest"]


def test_every_registered_method_runs_in_the_quick_benchmark(tmp_path):
    """Each method of the registry, the path forms with the shipped U-hook models, makes its
    pick on the quick benchmark's pile."""
    named = {f"{MODEL_PREFIX}PATH": f"{MODEL_PREFIX}{trained_model_path('u_hook')}",
             "RULE:PATH": f"success-cnn:{trained_model_path('u_hook', 'outcome')}"}
    methods = [named.get(entry.name, entry.name) for entry in REGISTRY]
    outcome = run_bench(replace(QUICK, out=tmp_path, trials=1, methods=methods),
                        say=lambda _: None)
    ran = {rate["method"] for rate in outcome.summary["rates"] if rate["part"] == "all"}
    assert len(ran) == len(REGISTRY) == len(methods)
    assert all(rate["n"] == 1 for rate in outcome.summary["rates"])


def test_the_bench_and_the_demo_select_alike_without_a_cnn():
    """The benchmark's switched selector and the demo's fixed one give the same order, the
    same ``random`` draw included: one system, the rules' ``rank``."""
    candidates = [SimpleNamespace(u=float(i), v=2.0 * i, angle_deg=10.0 * i, score=1 - i / 10,
                                  pose=None) for i in range(8)]
    switch = GraspSelector([])
    for name in ("random", "graspability"):
        for seed in range(6):
            fixed = GraspSelector([], MethodRun(name, seed))
            assert not fixed.HasInputPort("method")
            orders = []
            for system in (switch, fixed):
                context = system.CreateDefaultContext()
                system.GetInputPort("candidates").FixValue(context, candidates)
                if system is switch:
                    system.GetInputPort("method").FixValue(context, MethodRun(name, seed))
                scored = system.GetOutputPort("scored_candidates").Eval(context)
                selected = system.GetOutputPort("selected_grasp").Eval(context)
                assert selected is scored[0].candidate
                orders.append([s.candidate.u for s in scored])
            assert orders[0] == orders[1]
            if name == "graspability":
                assert orders[0] == [float(i) for i in range(8)]
            else:
                assert orders[0][0] in range(5)


# --- the command, its report, resuming ----------------------------------------------------


def test_the_quick_benchmark_writes_its_report(quick_run, untrained_model):
    _, out = quick_run
    for name in ("report.md", "results.csv", "summary.csv", "paired.csv", "summary.json",
                 "success.png", "outcomes.png", "bench.json", "scenario.yaml"):
        assert (out / name).is_file(), name
    scenario = (out / "scenario.yaml").read_bytes()  # the scenario it ran on, beside it
    assert hashlib.sha256(scenario).hexdigest() == \
        json.loads((out / "bench.json").read_text())["scenario_sha256"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["command"] == (f"tangle-drake bench --methods random graspability "
                                  f"model:{shown_path(untrained_model)} --quick "
                                  f"--out {shown_path(out)}")
    overall = {r["method"]: r for r in summary["rates"] if r["part"] == "all"}
    assert set(overall) == {"random", "graspability", next(m for m in overall
                                                           if m.startswith("model:"))}
    for row in overall.values():
        assert row["n"] == 2 and row["lower"] <= row["rate"] <= row["upper"]
    assert len([r for r in summary["paired"] if r["part"] == "all"]) == 3
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 3  # a row per pick
    # The code and the kind of machine that made it, in the summary and the report's header.
    assert re.fullmatch(r"[0-9a-f]{7}(\+changes)?|not a git checkout", summary["commit"])
    assert re.fullmatch(r"\d+ CPU cores, (\d+ GB, )?(no GPU|.+)", summary["machine"])
    header = (out / "report.md").read_text().splitlines()[2]
    assert f"commit {summary['commit']}, on {summary['machine']}" in header
    model_picks = [p for t in trials_in(out) for p in t["picks"] if p["method"].startswith(
        "model:")]
    assert all(p.get("p_model") is not None for p in model_picks
               if p["result"] != "failure")
    assert "| method | u_hook | all |" in (out / "report.md").read_text()
    assert "## Timings" in (out / "report.md").read_text()
    assert "| random |" in terminal_summary(summary)


def test_the_quick_benchmark_runs_a_pick_outcome_model_with_its_own_rule(tmp_path):
    torch.manual_seed(0)
    config = NetworkConfig(input_size=32, classes=3)
    model = tmp_path / "outcome.pt"
    save_atomic(model_checkpoint(config, CropSpec(0.05, 32), DEFAULT_NORMALISATION,
                                 TangleNet(config).state_dict(), part="u_hook",
                                 objective="outcome"), model)
    out = tmp_path / "quick"
    assert main(["bench", "--quick", "--workers", "1", "--out", str(out), "--methods",
                 "graspability", f"model:{model}"]) == 0
    identity = json.loads((out / IDENTITY_FILE).read_text())
    assert [m["rule"] for m in identity["methods"]["u_hook"]] == ["graspability",
                                                                  "success-harmonic"]
    name = f"model:{shown_path(model)}"
    picks = [p for t in trials_in(out) for p in t["picks"] if p["method"] == name]
    assert len(picks) == 2 and all(p.get("p_model") is not None for p in picks
                                   if p["result"] != "failure")  # its P(one part)


def test_an_interrupted_run_resumes_without_redoing_finished_trials(tmp_path):
    out = tmp_path / "resume"
    first = run_bench(replace(QUICK, out=out, trials=1), say=lambda _: None)
    assert first.new_trials == 1
    line = (out / RESULTS_FILE).read_text()

    second = run_bench(replace(QUICK, out=out, trials=2), say=lambda _: None)
    assert second.new_trials == 1  # trial 0 was not run again
    header = (out / "report.md").read_text().splitlines()[2]
    assert "1 trial(s) run in" in header and "1 from earlier runs" in header
    lines = (out / RESULTS_FILE).read_text().splitlines(keepends=True)
    assert lines[0] == line and len(lines) == 2

    # Killed while writing trial 1: half its line on disk. The next run drops it, redoes it.
    (out / RESULTS_FILE).write_text(lines[0] + lines[1][: len(lines[1]) // 2])
    said: list[str] = []
    third = run_bench(replace(QUICK, out=out, trials=2), say=said.append)
    assert third.new_trials == 1
    assert any("dropped 1 unreadable line" in s for s in said)
    again = (out / RESULTS_FILE).read_text().splitlines(keepends=True)
    assert again[0] == line
    assert physics(json.loads(again[1])) == physics(json.loads(lines[1]))  # redone the same

    with pytest.raises(TangleDrakeError, match=r"other settings.*methods"):
        run_bench(replace(QUICK, out=out, methods=["graspability"]), say=lambda _: None)

    # Results made with other graspability settings (e.g. before the grip test) are not mixed.
    identity_file = out / IDENTITY_FILE
    stored = json.loads(identity_file.read_text())
    for params in stored["graspability"].values():
        params["max_grip_span_m"] = None
    identity_file.write_text(json.dumps(stored))
    with pytest.raises(TangleDrakeError, match=r"other settings.*graspability"):
        run_bench(replace(QUICK, out=out, trials=2), say=lambda _: None)


def physics(trial: dict) -> dict:
    """A trial's result without its timings (which no two runs share)."""
    timings = {"wall_s", "cpu_s", "perception_s", "cnn_s", "planning_s"}

    def strip(values: dict) -> dict:
        return {k: v for k, v in values.items() if k not in timings}

    return {**strip(trial), "pile": strip(trial["pile"]),
            "picks": [strip(p) for p in trial["picks"]]}


# --- bad input ----------------------------------------------------------------------------


@pytest.mark.parametrize(("options", "message"), [
    (dict(methods=["magic"]), "unknown method 'magic'"),
    (dict(methods=["model:/no/such.pt"]), "model file not found"),
    (dict(parts=["no_such_part"]), "no_such_part"),
    (dict(trials=0), "--trials must be at least 1"),
    (dict(workers=0), "--workers must be at least 1"),
    (dict(methods=["random", "random"]), "given twice"),
    (dict(mode="teleport"), "unknown --mode"),
    (dict(mode="arm", scenario="floating_gripper.yaml"), "--mode arm disagrees with --scenario"),
    (dict(scenario="pile_only.yaml"), "picking needs a robot"),
])
def test_bad_arguments_are_clear_errors(options, message):
    with pytest.raises(TangleDrakeError, match=message):
        plan(replace(QUICK, **options))


@pytest.mark.parametrize(("options", "mode", "scenario"), [
    (dict(), "floating", "floating_gripper.yaml"),
    (dict(mode="arm"), "arm", "pick_demo.yaml"),
    (dict(scenario="pick_demo.yaml"), "arm", "pick_demo.yaml"),
    (dict(mode="floating", scenario="floating_gripper.yaml"), "floating",
     "floating_gripper.yaml"),
])
def test_the_mode_chooses_the_scenario_and_a_scenario_its_mode(options, mode, scenario):
    config, _, _ = plan(replace(QUICK, **options))
    assert config.mode == mode
    assert config.scenario_text == (diagrams_dir() / scenario).read_text()


def test_a_cnn_method_without_a_model_is_an_error_or_left_out_of_the_defaults(
        tmp_path, monkeypatch):
    monkeypatch.setattr("tangle_drake.selection.choice.TRAINED_DIR", tmp_path)
    with pytest.raises(TangleDrakeError,
                       match=r"'harmonic' needs a model of P\(not tangled\).*u_hook\.pt"):
        plan(replace(QUICK, methods=["graspability", "harmonic"]))
    config, trials, notices = plan(BenchOptions(parts=["u_hook"]))
    assert [m.name for m in config.methods["u_hook"]] == ["random", "graspability"]
    assert trials == 50 and config.mode == "floating"
    assert len(notices) == 1 and "cnn, harmonic, success-cnn, outcome" in notices[0]
    assert all(f"u_hook{suffix}.pt" in notices[0] for suffix in ("", ".success", ".outcome"))


def test_the_outcome_method_reads_the_part_s_pick_outcome_model(tmp_path, monkeypatch):
    monkeypatch.setattr("tangle_drake.selection.choice.TRAINED_DIR", tmp_path)
    method = parse_method("outcome")
    assert (method.rule, method.model_for("c_ring")) == ("success-harmonic",
                                                          tmp_path / "c_ring.outcome.pt")
    assert parse_method("success-harmonic").model_for("c_ring") == tmp_path / "c_ring.success.pt"
    with pytest.raises(TangleDrakeError, match=r"'outcome' needs a model of P\(one part\).*"
                                               r"u_hook\.outcome\.pt.*--objective outcome"):
        plan(replace(QUICK, methods=["graspability", "outcome"]))


def test_perturbed_physics_is_one_draw_per_pile_and_part_of_the_runs_identity():
    from dataclasses import asdict

    from tangle_drake.bench.runner import identity
    from tangle_drake.bench.trials import trial_physics
    from tangle_drake.station.perturb import PhysicsSpread

    config, _, _ = plan(replace(QUICK, perturb=True))
    assert identity(config)["physics"] == asdict(PhysicsSpread())
    first = trial_physics(config, "u_hook", 0)
    assert first == trial_physics(config, "u_hook", 0) != trial_physics(config, "u_hook", 1)
    plain, _, _ = plan(QUICK)
    assert trial_physics(plain, "u_hook", 0) is None and "physics" not in identity(plain)
    with pytest.raises(TangleDrakeError, match="--perturb"):
        plan(replace(QUICK, clear=True, perturb=True))


def test_out_must_be_a_directory(tmp_path, capsys):
    out = tmp_path / "a_file"
    out.write_text("")
    assert main(["bench", "--quick", "--out", str(out)]) == 2
    assert "is a file, not a directory" in capsys.readouterr().err


# --- clearing whole bins --------------------------------------------------------------------


def test_clearing_a_quick_bin_counts_what_landed_in_the_tray(tmp_path, capsys):
    out = tmp_path / "clear"
    assert main(["bench", "--clear", "--quick", "--workers", "1", "--out", str(out)]) == 0
    (trial,) = trials_in(out)
    (run,) = trial["runs"]
    assert run["method"] == "graspability" and trial["pile"]["parts"] == 2
    assert run["delivered"] + run["left_in_bin"] + run["lost"] == trial["pile"]["in_bin"]
    assert sum(g["landed"] for g in run["grasps"]) == run["delivered"]
    assert len(run["escapes"]) <= run["lost"]
    assert all(g["weighed"] is not None or g["disposition"] in ("EMPTY", None)
               for g in run["grasps"])  # closed loop: every held lift was weighed
    for g in run["grasps"]:  # the load path's truth: a part that landed was held up
        if g["landed"] and g["disposition"] == "DELIVERED":
            assert g["held"] >= 1 and g["resting"] is not None and g["held_decided"] >= 1
    summary = json.loads((out / "clear_summary.json").read_text())
    figures = summary["overall"]["graspability"]
    assert figures["delivered"] == run["delivered"] and figures["bins"] == 1
    assert figures["parts_per_hour"] > 0
    assert sum(figures["lost_by_mode"].values()) == run["lost"]
    assert f"commit {summary['commit']}, on {summary['machine']}" in \
        (out / "clear_report.md").read_text().splitlines()[2]
    assert "exactly one part" in (out / "clear_report.md").read_text()
    assert "graspability: delivered" in capsys.readouterr().out
    for g in run["grasps"]:  # a grasp that delivered reached into the bin, after a look
        if g["landed"]:
            assert g["in_bin_s"] > 0 and g["look_s"] > 0
    assert "two arms could deliver at most" in (out / "clear_report.md").read_text()
    starts = [g["started_at"] for g in run["grasps"] if g["started_at"] is not None]
    assert starts == sorted(starts) and len(starts) >= 1
    if run["left_in_bin"]:  # why it stopped short is in the report
        assert run["end_reason"] != "the bin is empty"
        assert run["end_reason"] in (out / "clear_report.md").read_text()
    else:
        assert run["end_reason"] == "the bin is empty"
    # The same command again resumes: nothing to run.
    assert main(["bench", "--clear", "--quick", "--workers", "1", "--out", str(out)]) == 0
    assert len(trials_in(out)) == 1
    with pytest.raises(TangleDrakeError, match="other settings"):  # open loop is another run
        run_bench(BenchOptions(clear=True, open_loop=True, quick=True, workers=1, out=out,
                               show_progress=False))


def test_the_rate_is_reported_by_third_of_the_bin_as_it_empties():
    def grasp(start, landed):
        return {"outcome": "ONE" if landed else "NONE", "failure": None, "lifted": landed,
                "held": landed, "resting": 0, "held_decided": landed, "recoveries": [],
                "disposition": "DELIVERED" if landed else "EMPTY", "landed": landed,
                "started_at": start, "execution_s": 10.0, "compute_s": 1.0}

    # 6 parts: two delivered by 22 s, four by 56 s, five when it ended at 70 s, one left.
    run = {"method": "m", "delivered": 5, "left_in_bin": 1, "lost": 0, "sim_s": 70.0,
           "compute_s": 6.0, "grasps": [grasp(0, 1), grasp(12, 1), grasp(24, 0), grasp(34, 1),
                                        grasp(46, 1), grasp(58, 1)]}
    first, middle, last = figures([run])["parts_per_hour_by_third"]
    assert first == pytest.approx(2 / (24 / 3600))  # 22 s simulated + 2 s computing
    assert middle == pytest.approx(2 / (37 / 3600))  # 22 -> 56 s, three grasps' computing
    assert last == pytest.approx(1 / (15 / 3600))  # 56 -> 70 s, one grasp's
    old = {**run, "grasps": [{k: v for k, v in g.items() if k != "started_at"}
                             for g in run["grasps"]]}
    assert figures([old])["parts_per_hour_by_third"] is None  # made before starts were kept


def test_a_clearing_says_why_it_ended():
    gave_up = PickRecord(index=7, failure=FailureKind.GAVE_UP,
                         reason="5 grasps in a row delivered nothing, 2 stirs since the last "
                                "delivery")
    done = PickRun([PickRecord(index=1, outcome=Outcome.ONE)], RunEnd.DONE, 80.0)
    assert end_reason(done, 0, 600.0) == "the bin is empty"
    assert end_reason(replace(done, records=[gave_up]), 3, 600.0) == \
        "gave up: 5 grasps in a row delivered nothing, 2 stirs since the last delivery"
    assert end_reason(replace(done, end=RunEnd.TIMEOUT), 3, 600.0) == \
        "out of time: 600 simulated s allowed"
    assert end_reason(replace(done, end=RunEnd.STOPPED, safety_message="wrist overload"), 3,
                      600.0) == "safety stop: wrist overload"
    assert "with 3 parts in the bin" in end_reason(done, 3, 600.0)


def test_a_long_clearing_says_where_it_stands_within_its_bin():
    lines: list[str] = []
    progress = BinProgress("s_hook bin 2 (harmonic)", 40, 0.0, lines.append)
    rows = [{"landed": 1, "compute_s": 2.0}, {"landed": 0, "compute_s": 2.0},
            {"landed": 1, "compute_s": 2.0}]
    progress.grasp(rows, 34.0, 37)  # 2 parts in 34 + 6 s: 180 parts per hour
    (line,) = lines
    assert line.startswith("  s_hook bin 2 (harmonic): 2 of 40 parts delivered, 37 in the bin, "
                           "3 grasps, 180 parts per hour so far, about ")
    assert line.endswith(" min left")
    BinProgress("quiet", 40, None, lines.append).grasp(rows, 34.0, 37)
    assert len(lines) == 1  # no interval: silent


def test_the_escape_watch_names_the_mode_a_lost_part_left_the_bin_in():
    bin_config = BinConfig()  # centred at (0.34, 0.22), floor at 0.93
    inside, tray_xy = [0.34, 0.22, 0.95], [0.34, 0.60]
    poses = np.tile(np.eye(4), (3, 1, 1))
    pick = SimpleNamespace(
        station=SimpleNamespace(part_poses=lambda context: poses.copy()),
        tray=SimpleNamespace(in_tray=lambda p: np.linalg.norm(p[..., :2] - tray_xy, axis=-1)
                             < 0.1))
    grasps: list[dict] = []
    watch = EscapeWatch(pick, bin_config, None, grasps)
    poses[:, :3, 3] = inside
    assert watch(Mode.LIFT) > 0 and watch.escapes == []
    grasps.append({})  # one grasp recorded; the next one shakes
    watch(Mode.SHAKE)
    poses[1, :3, 3] = [0.34, 0.45, 0.40]  # flung past the wall during the shake, falling
    poses[2, :3, 3] = [0.34, 0.20, 1.20]  # held high above the bin: not lost
    watch(Mode.TRANSFER)  # seen at the look after the shake's interval
    assert watch.escapes == [{"grasp": 1, "mode": "shake", "part": 1, "source": "bin"}]
    poses[1, :3, 3] = [0.34, 0.45, 0.01]  # on the ground: the same escape, counted once
    poses[2, :3, 3] = [*tray_xy, 0.89]  # released into the tray (below the bin's floor)
    watch(Mode.HOME)
    assert len(watch.escapes) == 1
    poses[2, :3, 3] = [0.34, 0.75, 0.30]  # bounced out of the tray while the next grasp began
    watch(Mode.APPROACH)
    assert watch.escapes[1] == {"grasp": 1, "mode": "home", "part": 2, "source": "tray"}


def test_several_read_as_one_is_judged_at_the_weighing_that_decided_the_delivery():
    def grasp(landed=1, held=1, decided=1, recoveries=(), disposition="DELIVERED"):
        return {"outcome": "ONE", "failure": None, "lifted": held, "held": held,
                "resting": 0, "held_decided": decided, "recoveries": list(recoveries),
                "disposition": disposition, "landed": landed}

    def read_as_one(*grasps):
        run = {"method": "m", "grasps": list(grasps), "delivered": 1, "left_in_bin": 0,
               "lost": 0, "sim_s": 10.0, "compute_s": 1.0}
        return figures([run])["several_read_as_one"]

    assert read_as_one(grasp()) == 0
    assert read_as_one(grasp(held=2, decided=1, recoveries=["SHAKE"])) == 0  # the shake worked
    assert read_as_one(grasp(held=2, decided=2, recoveries=["SHAKE"])) == 1  # it did not
    assert read_as_one(grasp(held=1, decided=2)) == 1
    assert read_as_one(grasp(landed=2)) == 1  # two landed, whatever was weighed
    assert read_as_one(grasp(held=2, decided=2, disposition="PUT_BACK", landed=0)) == 0
    # Rows made before the deciding weighing was recorded: the first weighing decided unless
    # a shake or re-weighing followed.
    assert read_as_one(grasp(held=2, decided=None)) == 1
    assert read_as_one(grasp(held=2, decided=None, recoveries=["SHAKE", "REWEIGH"])) == 0


def test_a_weighing_with_a_part_on_the_pile_counts_and_fingers_closed_on_nothing_do_not():
    def grasp(resting, weighed, verdict):
        return {"outcome": "NONE", "failure": None, "lifted": 0, "held": 1,
                "resting": resting, "held_decided": 1, "recoveries": [], "weighed": weighed,
                "verdict": verdict, "disposition": "EMPTY", "landed": 0}

    run = {"method": "m", "delivered": 0, "left_in_bin": 1, "lost": 0, "sim_s": 10.0,
           "compute_s": 1.0, "grasps": [grasp(1, 0.4, "NONE"), grasp(1, None, "UNSURE"),
                                        grasp(2, None, "NONE"), grasp(0, 1.0, "ONE")]}
    assert figures([run])["weighed_resting"] == 2


def test_lost_parts_are_reported_by_the_mode_they_left_the_bin_in():
    runs = [{"method": "m", "grasps": [], "delivered": 3, "left_in_bin": 0, "lost": 3,
             "sim_s": 10.0, "compute_s": 1.0,
             "escapes": [{"grasp": 0, "mode": "shake", "part": 1, "source": "bin"},
                         {"grasp": 2, "mode": "shake", "part": 4, "source": "bin"}]},
            {"method": "m", "grasps": [], "delivered": 5, "left_in_bin": 0, "lost": 1,
             "sim_s": 10.0, "compute_s": 1.0}]  # a run made before escapes were recorded
    assert figures(runs)["lost_by_mode"] == {"bin in shake": 2, "unseen": 2}


def test_open_loop_goes_with_clear():
    with pytest.raises(TangleDrakeError, match="--open-loop goes with --clear"):
        plan(replace(QUICK, open_loop=True))


def test_a_scenario_without_parts_is_refused_and_a_scenarios_own_part_is_the_default(tmp_path):
    text = (diagrams_dir() / "floating_gripper.yaml").read_text()
    empty = tmp_path / "empty.yaml"
    empty.write_text(text.replace("count: 15", "count: 0"))
    with pytest.raises(TangleDrakeError, match="pile has no parts"):
        plan(BenchOptions(scenario=str(empty), workers=1))
    rings = tmp_path / "rings.yaml"
    rings.write_text(text.replace("part: u_hook", "part: c_ring"))
    config, _, notices = plan(BenchOptions(scenario=str(rings), workers=1,
                                           methods=["graspability"]))
    assert [p.name for p in config.parts] == ["c_ring"]
    assert any("parts from the scenario" in note and "c_ring" in note for note in notices)


def test_a_model_of_another_part_is_noticed_in_the_run():
    from tangle_drake.selection.choice import trained_model_path

    model = trained_model_path("c_ring")
    _, _, notices = plan(replace(QUICK, methods=["graspability", f"model:{model}"]))
    assert any("trained on part 'c_ring'" in note and "'u_hook'" in note for note in notices)
    _, _, notices = plan(replace(QUICK, parts=["c_ring"],
                                 methods=["graspability", f"model:{model}"]))
    assert not any("trained on part" in note for note in notices)


def test_a_run_that_finished_no_trial_binds_nothing(tmp_path):
    from tangle_drake.bench.results import ResultStore

    first = ResultStore(tmp_path, {"methods": ["harmonic"], "seed": 0})
    assert not first.trials  # it failed before a trial finished (a corrupt model, say)
    again = ResultStore(tmp_path, {"methods": ["harmonic", "graspability"], "seed": 0})
    assert any("starting over" in note for note in again.notices)
    again.add({"part": "u_hook", "trial": 0, "picks": []})
    with pytest.raises(TangleDrakeError, match="other settings"):
        ResultStore(tmp_path, {"methods": ["harmonic"], "seed": 0})


def test_clearing_with_a_sensor_too_coarse_for_the_part_says_so_before_it_starts():
    overlay = Path(__file__).parents[1] / "docs/results/clearing/overlays/wrist_noise_x5.yaml"
    scenario = scenario_source(["floating_gripper.yaml", overlay])
    _, _, notices = plan(BenchOptions(clear=True, scenario=scenario, parts=["u_hook", "j_hook"],
                                      methods=["graspability"], trials=1))
    warnings = [n for n in notices if "weighs one part" in n]
    assert len(warnings) == 1 and "32.8 g" in warnings[0]  # the U-hook's; the J-hook is heavy
    _, _, notices = plan(BenchOptions(clear=True, open_loop=True, scenario=scenario,
                                      parts=["u_hook"], methods=["graspability"], trials=1))
    assert not any("weighs one part" in n for n in notices)  # the open loop weighs nothing
