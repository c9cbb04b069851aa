"""The seed's second baseline: a success/failure CNN learns P(success) from physical picks'
outcomes, names its objective, ranks with ``success-cnn``, and is refused, with a clear error,
by the rules that read P(not tangled) (and a tangle CNN by ``success-cnn``)."""

import json
import shutil
import subprocess
import sys
from functools import partial
from pathlib import Path

import numpy as np
import pytest
import torch
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.dataset import load_samples
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.selection.choice import resolve_tangle_choice
from tangle_drake.selection.cnn_system import TangleCnnSystem
from tangle_drake.selection.methods import parse_method
from tangle_drake.tangle_cnn.card import classes_test_header, classes_test_row, validation_row
from tangle_drake.tangle_cnn.checkpoint import read_checkpoint
from tangle_drake.tangle_cnn.evaluate import calibration_error, evaluate_model
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.objectives import OUTCOME, SUCCESS
from tangle_drake.tangle_cnn.synthetic import (
    FLOOR_M,
    GRASP_DEPTH_M,
    synthetic_crop,
    write_synthetic_dataset,
)
from tangle_drake.tangle_cnn.train import TrainSettings, train
from tangle_drake.tangle_cnn.training_data import load_checked_samples

pytestmark = pytest.mark.usefixtures("one_torch_thread")
INTRINSICS = CameraIntrinsics(64, 48, 50.0, 50.0, 32.0, 24.0)
run_train = partial(run_command, "train")
TOOLS = Path(__file__).parents[1] / "tools"


