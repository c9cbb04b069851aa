"""Physical-pick data (``collect --label pick``): each top candidate picked by the simulated
gripper from the same pile, labelled by the simulation's count, resumable to exactly the
uninterrupted dataset; a forced candidate is that one alone; bad options are clear errors."""

import json
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import finished_tasks, load_samples, read_manifest
from tangle_drake.graspability import GraspCandidate
from tangle_drake.selection.methods import GraspSelector, MethodRun
from tangle_drake.station.perturb import ContactScaler, PhysicsSpread, PickPhysics, offset_pose
from tangle_drake.tangle_data.ceiling import pick_ceiling, rule_choice
from tangle_drake.tangle_data.collect import collect_picks
from tangle_drake.tangle_data.physical import PhysicalPickSimulator, PickDataSettings

SETTINGS = PickDataSettings(part="c_ring", parts_per_pile=4, top_k=2)
SAMPLES = 3  # two piles of two picks
FIELDS = ("outcome", "label", "rank", "task", "pile_seed", "sim_lifted", "u", "v", "crop")

run_cli = partial(run_command, "collect")


def _arrays(directory: Path) -> dict[str, np.ndarray]:
    return load_samples(directory, FIELDS)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("picks")
    result = collect_picks(SETTINGS, out, SAMPLES, workers=1, show_progress=False)
    assert not result.interrupted
    return out


def test_each_pick_is_labelled_by_what_the_simulation_saw_come_up(uninterrupted):
    samples = _arrays(uninterrupted)
    counts = read_manifest(uninterrupted)["counts"]
    assert counts["tasks"] == 2
    assert counts["samples"] + counts["failed"] == 4  # every candidate tried
    assert counts["samples"] == len(samples["outcome"]) >= SAMPLES
    assert counts["one"] + counts["tangled"] + counts["none"] == counts["samples"]
    for outcome, lifted, label in zip(samples["outcome"], samples["sim_lifted"],
                                      samples["label"], strict=True):
        # none 0, one 1, several 2; -1: no lift, the fingers closed on nothing
        assert outcome == (0 if lifted == -1 else min(int(lifted), 2))
        assert label == {0: -1, 1: 0, 2: 1}[int(outcome)]  # tangled: several
    for task in np.unique(samples["task"]):
        mine = samples["task"] == task
        assert len(np.unique(samples["pile_seed"][mine])) == 1  # one pile per task
        assert set(samples["rank"][mine]) <= {0, 1}
        picked = np.c_[samples["u"][mine], samples["v"][mine]]
        assert len(np.unique(picked, axis=0)) == mine.sum()  # each rank its own candidate
    assert np.isfinite(samples["crop"]).all()
    assert read_manifest(uninterrupted)["label"] == "pick"


def test_an_interrupted_collection_resumes_to_the_same_picks(uninterrupted, tmp_path,
                                                              monkeypatch):
    run_task = PhysicalPickSimulator.run_task

    def interrupted_at_task_1(self, task):
        if task == 1:
            raise KeyboardInterrupt  # as Ctrl-C would, between two piles
        return run_task(self, task)

    monkeypatch.setattr(PhysicalPickSimulator, "run_task", interrupted_at_task_1)
    first = collect_picks(SETTINGS, tmp_path, SAMPLES, workers=1, show_progress=False)
    assert first.interrupted and finished_tasks(tmp_path) == {0}
    monkeypatch.setattr(PhysicalPickSimulator, "run_task", run_task)
    collect_picks(SETTINGS, tmp_path, SAMPLES, workers=1, show_progress=False)
    assert finished_tasks(tmp_path) == finished_tasks(uninterrupted)
    resumed, reference = _arrays(tmp_path), _arrays(uninterrupted)
    for name in FIELDS:
        assert resumed[name].tobytes() == reference[name].tobytes(), name
    with pytest.raises(TangleDrakeError, match="other settings"):
        collect_picks(PickDataSettings(part="c_ring", parts_per_pile=4, top_k=3), tmp_path,
                      SAMPLES, workers=1, show_progress=False)


