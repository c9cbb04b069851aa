"""``tangle-drake teach``: the mesh check refuses what is not a pickable part, with the reason,
and accepts the meshes a user brings; a small run goes through every stage, and one interrupted
at each stage boundary resumes there without redoing finished work."""

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from cli_run import run_command

from tangle_drake.cli import main
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.parts import catalog, wire
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.choice import model_part_notice, trained_model_path
from tangle_drake.station.pile import PileReport
from tangle_drake.teach import pipeline
from tangle_drake.teach.check import check_part, settle_verdict
from tangle_drake.teach.pipeline import STAGES, Teacher, TeachSettings

SCENARIO = resolve_scenario("floating_gripper.yaml")


def _hook_mm() -> trimesh.Trimesh:
    mesh = wire.tube_mesh(catalog.builtin_spec("u_hook"))
    mesh.apply_scale(1000.0)
    return mesh


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    """Meshes a user might bring, good and bad."""
    out = tmp_path_factory.mktemp("meshes")
    hook = _hook_mm()
    hook.export(out / "hook_mm.stl")
    trimesh.creation.torus(major_radius=0.02, minor_radius=0.0025).export(out / "ring_m.ply")
    trimesh.creation.box(extents=(50.0, 20.0, 3.0)).export(out / "bracket_mm.obj")
    hook.update_faces(np.arange(len(hook.faces)) >= wire.TUBE_SIDES * 6)  # an end face gone
    hook.remove_unreferenced_vertices()
    hook.export(out / "open_hook_mm.stl")
    trimesh.Trimesh([[0, 0, 0], [40, 0, 0], [40, 30, 0], [0, 30, 0]],
                    [[0, 1, 2], [0, 2, 3]]).export(out / "sheet_mm.stl")
    (out / "empty.obj").write_text("# nothing here\n")
    return out


@pytest.mark.parametrize(("name", "scale"), [("hook_mm.stl", 0.001), ("ring_m.ply", 1.0),
                                             ("bracket_mm.obj", 0.001),
                                             ("open_hook_mm.stl", 0.001)])
def test_the_check_accepts_the_parts_a_user_brings(meshes, name, scale):
    check = check_part(meshes / name, scale, SCENARIO)
    assert check.accepted, check.refusal
    assert max(check.size_m) == pytest.approx({"hook_mm.stl": 0.070, "ring_m.ply": 0.045,
                                               "bracket_mm.obj": 0.050,
                                               "open_hook_mm.stl": 0.070}[name], abs=1e-3)
    assert check.mass_kg > 0 and check.pieces >= 1 and check.pieces_volume_ratio > 0.9
    assert check.watertight == (name != "open_hook_mm.stl")
    assert check.holes_capped == (name == "open_hook_mm.stl")
    assert any("mm" in line for line in check.lines())


@pytest.mark.parametrize(("name", "scale", "reason"), [
    ("sheet_mm.stl", 0.001, "encloses no volume"),
    ("empty.obj", 1.0, "no triangles"),
    ("hook_mm.stl", 1.0, "the scale is probably wrong"),  # millimetres read as metres
    ("hook_mm.stl", 0.0001, "smaller than a finger is wide"),
    ("ring_m.ply", 10.0, "too large for the bin"),
    ("missing.stl", 1.0, "not found"),
])
def test_the_check_refuses_what_is_not_a_pickable_part_with_the_reason(meshes, name, scale,
                                                                      reason):
    check = check_part(meshes / name, scale, SCENARIO)
    assert not check.accepted and reason in check.refusal
    assert check.lines()[-1].startswith(f"mesh {meshes / name}: refused") or \
        check.lines()[-1].startswith("refused")