@pytest.fixture(scope="module")
def picks(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("picks")
    write_synthetic_dataset(directory, 256, seed=3, outcomes=True)
    return directory


@pytest.fixture(scope="module")
def lifts(tmp_path_factory) -> Path:
    directory = tmp_path_factory.mktemp("lifts")
    write_synthetic_dataset(directory, 64, seed=4)
    return directory


@pytest.fixture(scope="module")
def models(picks, lifts, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("models")
    paths = {"success": out / "bars.success.pt", "tangled": out / "bars.pt",
             "outcome": out / "bars.outcome.pt"}
    train(picks, paths["success"], TrainSettings(epochs=4, seed=2, objective="success"),
          device="cpu", log=lambda line: None)
    train(picks, paths["outcome"], TrainSettings(epochs=4, seed=2, objective="outcome"),
          device="cpu", log=lambda line: None)
    train(lifts, paths["tangled"], TrainSettings(epochs=1, seed=2), device="cpu",
          log=lambda line: None)
    return paths


def test_labels_come_from_the_outcome_with_empty_grasps_as_failures(picks):
    samples, _, _ = load_checked_samples(picks, objective=SUCCESS)
    outcome = samples["outcome"]
    assert set(np.unique(outcome)) == {0, 1, 2}  # the empty grasps are kept
    assert (samples["label"] == (outcome != 1)).all()  # failure: several or none
    tangle_labelled, _, _ = load_checked_samples(picks)
    assert len(tangle_labelled["label"]) < len(outcome)  # the tangle CNN drops the empties


def test_the_success_cnn_learns_p_success_and_says_so(models):
    model = load_tangle_model(models["success"])
    assert model.objective is SUCCESS
    assert read_checkpoint(models["success"])["objective"] == "success"
    rng = np.random.default_rng(7)
    crossing = np.arange(60) % 2 == 1  # several parts came up
    crops = np.stack([synthetic_crop(bool(c), 32, rng) for c in crossing])
    p_success = model.predict(crops, np.full(60, GRASP_DEPTH_M))
    assert ((p_success > 0.5) == ~crossing).mean() > 0.9


def test_the_outcome_model_tells_one_part_from_a_tangle_from_an_empty_grasp(models):
    model = load_tangle_model(models["outcome"])
    assert model.objective is OUTCOME and model.network.config.classes == 3
    rng = np.random.default_rng(8)
    truth = np.arange(90) % 3  # 0 one part, 1 several, 2 none
    crops = np.stack([synthetic_crop(k == 1, 32, rng) if k < 2 else
                      np.full((32, 32), FLOOR_M, np.float32) + rng.normal(0, 5e-4, (32, 32))
                      for k in truth]).astype(np.float32)
    probabilities = model.probabilities(crops, np.full(90, GRASP_DEPTH_M))
    assert probabilities.shape == (90, 3)
    assert np.allclose(probabilities.sum(axis=1), 1, atol=1e-5)
    assert (probabilities.argmax(axis=1) == truth).mean() > 0.85
    assert np.array_equal(model.predict(crops, np.full(90, GRASP_DEPTH_M)),
                          probabilities[:, 0])  # P(one part) is what the rules read
    # Its record and card count the picks that did not bring up one part (several or none).
    data = read_checkpoint(models["outcome"])["data"]
    assert data["tangled"] == data["samples"] - data["class_counts"]["one part"]
    assert data["class_counts"]["no part"] > 0
    share = float(validation_row(models["outcome"]).strip("|").split("|")[2])
    assert share == pytest.approx(100 * data["tangled"] / data["samples"], abs=0.05)


def test_a_pick_model_gives_its_data_s_rates_where_a_crop_tells_it_nothing(models, picks):
    """Trained on balanced classes, a network that cannot tell says 1/classes; a pick model's
    probabilities are moved back to the shares of outcomes in its data (the priors), a
    tangle CNN's are not (the paper's balanced output)."""
    samples, _, _ = load_checked_samples(picks, objective=OUTCOME)
    shares = np.bincount(samples["label"].astype(int), minlength=3) / len(samples["label"])
    assert abs(shares[0] - 1 / 3) > 0.05  # the data are not balanced
    crops = np.stack([synthetic_crop(False, 32, np.random.default_rng(k)) for k in range(4)])
    depths = np.full(4, GRASP_DEPTH_M)
    for name, expected in (("outcome", shares), ("success", [shares[0], 1 - shares[0]]),
                           ("tangled", [0.5, 0.5])):
        model = load_tangle_model(models[name])
        with torch.no_grad():
            last = model.network.classifier[-1]
            last.weight.zero_()  # the crop no longer matters
            last.bias.zero_()
        assert np.allclose(model.probabilities(crops, depths), expected, atol=1e-6)
        balanced = model.probabilities(crops, depths, balanced=True)
        assert np.allclose(balanced, 1 / len(expected), atol=1e-6)


def test_evaluation_breaks_a_success_model_down_by_outcome(models, picks, tmp_path):
    result = evaluate_model(load_tangle_model(models["success"]), picks)
    assert result.objective == "success" and result.classes == ("success", "failure")
    by_name = {group.name.split(":")[1].strip(): group for group in result.groups}
    assert set(by_name) == {"several parts came up", "no part came up",
                            "exactly one part came up"}
    assert sum(group.samples for group in result.groups) == result.samples
    assert result.accuracy > 0.8
    assert sum(b.samples for b in result.calibration) == result.samples
    assert result.class_accuracy is None  # two classes
    three = evaluate_model(load_tangle_model(models["outcome"]), picks)
    assert three.classes == ("one part", "several parts", "no part")
    assert three.class_accuracy > 0.8 and len(three.class_recall) == 3
    # Its own data: the validation piles, every sample (its loss was weighted by class, not
    # undersampled), so the prior correction applies.
    assert three.scope == "the model's validation piles (this is its training data)"
    assert three.samples == read_checkpoint(models["outcome"])["data"]["validation_samples"]
    assert three.prior_corrected and sum(three.class_samples) == three.samples
    info = read_checkpoint(models["outcome"])
    assert info["training"]["balance"] == "weight"
    assert three.accuracy == pytest.approx(info["metrics"]["val_accuracy"])  # scored alike
    assert info["data"]["train_samples"] + info["data"]["validation_samples"] == 256
    fresh = tmp_path / "fresh"
    write_synthetic_dataset(fresh, 60, seed=4, outcomes=True)
    three = evaluate_model(load_tangle_model(models["outcome"]), fresh)
    outcomes = load_samples(fresh, ("outcome",))["outcome"]
    assert three.class_samples == [int((outcomes == code).sum()) for code in (1, 2, 0)]
    # The card's row: the classes' shares, recalls and the calibration error, from the figures.
    error = calibration_error(three.calibration)
    assert 0 <= error < 0.5
    row = classes_test_row("u_hook", three.to_dict()).strip("|").split("|")
    shares = [float(x) for x in row[2].split("/")]
    assert np.allclose(shares, [100 * n / three.samples for n in three.class_samples], atol=0.05)
    assert float(row[-1]) == pytest.approx(100 * error, abs=0.05)
    assert len(classes_test_header(three.classes).splitlines()[0].split("|")) == len(row) + 2


def test_each_model_serves_its_rules_and_is_refused_by_the_others(models):
    success, tangled = models["success"], models["tangled"]
    TangleCnnSystem(success, INTRINSICS, "success-cnn", warm_up=0)
    for rule in ("success-cnn", "success-harmonic"):
        TangleCnnSystem(models["outcome"], INTRINSICS, rule, warm_up=0)
    with pytest.raises(TangleDrakeError, match="--objective success or outcome"):
        TangleCnnSystem(tangled, INTRINSICS, "success-harmonic", warm_up=0)
    TangleCnnSystem(tangled, INTRINSICS, "harmonic", warm_up=0)
    for rule in ("harmonic", "cnn"):
        with pytest.raises(TangleDrakeError,
                           match=rf"the {rule} rule needs a model of P\(not tangled\).*"
                                 r"success-cnn or success-harmonic rule"):
            TangleCnnSystem(success, INTRINSICS, rule, warm_up=0)
    with pytest.raises(TangleDrakeError, match=r"needs a model of P\(success\)"):
        TangleCnnSystem(tangled, INTRINSICS, "success-cnn", warm_up=0)
    # A checkpoint given by path picks with the rule of its objective.
    assert parse_method(f"model:{success}").rule == "success-cnn"
    assert parse_method(f"model:{tangled}").rule == "harmonic"
    assert parse_method(f"model:{models['outcome']}").rule == "success-harmonic"
    assert resolve_tangle_choice("u_hook", model=success).rule == "success-cnn"
    # RULE:PATH names the rule: an outcome model's P(one part) alone, or a refusal.
    alone = parse_method(f"success-cnn:{models['outcome']}")
    assert (alone.rule, alone.model) == ("success-cnn", Path(models["outcome"]).resolve())
    assert alone.name != parse_method("success-cnn").name
    with pytest.raises(TangleDrakeError, match=r"the harmonic rule needs a model of P\(not"):
        parse_method(f"harmonic:{models['outcome']}")
    with pytest.raises(TangleDrakeError, match="model file not found"):
        parse_method(f"success-cnn:{models['outcome']}.missing")
    with pytest.raises(TangleDrakeError, match="unknown method 'random:"):
        parse_method(f"random:{models['outcome']}")


def test_a_weighted_validation_is_scored_at_its_data_s_class_shares():
    """Kept at the data's shares (80 % one part), the validation is scored as the model will
    be used: a network that cannot tell then calls every pick one part, right 80 % of the
    time, where its balanced output (1/3 each) would call every pick a failure."""
    from tangle_drake.tangle_cnn.train import validation_figures

    labels = np.array([0] * 8 + [1, 2])
    uniform = np.full((10, 3), 1 / 3, dtype=np.float32)
    shares = torch.tensor([0.8, 0.1, 0.1])
    assert validation_figures(labels, uniform, shares)["accuracy"] == pytest.approx(0.8)
    assert validation_figures(labels, uniform, None)["accuracy"] == pytest.approx(0.2)


def test_a_success_cnn_needs_outcomes_in_its_data(lifts, tmp_path):
    with pytest.raises(TangleDrakeError, match=r"no .outcome. field.*collect --label pick"):
        run_train("--data", str(lifts), "--out", str(tmp_path / "m.pt"), "--objective",
                  "success", "--epochs", "1")


def test_bench_warns_when_a_model_was_trained_on_the_piles_it_tests(tmp_path):
    from tangle_drake.bench.runner import BenchOptions, plan
    from tangle_drake.bench.trials import pile_seed
    from tangle_drake.dataset import write_manifest, write_shard
    from tangle_drake.tangle_cnn.synthetic import synthetic_samples

    data = tmp_path / "data"
    data.mkdir()
    samples = synthetic_samples(48, 32, seed=5)
    samples["pile_seed"][:8] = pile_seed(0, "u_hook", 1)  # one pile is the bench's trial 1
    for task in np.unique(samples["task"]):
        rows = samples["task"] == task
        write_shard(data, int(task), {name: array[rows] for name, array in samples.items()})
    write_manifest(data, {"part": "u_hook", "crop": {"size_m": 0.05, "size_px": 32}})
    model = tmp_path / "u_hook.pt"
    train(data, model, TrainSettings(epochs=1), device="cpu", log=lambda line: None)

    def notices(trials: int) -> list[str]:
        _, _, found = plan(BenchOptions(methods=[f"model:{model}"], parts=["u_hook"],
                                        trials=trials))
        return [n for n in found if "was trained on" in n]

    assert notices(1) == []  # trial 0's pile is not among its training piles
    shown = shown_path(model)
    assert notices(3) == [f"warning: {shown} was trained on 1 of the 3 u_hook piles this run "
                          f"tests model:{shown} on: its figures there are not a test; collect "
                          "its data with another --seed"]


def test_pick_ceiling_scores_a_models_first_picks_on_pick_data(models, picks, tmp_path):
    """``tangle-drake pick-ceiling --model``: the success CNN, which tells the synthetic piles'
    picks apart, closes graspability's gap to the oracle (graspability's scores are noise
    there); a model the rule cannot serve is refused with the reason."""
    from tangle_drake.dataset import read_manifest, write_manifest

    data = tmp_path / "picks"
    shutil.copytree(picks, data)
    write_manifest(data, {**read_manifest(data), "label": "pick"})
    command = [sys.executable, "-m", "tangle_drake.cli", "pick-ceiling", str(data), "--model"]
    figures = tmp_path / "ceiling.json"
    done = subprocess.run([*command, str(models["success"]), "--json", str(figures)],
                          capture_output=True, text=True, check=True)
    row = json.loads(figures.read_text())["synthetic_bars"]
    choice = row["models"][shown_path(models["success"])]  # as results record paths
    assert choice["rule"] == "success-cnn" and "| success-cnn |" in done.stdout
    assert row["graspability"] < choice["success"] == pytest.approx(row["oracle"])
    assert choice["closed"] == pytest.approx(1.0)
    refused = subprocess.run([*command, str(models["tangled"]), "--rule", "success-cnn"],
                             capture_output=True, text=True)
    assert refused.returncode == 2 and "needs a model of P(success)" in refused.stderr
    refused = subprocess.run([*command, str(models["success"]), "--rule", "random"],
                             capture_output=True, text=True)
    assert refused.returncode == 2 and "--rule 'random': choose a rule" in refused.stderr


def test_the_learning_curve_tool_trains_pick_models_on_prefixes_and_scores_them(
        models, picks, tmp_path):
    """``tools/learning_curve.py --objective success``: a success CNN per prefix of the pick
    data, each scored on fresh piles' picks by P(not one part); a comparison model of another
    objective is refused before any training."""
    test = tmp_path / "test_picks"
    write_synthetic_dataset(test, 64, seed=5, outcomes=True)
    tool = TOOLS / "learning_curve.py"
    command = [sys.executable, str(tool), "--objective", "success", "--data", str(picks),
               "--test", str(test), "--sizes", "64", "--out", str(tmp_path / "curve")]
    refused = subprocess.run([*command, "--against", str(models["tangled"])],
                             capture_output=True, text=True)
    assert refused.returncode == 1 and "is a tangled model" in refused.stderr
    assert not (tmp_path / "curve").exists()
    done = subprocess.run([*command, "--against", str(models["success"])],
                          capture_output=True, text=True, check=True)
    curve = json.loads((tmp_path / "curve" / "curve.json").read_text())
    assert curve["objective"] == "success" and curve["test_samples"] == 64
    assert [point["samples"] for point in curve["points"]] == [64, 256]
    assert curve["points"][-1]["auc"] > 0.9, done.stdout  # the bars tell the outcomes apart
    assert curve["points"][-1]["auc_difference"] == 0.0
    assert "| 64 |" in done.stdout and "| 256 |" in done.stdout