def test_the_fast_pick_ends_an_empty_close_there_with_the_full_picks_outcome():
    from tangle_drake.common.paths import diagrams_dir
    from tangle_drake.episode.episode import Episode
    from tangle_drake.pick.outcome import Outcome
    from tangle_drake.selection.methods import Method
    from tangle_drake.tangle_data.physical import PICK_SCENARIO, pick_data_scenario

    settings = PickDataSettings(part="e_shape", parts_per_pile=4, physics=None)
    scenario = pick_data_scenario((diagrams_dir() / PICK_SCENARIO).read_text(), settings)
    methods = [Method("graspability", "graspability")]
    full, fast = (Episode.single_pick(scenario, methods, "e_shape", True, fast=f)
                  for f in (False, True))
    settled = full.settle(9)  # rank 0 closes on nothing, rank 1 brings up one E
    for rank, outcome in ((0, Outcome.NONE), (1, Outcome.ONE)):
        run = MethodRun("graspability", 0, only=rank)
        slow, quick = full.pick(settled.state, run), fast.pick(settled.state, run)
        assert slow.record.outcome is quick.record.outcome is outcome
        assert quick.record.candidate.u == slow.record.candidate.u
        assert np.array_equal(quick.depth, slow.depth)
        if outcome is Outcome.NONE:  # judged at the close, two simulated seconds sooner
            assert quick.record.width < fast.empty_width and quick.record.truth.lifted is None
            assert quick.sim_s < slow.sim_s - 1.5
            assert 0 < quick.record.timing.execution_s < quick.sim_s
        else:  # a grasp that holds something is the full pick, the parts out of reach frozen
            assert quick.sim_s == slow.sim_s
            assert quick.record.truth.lifted == slow.record.truth.lifted
            assert quick.record.width == pytest.approx(slow.record.width, abs=2e-4)
            assert quick.record.width != slow.record.width  # a part was frozen: another sim


def test_a_forced_candidate_is_that_candidate_alone():
    candidates = [SimpleNamespace(u=float(i), v=0.0, angle_deg=0.0, score=1 - i / 10, pose=None)
                  for i in range(4)]
    switch = GraspSelector([])
    context = switch.CreateDefaultContext()
    switch.GetInputPort("candidates").FixValue(context, candidates)
    for rank in range(6):
        switch.GetInputPort("method").FixValue(context, MethodRun("graspability", 0, rank))
        scored = switch.GetOutputPort("scored_candidates").Eval(context)
        selected = switch.GetOutputPort("selected_grasp").Eval(context)
        if rank < len(candidates):
            assert [s.candidate for s in scored] == [candidates[rank]]
            assert selected == candidates[rank]
        else:
            assert scored == [] and selected is None


@pytest.mark.parametrize(("argv", "message"), [
    (["--repeat", "3"], "--repeat is an option of the force lift"),
    (["--lift-height", "0.2"], "--lift-height"),
    (["--top-k", "0"], "--top-k"),
    (["--label", "lift", "--full-pick"], "--full-pick is an option of --label pick"),
    (["--label", "lift", "--depth-noise", "0.001"], "--depth-noise is an option of --label"),
    (["--depth-noise", "-0.001"], "--depth-noise must be >= 0"),
    (["--no-randomise", "--depth-noise", "0.001"], "drop --depth-noise"),
    (["--parts-per-pile", "0"], "--parts-per-pile"),
    (["--scenario", "no_such.yaml"], "cannot read scenario"),
])
def test_bad_options_are_clear_errors(argv, message, tmp_path):
    with pytest.raises(TangleDrakeError, match=message):
        run_cli("--label", "pick", "--part", "c_ring", *argv, "--out", str(tmp_path / "d"))