def test_a_weighed_mass_overrides_the_meshs_and_a_pile_the_physics_cannot_make_is_refused(
        meshes):
    part_file = meshes / "hook.json"
    part_file.write_text(json.dumps({"mesh": "hook_mm.stl", "mesh_scale": 0.001,
                                     "mass_kg": 0.02}))
    check = check_part(part_file, 1.0, SCENARIO)
    assert check.mass_kg == pytest.approx(0.02) and check.mass_from == "weighed"
    assert check.pieces_volume_ratio == pytest.approx(
        check_part(meshes / "hook_mm.stl", 0.001, SCENARIO).pieces_volume_ratio)
    good = PileReport(seed=0, num_parts=15, settle_time=1.0, max_penetration=0.0002,
                      settled=True)
    assert settle_verdict(check, good).accepted
    bad = PileReport(seed=0, num_parts=15, settle_time=16.0, parked=[f"p{i}" for i in range(9)],
                     max_penetration=0.011, settled=False)
    refused = settle_verdict(check, bad)
    assert "cannot pile this part: 9 of 15" in refused.refusal
    assert "9 parked" in refused.pile


def test_a_small_run_teaches_every_stage_and_resumes_at_each_boundary(meshes, tmp_path,
                                                                      monkeypatch):
    settings = TeachSettings(str(meshes / "hook_mm.stl"), 0.001, samples=30, test_samples=6,
                             bench_trials=1, epochs=1, parts_per_pile=10,
                             validation_fraction=0.3)
    out = tmp_path / "hook"
    finished: list[str] = []

    def stop_after_each(stage: str) -> None:
        finished.append(stage)
        raise KeyboardInterrupt  # as Ctrl-C would, between two stages

    monkeypatch.setattr(pipeline, "AFTER_STAGE", stop_after_each)
    said: list[str] = []
    labelled = None
    for _ in STAGES:
        with pytest.raises(KeyboardInterrupt):
            Teacher(settings, out, workers=1, say=said.append).run()
        if finished[-1] == "labels":
            labelled = _mtimes(out / "data")
    assert finished == list(STAGES)  # each stage ran once, in order
    assert _mtimes(out / "data") == labelled  # the labels were not collected again
    assert sum(line.endswith(": done before") for line in said) == sum(range(len(STAGES)))
    for name in ("part.json", "check.json", "part.png", "pile.png", "model.pt", "test.json",
                 "card.md", "bench/report.md"):
        assert (out / name).is_file(), name
    assert json.loads((out / "teach.json").read_text())["done"] == list(STAGES)
    card = (out / "card.md").read_text()
    assert "## Test on fresh piles" in card and "| graspability |" in card
    assert model_part_notice(out / "model.pt", str(out / "part.json")) is None  # its part
    assert "trained on part 'hook_mm'" in model_part_notice(out / "model.pt", "u_hook")
    with pytest.raises(TangleDrakeError, match="other settings"):
        Teacher(replace(settings, samples=31), out, say=said.append)


def _mtimes(directory: Path) -> dict[Path, int]:
    return {p: p.stat().st_mtime_ns for p in directory.glob("shard_*")}


def test_the_command_refuses_a_bad_mesh_with_its_reason(meshes, tmp_path):
    with pytest.raises(TangleDrakeError, match=r"sheet_mm\.stl is refused: .*encloses no volume"):
        run_command("teach", str(meshes / "sheet_mm.stl"), "--mesh-scale", "0.001",
                    "--out", str(tmp_path / "sheet"))


