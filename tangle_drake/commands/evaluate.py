"""``tangle-drake evaluate``: a trained tangle CNN's figures on a labelled dataset."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tangle_drake.tangle_cnn.objectives import objective_named


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "evaluate", help="score a trained tangle CNN on a dataset from `tangle-drake collect`",
        description="Score a tangle CNN on every sample of a dataset: accuracy (with its 95 % "
                    "interval), balanced accuracy, precision and recall of tangled, ROC-AUC, "
                    "and the accuracy by how each label came about (two parts in the closing "
                    "region, a part hanging or riding, a neighbour disturbed but not lifted). "
                    "Collect the data with another --seed than the model's for a test on "
                    "piles it never saw; on the model's own training data only its validation "
                    "piles are scored.")
    parser.add_argument("--data", type=Path, required=True, help="dataset directory")
    parser.add_argument("--model", type=Path, default=None,
                        help="checkpoint (default: the shipped model of the dataset's part, "
                             "tangle_drake/trained/<part>.pt)")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures here")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from tangle_drake.common.errors import TangleDrakeError
    from tangle_drake.dataset import read_manifest
    from tangle_drake.selection.choice import resolve_tangle_choice, trained_model_path
    from tangle_drake.tangle_cnn.evaluate import evaluate_model
    from tangle_drake.tangle_cnn.metrics import few_samples_warning
    from tangle_drake.tangle_cnn.model import load_tangle_model

    model_path = args.model
    if model_path is None:
        part = read_manifest(args.data).get("part")
        if not part:
            raise TangleDrakeError(f"dataset {args.data} names no part; pass --model")
        model_path = resolve_tangle_choice(part).model
        if model_path is None:
            raise TangleDrakeError(f"no shipped model for part {part!r} "
                                   f"({trained_model_path(part)}); pass --model")
    model = load_tangle_model(model_path)
    with tqdm(desc="scoring", unit="sample", disable=None, leave=False) as bar:
        result = evaluate_model(model, args.data, progress=bar.update)
    if result.model_part and result.data_part and result.model_part != result.data_part:
        print(f"note: the model was trained on {result.model_part}, the data is of "
              f"{result.data_part}", file=sys.stderr)
    print(_report(result, model_path))
    if warning := few_samples_warning(result.tangled, result.samples - result.tangled,
                                      f"the scored part of {args.data}",
                                      model.objective.classes):
        print(warning, file=sys.stderr)
    if args.json is not None:
        try:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(result.to_dict(), indent=1))
        except OSError as error:
            raise TangleDrakeError(f"cannot write {args.json}: {error}") from None
        print(f"wrote {args.json}")
    return 0


def _report(result, model_path: Path) -> str:
    def share(value: float | None) -> str:
        return "n/a" if value is None else f"{100 * value:.1f} %"

    low, high = result.accuracy_interval
    bad = objective_named(result.objective).failure
    lines = [
        f"{model_path} on {result.data} ({result.scope}): {result.samples} samples, "
        f"{result.tangled} {bad}, {result.piles} piles"
        + ("; probabilities at the training data's class shares" if result.prior_corrected
           else ""),
        f"accuracy {share(result.accuracy)} [{100 * low:.1f}, {100 * high:.1f}]  "
        f"balanced accuracy {share(result.balanced_accuracy)}  "
        f"precision {share(result.precision)}  recall {share(result.recall)}  "
        f"ROC-AUC {'n/a' if result.auc is None else f'{result.auc:.3f}'}",
    ]
    if result.class_accuracy is not None:
        recalls = ", ".join(f"{name} {share(value)}" for name, value in
                            zip(result.classes, result.class_recall, strict=True))
        lines.append(f"most probable class right {share(result.class_accuracy)}; recall: "
                     f"{recalls}")
    if result.calibration:
        lines.append(f"calibration of P({result.classes[0]}): " + ", ".join(
            f"{b.low:.1f}-{b.high:.1f}: {b.observed:.2f} of {b.samples}"
            for b in result.calibration))
    if result.groups:
        width = max(len(group.name) for group in result.groups)
        lines.append(f"{'label came about as':{width}}  samples  right   mean P({bad})")
        for group in result.groups:
            right = share(group.correct / group.samples) if group.samples else "n/a"
            mean = "n/a" if group.mean_p_tangled is None else f"{group.mean_p_tangled:.2f}"
            lines.append(f"{group.name:{width}}  {group.samples:7d}  {right:>7}  {mean:>6}")
    return "\n".join(lines)