def test_a_scenario_without_a_gripper_to_pick_with_is_refused(tmp_path):
    from tangle_drake.common.paths import diagrams_dir

    text = (diagrams_dir() / "pile_only.yaml").read_text()
    with pytest.raises(TangleDrakeError, match="the pick-data scenario: picking needs a robot"):
        collect_picks(SETTINGS, tmp_path / "d", 1, workers=1, scenario_text=text,
                      show_progress=False)


def test_the_ceiling_is_graspabilitys_first_reachable_pick_against_the_best_of_each_pile():
    # Pile 0: rank 0 several, rank 2 one. Pile 1: rank 0 unreachable (absent), rank 1 one.
    # Pile 2: nothing but empty grasps.
    samples = {"task": np.array([0, 0, 0, 1, 1, 2, 2]),
               "rank": np.array([2, 0, 1, 1, 2, 0, 1]),
               "outcome": np.array([1, 2, 0, 1, 0, 0, 0])}
    ceiling = pick_ceiling(samples)
    assert ceiling.piles == 3
    assert ceiling.graspability == pytest.approx(1 / 3)  # only pile 1's first reachable pick
    assert ceiling.oracle == pytest.approx(2 / 3)
    assert ceiling.gap == pytest.approx(1 / 3)
    assert ceiling.by_rank == {0: (0.0, 2), 1: (pytest.approx(1 / 3), 3), 2: (0.5, 2)}
    with pytest.raises(ValueError, match="no physical picks"):
        pick_ceiling({name: np.zeros(0) for name in samples})


def test_a_rules_first_picks_are_scored_by_the_recorded_outcomes_of_its_choice():
    # Pile 0: rank 0 several, rank 1 one; pile 1: rank 0 one, rank 1 none; pile 2: rank 0
    # unreachable (absent), rank 1 several, rank 2 one. The model favours the one-part picks.
    samples = {"task": np.array([0, 0, 1, 1, 2, 2]), "rank": np.array([1, 0, 0, 1, 2, 1]),
               "outcome": np.array([1, 2, 1, 0, 1, 2]),
               "score": np.array([0.8, 0.9, 0.7, 0.6, 0.4, 0.5])}
    p_one = np.array([0.9, 0.2, 0.8, 0.3, 0.7, 0.1])
    ceiling = pick_ceiling(samples)
    choice = rule_choice(samples, "success-cnn", p_one)
    assert choice.success == pytest.approx(1.0) and ceiling.graspability == pytest.approx(1 / 3)
    assert choice.closed == pytest.approx(1.0)
    assert (choice.against_graspability.a_only, choice.against_graspability.b_only) == (2, 0)
    assert rule_choice(samples, "graspability").success == pytest.approx(ceiling.graspability)
    # A model that prefers the wrong picks loses against graspability: a negative share.
    worse = rule_choice(samples, "success-cnn", 1 - p_one)
    assert worse.success == 0.0 and worse.closed == pytest.approx(-0.5)


def test_a_pick_draws_its_physics_from_the_seed_within_the_spread(uninterrupted):
    spread = PhysicsSpread()
    draws = [PickPhysics.draw(spread, np.random.default_rng(seed)) for seed in range(200)]
    assert PickPhysics.draw(spread, np.random.default_rng(3)) == draws[3]
    friction = np.array([d.friction for d in draws])
    stiffness = np.array([d.pad_stiffness for d in draws])
    offsets = np.array([d.offset for d in draws])
    assert (abs(friction - 1) <= spread.friction).all() and friction.std() > 0.05
    assert (stiffness >= 1 / (1 + spread.pad_stiffness) - 1e-12).all()
    assert (stiffness <= 1 + spread.pad_stiffness + 1e-12).all()
    assert offsets[:, :2].std() == pytest.approx(spread.position_m, rel=0.2)
    assert offsets[:, 2].std() == pytest.approx(spread.angle_deg, rel=0.2)
    assert PickPhysics.draw(PhysicsSpread(0, 0, 0, 0), np.random.default_rng(0)) == \
        PickPhysics(1.0, 1.0, (0.0, 0.0, 0.0))
    # The collection records each pick's draw, and the depth noise its crop saw.
    record = json.loads((uninterrupted / "shard_0000000.json").read_text())
    assert [p["rank"] for p in record["physics"]] == list(range(record["samples"]))
    noise = record["depth_noise_m"]
    assert len(noise) == record["samples"]
    assert all(0 <= n <= SETTINGS.depth_noise_m for n in noise) and len(set(noise)) == len(noise)


