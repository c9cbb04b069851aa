"""How many samples does a model need (a tangle CNN's auto-lift labels, a pick model's
physical picks)? Train on growing prefixes of one dataset and score every model on the same
fresh test piles.

    python tools/learning_curve.py --data data/u_hook --test data/u_hook_test \
        --sizes 1000 2000 3000 --out results/curve_u_hook
    python tools/learning_curve.py --objective success --data data/u_hook_pick \
        --test data/u_hook_pick_test --sizes 250 500 750 --out results/curve_u_hook_success

For each size N the first piles of ``--data`` (in task order, as a shorter collection with the
same seed would have made them) up to N samples become a dataset of their own under ``--out``,
trained with the shipped recipe (``train`` at ``--seed`` for ``--objective``, on
``TRAIN_THREADS``); the whole dataset is the last point. Each model is scored on every sample
of ``--test`` labelled for the objective: ROC-AUC and accuracy of its P(not class 0)
(P(tangled); a pick model's P(not exactly one part)), and the paired difference of its ROC-AUC
from the whole dataset's model with a 95 % bootstrap interval over the test piles (the same
samples score both models, so the interval is much narrower than either AUC's own). ``--against
MODEL`` (e.g. the part's shipped model) adds each model's paired difference from that one too.
Training resumes where it stopped; a finished model is not trained again. ``curve.json`` in
``--out`` keeps the figures.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.dataset import MANIFEST, finished_tasks, load_samples, read_shard, shard_name
from tangle_drake.tangle_cnn.evaluate import class_probabilities
from tangle_drake.tangle_cnn.metrics import binary_metrics, roc_auc
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.objectives import DEFAULT_OBJECTIVE, OBJECTIVES, objective_named
from tangle_drake.tangle_cnn.train import TrainSettings, train
from tangle_drake.tangle_cnn.train_settings import TRAIN_THREADS
from tangle_drake.tangle_cnn.training_data import load_checked_samples

BOOTSTRAP_SAMPLES = 2000
BOOTSTRAP_SEED = 0


def prefix_dataset(data: Path, samples: int, out: Path) -> int:
    """``out`` holds the first tasks of ``data`` up to ``samples`` samples (hard links, or
    copies across file systems); the samples it holds."""
    out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(data / MANIFEST, out / MANIFEST)
    held = 0
    for task in sorted(finished_tasks(data)):
        if held >= samples:
            break
        for name in (shard_name(task), Path(shard_name(task)).with_suffix(".json").name):
            source, target = data / name, out / name
            if source.exists() and not target.exists():
                try:
                    target.hardlink_to(source)
                except OSError:
                    shutil.copyfile(source, target)
        held += len(read_shard(data / shard_name(task), ("label",))["label"])
    return held


def p_failure(model_path: Path, samples: dict[str, np.ndarray]) -> np.ndarray:
    """The model's P(not class 0) of every test sample (as ``evaluate`` computes it): P(tangled),
    or a pick model's P(not exactly one part)."""
    probabilities = class_probabilities(load_tangle_model(model_path), samples)
    return (1.0 - probabilities[:, 0].astype(np.float32)).astype(np.float64)