def test_a_refusal_is_one_error_line_and_leaves_out_free_for_the_fixed_mesh(meshes, tmp_path,
                                                                           capsys,
                                                                           monkeypatch):
    """The user's mesh is a sheet: ``teach`` says so on stderr, as every command refuses, and
    leaves ``--out`` as it was (not made, or made by the user and still empty); the user fixes
    the mesh in place and the same command teaches into the same ``--out``."""
    mesh = tmp_path / "bracket.stl"
    shutil.copy(meshes / "sheet_mm.stl", mesh)
    out = tmp_path / "runs" / "bracket"
    command = ["teach", str(mesh), "--mesh-scale", "0.001", "--out", str(out)]
    assert main(command) == 2
    printed = capsys.readouterr()
    assert "refused" not in printed.out
    (line,) = printed.err.splitlines()
    assert line.startswith(f"error: {mesh} is refused: ") and "encloses no volume" in line
    assert not (tmp_path / "runs").exists()  # nor the parent teach made for it
    out.mkdir(parents=True)
    assert main(command) == 2
    assert out.is_dir() and not any(out.iterdir())

    def stop_after(stage: str) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "AFTER_STAGE", stop_after)
    shutil.copy(meshes / "hook_mm.stl", mesh)  # fixed in place: another mesh, the same path
    capsys.readouterr()
    assert main(command) == 130
    assert "check: finished" in capsys.readouterr().out
    assert json.loads((out / pipeline.STATE_FILE).read_text())["done"] == ["check"]


@pytest.mark.parametrize("how", ["the pile", "an error"])
def test_a_check_refused_after_its_pictures_leaves_out_as_it_found_it(tmp_path, monkeypatch,
                                                                      how):
    """The pile refusal comes after the pictures and part file are written: they go too, as
    does what an earlier, interrupted check of the same run left."""
    out = tmp_path / "ring"

    def stop_after(stage: str) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "AFTER_STAGE", stop_after)
    with pytest.raises(KeyboardInterrupt):  # a check that finished: its files and the state
        Teacher(TeachSettings("c_ring"), out, say=lambda line: None).run()
    state = json.loads((out / pipeline.STATE_FILE).read_text())
    (out / pipeline.STATE_FILE).write_text(json.dumps({**state, "done": []}))  # as if cut
    assert (out / "pile.png").is_file()

    def refuse(check, report):
        if how == "an error":
            raise TangleDrakeError("the pile cannot be made")
        return replace(check, refusal="the simulation cannot pile this part")

    monkeypatch.setattr(pipeline, "settle_verdict", refuse)
    teacher = Teacher(TeachSettings("c_ring"), out, say=lambda line: None)
    if how == "an error":
        with pytest.raises(TangleDrakeError, match="cannot be made"):
            teacher.run()
    else:
        assert "cannot pile" in teacher.run().refusal
    assert out.is_dir() and not any(out.iterdir())  # it was there when this run began


def test_an_interrupted_benchmark_is_not_done_and_the_same_command_finishes_it(tmp_path,
                                                                              monkeypatch,
                                                                              capsys):
    """Ctrl-C in the benchmark's trials (which ``run_bench`` catches to report what finished)
    stops ``teach`` with 130 and leaves the benchmark and the card unfinished; the same command
    resumes at the benchmark, not redoing the stages before it. The labels, training and test
    stand in (the shipped model for the trained one) to keep it to one benchmark trial."""
    from tangle_drake.bench.trials import TrialWorker

    ran: list[str] = []

    def stand_in(stage: str):
        def run(self: Teacher) -> None:
            ran.append(stage)
            if stage == "train":
                shutil.copy(trained_model_path("u_hook"), self.model)
        return run

    for stage in ("labels", "train", "test", "card"):
        monkeypatch.setattr(Teacher, f"_{stage}", stand_in(stage))

    def ctrl_c(self, task):
        raise KeyboardInterrupt

    out = tmp_path / "hook"
    command = ["teach", "u_hook", "--quick", "--workers", "1", "--out", str(out)]
    with monkeypatch.context() as patch:
        patch.setattr(TrialWorker, "run_task", ctrl_c)
        assert main(command) == 130
    assert capsys.readouterr().err.startswith("interrupted")
    assert json.loads((out / pipeline.STATE_FILE).read_text())["done"] == [
        "check", "labels", "train", "test"]
    assert ran == ["labels", "train", "test"]  # the card did not run
    assert main(command) == 0
    printed = capsys.readouterr().out
    assert all(f"{stage}: done before" in printed for stage in ("check", "labels", "test"))
    assert "bench: done before" not in printed
    assert ran == ["labels", "train", "test", "card"]
    assert json.loads((out / pipeline.STATE_FILE).read_text())["done"] == list(STAGES)
    trials = (out / "bench" / "results.jsonl").read_text().splitlines()
    assert [json.loads(trial)["trial"] for trial in trials] == [0]