def test_a_crop_sees_the_depth_with_the_noise_drawn_for_its_pick():
    from tangle_drake.tangle_data.physical import noisy_depth
    from tangle_drake.tangle_data.seeds import depth_noise_rng

    depth = np.full((480, 640), 0.5, np.float32)
    noisy = noisy_depth(depth, 0.0004, depth_noise_rng(0, 1, 2))
    assert noisy.dtype == depth.dtype and noisy.shape == depth.shape
    assert (noisy - depth).std() == pytest.approx(0.0004, rel=0.02)
    assert abs((noisy - depth).mean()) < 1e-5
    assert np.array_equal(noisy, noisy_depth(depth, 0.0004, depth_noise_rng(0, 1, 2)))
    assert not np.array_equal(noisy, noisy_depth(depth, 0.0004, depth_noise_rng(0, 1, 3)))
    assert noisy_depth(depth, 0.0, depth_noise_rng(0, 1, 2)) is depth


def test_the_grasp_error_moves_the_executed_pose_not_what_the_method_saw():
    pose = np.eye(4)
    pose[:3, 3] = (0.3, 0.2, 0.95)
    moved = offset_pose(pose, (0.002, -0.001, 90.0))
    assert np.allclose(moved[:3, 3], (0.302, 0.199, 0.95))
    assert np.allclose(moved[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    assert np.array_equal(offset_pose(pose, (0.0, 0.0, 0.0)), pose)
    candidate = GraspCandidate(u=10.0, v=20.0, angle_deg=30.0, width_m=0.03, depth_m=0.5,
                               score=0.9, pose=pose)
    switch = GraspSelector([])
    context = switch.CreateDefaultContext()
    switch.GetInputPort("candidates").FixValue(context, [candidate])
    switch.GetInputPort("method").FixValue(context, MethodRun("graspability", 0, 0,
                                                              (0.002, -0.001, 90.0)))
    (scored,) = switch.GetOutputPort("scored_candidates").Eval(context)
    assert np.allclose(scored.candidate.pose, moved)
    assert (scored.candidate.u, scored.candidate.v, scored.candidate.angle_deg) == (10, 20, 30)
    assert np.allclose(switch.GetOutputPort("selected_grasp").Eval(context).pose, moved)


def test_the_contact_scaler_scales_friction_everywhere_and_the_pads_stiffness():
    from tangle_drake.scenario.files import resolve_scenario
    from tangle_drake.station import build_station

    station = build_station(resolve_scenario("floating_gripper.yaml"))
    scaler = ContactScaler(station.plant, station.scene_graph)
    context = station.CreateDefaultContext()
    scaler.apply(context, friction=0.8, pad_stiffness=1.5)
    inspector = station.scene_graph.get_query_output_port().Eval(
        station.scene_graph.GetMyContextFromRoot(context)).inspector()
    pads = 0
    for geometry, model in scaler.original.items():
        now = inspector.GetProximityProperties(geometry)
        assert now.GetProperty("material", "coulomb_friction").dynamic_friction() == \
            pytest.approx(0.8 * model.GetProperty("material", "coulomb_friction")
                          .dynamic_friction())
        if model.HasProperty("hydroelastic", "hydroelastic_modulus"):
            pads += 1
            assert now.GetProperty("hydroelastic", "hydroelastic_modulus") == pytest.approx(
                1.5 * model.GetProperty("hydroelastic", "hydroelastic_modulus"))
    assert pads == 2  # the two finger pads are the only compliant geometries