def paired_auc_interval(truth: np.ndarray, piles: np.ndarray, a: np.ndarray,
                        b: np.ndarray) -> list[float]:
    """95 % bootstrap interval of AUC(a) - AUC(b), resampling whole test piles."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    groups = [np.flatnonzero(piles == pile) for pile in np.unique(piles)]
    differences = []
    for _ in range(BOOTSTRAP_SAMPLES):
        rows = np.concatenate([groups[i] for i in rng.integers(len(groups), size=len(groups))])
        first, second = roc_auc(truth[rows], a[rows]), roc_auc(truth[rows], b[rows])
        if first is not None and second is not None:
            differences.append(first - second)
    return [float(np.percentile(differences, 2.5)), float(np.percentile(differences, 97.5))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, required=True, help="the training dataset")
    parser.add_argument("--test", type=Path, required=True, help="test piles of another seed")
    parser.add_argument("--sizes", type=int, nargs="+", required=True,
                        help="samples of each smaller training set")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--seed", type=int, default=0, help="training seed (default 0)")
    parser.add_argument("--objective", choices=sorted(OBJECTIVES), default=DEFAULT_OBJECTIVE,
                        help="what the models learn (train's --objective; default "
                             f"{DEFAULT_OBJECTIVE})")
    parser.add_argument("--against", type=Path, default=None,
                        help="also compare every model with this one (e.g. the shipped model)")
    args = parser.parse_args()
    try:
        check_inputs(args)
        run(args)
    except TangleDrakeError as error:
        sys.exit(f"error: {error}")


def check_inputs(args: argparse.Namespace) -> None:
    """Refuse a missing dataset, or a comparison model of another objective, before any
    training."""
    for option, directory in (("--data", args.data), ("--test", args.test)):
        if not (directory / MANIFEST).is_file():
            raise TangleDrakeError(f"{option} {directory}: no dataset there (no {MANIFEST})")
    if args.against is not None:
        objective = load_tangle_model(args.against).objective.name
        if objective != args.objective:
            raise TangleDrakeError(f"--against {args.against} is a {objective} model; the "
                                   f"curve's models are {args.objective} models")


def run(args: argparse.Namespace) -> None:
    """Train the models of every size (those not trained before) and score them."""
    torch.set_num_threads(TRAIN_THREADS)
    points = []
    for size in [*sorted(args.sizes), None]:
        data = args.data if size is None else args.out / f"data_{size}"
        held = (len(load_samples(data, ("label",))["label"]) if size is None
                else prefix_dataset(args.data, size, data))
        model = args.out / f"model_{'all' if size is None else size}.pt"
        seconds = None  # trained before
        if not model.is_file():
            start = time.perf_counter()
            train(data, model, TrainSettings(seed=args.seed, objective=args.objective),
                  device="cpu", log=lambda line: print(f"  {line}", flush=True))
            seconds = round(time.perf_counter() - start, 1)
        points.append({"samples": held, "model": str(model), "train_s": seconds})
        print(f"trained on {held} samples: {model}", flush=True)
    test, _, _ = load_checked_samples(args.test, objective=objective_named(args.objective))
    truth, piles = (test["label"] != 0).astype(int), test["pile_seed"]
    for point in points:
        point["p_failure"] = p = p_failure(Path(point["model"]), test)
        metrics = binary_metrics(truth, p)
        point["auc"], point["accuracy"] = metrics["auc"], metrics["accuracy"]
    full = points[-1]
    against = None
    if args.against is not None:
        p = p_failure(args.against, test)
        against = {"model": str(args.against), "auc": binary_metrics(truth, p)["auc"],
                   "p_failure": p}
    print(f"test: {len(truth)} samples from {len(np.unique(piles))} piles of {args.test}")
    extra = "" if against is None else f" ROC-AUC - {args.against.name}'s [95 % CI] |"
    print(f"| training samples | ROC-AUC | accuracy | ROC-AUC - whole set's [95 % CI] |{extra} "
          f"training s |\n|---|---|---|---|{'---|' if against else ''}---|")
    for point in points:
        cells = [difference(point, full, "auc_difference", truth, piles)]
        if against is not None:
            cells.append(difference(point, against, "auc_vs_against", truth, piles))
        print(f"| {point['samples']} | {point['auc']:.3f} | {100 * point['accuracy']:.1f} % | "
              + " | ".join(cells) +
              f" | {'–' if point['train_s'] is None else round(point['train_s'])} |")
    for point in points:
        del point["p_failure"]
        point["model"] = shown_path(point["model"])
    if against is not None:
        del against["p_failure"]
        against["model"] = shown_path(against["model"])
    (args.out / "curve.json").write_text(json.dumps(
        {"data": shown_path(args.data), "test": shown_path(args.test),
         "objective": args.objective,
         "test_samples": len(truth),
         "points": points, **({"against": against} if against else {})}, indent=1) + "\n")


def difference(point: dict, other: dict, key: str, truth: np.ndarray,
               piles: np.ndarray) -> str:
    """Record in ``point`` its ROC-AUC minus ``other``'s (``key``) with the paired interval
    (``key`` + ``_ci``); the table cell."""
    interval = paired_auc_interval(truth, piles, point["p_failure"], other["p_failure"])
    point[key], point[f"{key}_ci"] = point["auc"] - other["auc"], interval
    return f"{point[key]:+.3f} [{interval[0]:+.3f}, {interval[1]:+.3f}]"


if __name__ == "__main__":
    main()