def test_the_command_takes_the_label_and_test_counts(tmp_path, monkeypatch):
    for option in ("--samples", "--test-samples"):
        with pytest.raises(TangleDrakeError, match=f"{option} must be at least 1, got 0"):
            run_command("teach", "c_ring", option, "0", "--out", str(tmp_path / "none"))

    def stop_after_check(stage: str) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "AFTER_STAGE", stop_after_check)
    out = tmp_path / "ring"
    assert run_command("teach", "c_ring", "--samples", "120", "--test-samples", "1000",
                       "--out", str(out)) == 130
    identity = json.loads((out / pipeline.STATE_FILE).read_text())["identity"]
    assert (identity["samples"], identity["test_samples"]) == (120, 1000)
    assert identity["bench_trials"] == TeachSettings("c_ring").bench_trials  # the rest default


def test_the_check_of_a_built_in_part_reads_its_wire():
    check = check_part("u_hook", 1.0, SCENARIO)
    assert check.accepted and check.mass_from == "wire" and check.watertight
    assert max(check.size_m) == pytest.approx(0.070, abs=2e-3)
    assert check.pieces == len(wire.capsules(catalog.builtin_spec("u_hook")))
    assert 1.0 < check.pieces_volume_ratio < 1.3  # capsules overlap at their joints
    assert check.lines()[0].startswith("built-in part u_hook")


def test_teaching_a_built_in_part_makes_the_shipped_recipes_labels_and_weights(tmp_path,
                                                                              monkeypatch):
    """One way to make a model: ``teach u_hook`` collects what ``collect --part u_hook`` does
    and trains what ``train`` on it does with the shipped models' one thread."""
    import torch

    from tangle_drake.dataset import load_samples
    from tangle_drake.tangle_cnn.checkpoint import read_checkpoint
    from tangle_drake.tangle_cnn.train import TrainSettings, train

    settings = TeachSettings("u_hook", samples=10, epochs=1, validation_fraction=0.3)
    out = tmp_path / "taught"

    def stop_after_train(stage: str) -> None:
        if stage == "train":
            raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "AFTER_STAGE", stop_after_train)
    threads = torch.get_num_threads()
    torch.set_num_threads(2)  # teach pins the training's threads whatever the process has
    try:
        with pytest.raises(KeyboardInterrupt):
            Teacher(settings, out, workers=1, say=lambda line: None).run()
    finally:
        torch.set_num_threads(threads)
    assert not (out / "part.json").exists()  # a built-in needs no part file
    data = tmp_path / "collected"
    assert run_command("collect", "--part", "u_hook", "--samples", "10", "--out", str(data),
                       "--seed", "0", "--workers", "1") == 0
    taught, collected = load_samples(out / "data"), load_samples(data)
    assert taught.keys() == collected.keys()
    for name in taught:
        np.testing.assert_array_equal(taught[name], collected[name], err_msg=name)
    torch.set_num_threads(1)
    try:
        train(data, tmp_path / "trained.pt", TrainSettings(epochs=1, seed=0,
                                                          validation_fraction=0.3),
              device="cpu", log=lambda line: None)
    finally:
        torch.set_num_threads(threads)
    mine = read_checkpoint(out / "model.pt")["state_dict"]
    theirs = read_checkpoint(tmp_path / "trained.pt")["state_dict"]
    assert mine.keys() == theirs.keys()
    assert all(torch.equal(mine[k], theirs[k]) for k in mine)


def test_a_built_in_part_takes_no_mesh_scale_or_mass(tmp_path):
    with pytest.raises(TangleDrakeError, match="built-in part, with its own size and mass"):
        Teacher(TeachSettings("c_ring", mesh_scale=0.001), tmp_path / "ring")
