"""``tangle-drake pick-ceiling``: the top-k oracle of physical-pick data, and how much of its
gap a model's rule closes, scored on recorded picks with no benchmark run."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.tangle_cnn.objectives import OBJECTIVES

if TYPE_CHECKING:
    from tangle_drake.tangle_data.ceiling import RuleChoice


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "pick-ceiling", help="how far re-ranking graspability's candidates can go on pick data",
        description="For each dataset of `tangle-drake collect --label pick` (one per part), "
                    "print the first-pick success of graspability alone, of the oracle that "
                    "picks the best of each pile's candidates, their gap, and each rank's "
                    "success rate. With --model, also what each model's rule would have picked "
                    "first on the same piles, paired against graspability, and how much of the "
                    "gap it closes: a measure of a model's ranking that needs no benchmark run "
                    "(use piles of another seed than its training data's).")
    parser.add_argument("data", nargs="+", type=Path, help="physical-pick dataset directories")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--model", nargs="+", default=[], metavar="MODEL",
                        help="checkpoints, or the names of shipped models' objectives "
                             f"({', '.join(OBJECTIVES)}: trained/<part>[.objective].pt, the "
                             "dataset's part's), whose rules' first picks to score")
    parser.add_argument("--rule", help="the rule the models pick with (default: each "
                                       "model's own, as bench's model:PATH)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.common.paths import shown_path
    from tangle_drake.dataset import load_samples, read_manifest
    from tangle_drake.tangle_data.ceiling import pick_ceiling

    rows = {}
    choices: list[tuple[str, str, RuleChoice]] = []
    print("| part | piles | graspability [95 % CI] | top-k oracle [95 % CI] | gap | by rank |")
    print("|---|---|---|---|---|---|")
    for directory in args.data:
        try:
            manifest = read_manifest(directory)
            if manifest.get("label") != "pick":
                raise TangleDrakeError(f"{directory} is not physical-pick data (collect "
                                       "--label pick)")
            part = manifest.get("part", directory.name)
            samples = load_samples(directory, ("task", "rank", "outcome") + (
                ("score", "crop", "depth_m") if args.model else ()))
            ceiling = pick_ceiling(samples)
            for model in args.model:
                choices.append((part, model, _choice(samples, manifest, directory, part, model,
                                                     args.rule)))
        except ValueError as error:  # a damaged dataset's arrays
            raise TangleDrakeError(f"{directory}: {error}") from error
        rows[part] = asdict(ceiling) | {"models": {shown_path(model): asdict(choice)
                                                   for p, model, choice in choices if p == part}}
        ranks = ", ".join(f"{r}: {100 * s:.0f} %" for r, (s, _) in ceiling.by_rank.items())
        print(f"| {part} | {ceiling.piles} | "
              f"{rate(ceiling.graspability, ceiling.graspability_interval)} | "
              f"{rate(ceiling.oracle, ceiling.oracle_interval)} | "
              f"{100 * ceiling.gap:+.1f} | {ranks} |")
    if choices:
        print("\n| part | model | rule | its first pick [95 % CI] | minus graspability [95 % CI] "
              "| McNemar p | gap closed |")
        print("|---|---|---|---|---|---|---|")
    for part, model, choice in choices:
        paired = choice.against_graspability
        closed = "-" if choice.closed is None else f"{100 * choice.closed:.0f} %"
        print(f"| {part} | {model} | {choice.rule} | {rate(choice.success, choice.interval)} | "
              f"{100 * paired.difference:+.1f} [{100 * paired.lower:+.1f}, "
              f"{100 * paired.upper:+.1f}] | {paired.p_value:.3g} | {closed} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


def rate(value: float, interval: tuple[float, float]) -> str:
    return f"{100 * value:.1f} % [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"


def _choice(samples: dict, manifest: dict, directory: Path, part: str, model: str,
            rule: str | None) -> RuleChoice:
    """``model``'s (a checkpoint, or a shipped objective's name) rule's first picks on the
    samples of ``directory``."""
    from tangle_drake.selection.choice import trained_model_path
    from tangle_drake.selection.rules import EMAP_RULES, MODEL_RULES
    from tangle_drake.tangle_cnn.evaluate import check_crop  # imports torch
    from tangle_drake.tangle_cnn.model import load_tangle_model
    from tangle_drake.tangle_cnn.objectives import DEFAULT_RULES, check_serves
    from tangle_drake.tangle_cnn.training_data import crop_spec
    from tangle_drake.tangle_data.ceiling import rule_choice

    path = trained_model_path(part, model) if model in OBJECTIVES else Path(model)
    tangle_model = load_tangle_model(path)
    rule = rule or DEFAULT_RULES[tangle_model.objective.name]
    if rule not in MODEL_RULES or rule in EMAP_RULES:
        raise TangleDrakeError(f"--rule {rule!r}: choose a rule that ranks by a model alone "
                               f"({', '.join(r for r in MODEL_RULES if r not in EMAP_RULES)})")
    check_serves(rule, tangle_model.objective, path)
    check_crop(tangle_model.crop, crop_spec(manifest, samples["crop"].shape[1], directory),
               directory)
    return rule_choice(samples, rule, tangle_model.predict(samples["crop"], samples["depth_m"]))

