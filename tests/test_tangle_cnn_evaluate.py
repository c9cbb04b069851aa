"""Scoring a trained tangle CNN on a dataset: fresh piles are all scored, the model's own
training data only on its validation piles (reproducing the checkpoint's figure), the figures
by cause of the label add up, and mismatched or unusable inputs are named clearly."""

import json
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import load_samples, write_shard
from tangle_drake.tangle_cnn.evaluate import evaluate_model
from tangle_drake.tangle_cnn.metrics import FEW_PER_CLASS, balanced_accuracy, few_samples_warning
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.synthetic import write_synthetic_dataset
from tangle_drake.tangle_cnn.train import TrainSettings, train

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def trained(tmp_path_factory, one_torch_thread) -> tuple[Path, Path]:
    """(training data, checkpoint) of a model of the crossing-bars task."""
    root = tmp_path_factory.mktemp("evaluate")
    write_synthetic_dataset(root / "train", 160, size_px=32, size_m=0.05, seed=1)
    model = root / "bars.pt"
    train(root / "train", model, TrainSettings(epochs=3, seed=2), device="cpu",
          log=lambda line: None)
    return root / "train", model


def with_causes(directory: Path, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Add the collector's cause fields to every shard of ``directory`` (random, but consistent
    with each label); returns them for the whole dataset, in load order."""
    for shard in sorted(directory.glob("shard_*.npz")):
        with np.load(shard) as data:
            arrays = dict(data)
        n, tangled = len(arrays["label"]), arrays["label"] == 1
        arrays["num_in_region"] = np.where(tangled & (rng.random(n) < 0.3), 2, 1)
        arrays["num_hanging"] = np.where(tangled & (rng.random(n) < 0.5), 1, 0)
        arrays["num_riding"] = np.where(tangled & (rng.random(n) < 0.5), 1, 0)
        arrays["max_rise_m"] = np.where(tangled, 0.08, rng.choice([0.002, 0.02], n))
        write_shard(directory, int(shard.stem.split("_")[1]), arrays)
    return load_samples(directory, ("label", "num_in_region", "num_hanging", "num_riding",
                                    "max_rise_m"))


run_evaluate = partial(run_command, "evaluate")


def test_fresh_piles_are_all_scored(trained, tmp_path):
    _, model_path = trained
    write_synthetic_dataset(tmp_path, 96, size_px=32, size_m=0.05, seed=7)
    result = evaluate_model(load_tangle_model(model_path), tmp_path)
    assert result.scope == "all samples"
    assert (result.samples, result.tangled, result.piles) == (96, 48, 12)
    assert result.accuracy > 0.9 and result.auc > 0.95
    low, high = result.accuracy_interval
    assert low < result.accuracy < high or result.accuracy == high == 1.0
    assert result.groups == ()  # the synthetic data records no causes


def test_the_models_own_data_is_scored_on_its_validation_piles_only(trained):
    data, model_path = trained
    model = load_tangle_model(model_path)
    result = evaluate_model(model, data)
    assert result.scope.startswith("the model's validation piles")
    assert result.samples == model.info["data"]["validation_samples"] < 160
    assert result.accuracy == pytest.approx(model.info["metrics"]["val_accuracy"])


def test_figures_by_cause_partition_the_samples(trained, tmp_path):
    _, model_path = trained
    write_synthetic_dataset(tmp_path, 96, size_px=32, size_m=0.05, seed=8)
    causes = with_causes(tmp_path, np.random.default_rng(0))
    result = evaluate_model(load_tangle_model(model_path), tmp_path)
    groups = {group.name: group for group in result.groups}
    assert sum(group.samples for group in result.groups) == 96
    assert sum(group.correct for group in result.groups) == round(result.accuracy * 96)
    tangled = causes["label"] == 1
    region = causes["num_in_region"] >= 2
    assert groups["tangled: two parts in the closing region"].samples == (tangled & region).sum()
    assert groups["tangled: a part hangs from the target"].samples == \
        (tangled & ~region & (causes["num_hanging"] > 0)).sum()
    disturbed = groups["not tangled: another part rose 1 cm or more, under the threshold"]
    assert disturbed.samples == (~tangled & (causes["max_rise_m"] > 0.01)).sum() > 0


def test_few_samples_of_a_class_are_warned_of():
    assert few_samples_warning(FEW_PER_CLASS, FEW_PER_CLASS, "split") is None
    assert "only 3 tangled and 500 not tangled" in few_samples_warning(3, 500, "split")
    assert "only 3 failure and 500 success" in few_samples_warning(
        3, 500, "split", ("success", "failure"))
    assert "only 3 other than one part and 500 one part" in few_samples_warning(
        3, 500, "split", ("one part", "several parts", "no part"))
    assert few_samples_warning(500, FEW_PER_CLASS - 1, "split") is not None


def test_balanced_accuracy_weighs_the_classes_equally():
    labels = np.array([1, 0, 0, 0, 0])
    assert balanced_accuracy(labels, np.array([0.9, 0.1, 0.1, 0.1, 0.9])) == pytest.approx(
        (1 + 0.75) / 2)
    assert balanced_accuracy(labels, np.zeros(5)) == pytest.approx(0.5)  # accuracy 0.8
    assert balanced_accuracy(np.zeros(3), np.zeros(3)) is None


def test_cli_prints_and_writes_the_figures(trained, tmp_path, capsys):
    _, model_path = trained
    write_synthetic_dataset(tmp_path / "test", 48, size_px=32, size_m=0.05, seed=9)
    out = tmp_path / "new" / "figures.json"  # folders are made
    assert run_evaluate("--data", str(tmp_path / "test"), "--model", str(model_path),
                        "--json", str(out)) == 0
    captured = capsys.readouterr()
    assert "48 samples, 24 tangled" in captured.out and "ROC-AUC" in captured.out
    assert "only 24 tangled and 24 not tangled samples" in captured.err  # too few to trust
    figures = json.loads(out.read_text())
    assert figures["samples"] == 48 and 0.5 <= figures["accuracy"] <= 1
    (tmp_path / "file").write_text("")
    with pytest.raises(TangleDrakeError, match="cannot write"):
        run_evaluate("--data", str(tmp_path / "test"), "--model", str(model_path),
                     "--json", str(tmp_path / "file" / "figures.json"))


def test_unusable_inputs_are_named(trained, tmp_path):
    _, model_path = trained
    write_synthetic_dataset(tmp_path / "wide", 16, size_px=32, size_m=0.08, seed=3)
    with pytest.raises(TangleDrakeError, match=r"0\.08 m crops at 32 px.*0\.05 m at 32 px"):
        evaluate_model(load_tangle_model(model_path), tmp_path / "wide")
    with pytest.raises(TangleDrakeError, match="no shipped model for part 'synthetic_bars'"):
        run_evaluate("--data", str(tmp_path / "wide"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(TangleDrakeError):
        run_evaluate("--data", str(tmp_path / "empty"), "--model", str(model_path))
    with pytest.raises(TangleDrakeError, match="checkpoint not found"):
        run_evaluate("--data", str(tmp_path / "wide"), "--model", str(tmp_path / "nope.pt"))
    write_synthetic_dataset(tmp_path / "holes", 16, size_px=32, size_m=0.05, seed=4)
    shard = sorted((tmp_path / "holes").glob("shard_*.npz"))[0]
    with np.load(shard) as data:
        arrays = dict(data)
    arrays["crop"][0, 5, 5] = np.nan
    write_shard(tmp_path / "holes", int(shard.stem.split("_")[1]), arrays)
    with pytest.raises(TangleDrakeError, match="holes: crops and depths must be finite"):
        evaluate_model(load_tangle_model(model_path), tmp_path / "holes")
