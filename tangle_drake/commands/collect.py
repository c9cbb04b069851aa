"""``tangle-drake collect``: simulate picks on random piles and label them.

``--label lift`` (the default), the paper's data simulator (section III-B): piles of one part
type, graspability candidates, the part in the closing region lifted by a force, labelled
*tangled* if anything else comes up. ``--label pick``, the data of the seed's success/failure
baseline: each of graspability's top candidates picked by the physically simulated gripper
from the same restored pile, labelled by what came up (one part, several, none;
:mod:`tangle_drake.tangle_data.physical`). Resumable (run the same command again), parallel
(``--workers``, ``--ray``).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from tangle_drake.commands.arguments import add_scenario_argument, add_seed_argument, scenario_from
from tangle_drake.common.workers import add_worker_arguments

DEFAULT_SAMPLES = 5100
LABELS = ("lift", "pick")
LIFT_ONLY = ("lifts_per_pile", "lift_height", "rise_threshold", "repeat", "full_depth")
"""Options of the force lift, which physical picks do not have."""


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "collect", help="collect a labelled tangle dataset in simulation (resumable)",
        description="Drop random piles of one part, rank grasp candidates with the "
                    "graspability index, lift the part in each candidate's closing region "
                    "with a force and label the pick tangled if another part comes up (or "
                    "if two parts lie in the closing region). Stops once --out holds at "
                    "least --samples samples; run it again (or with a larger --samples) to "
                    "resume or continue. --label pick instead picks each of the top "
                    "candidates with the physically simulated gripper and labels it by what "
                    "came up: one part, several or none.")
    parser.add_argument("--label", choices=LABELS, default="lift",
                        help="lift: the paper's force lift of the part in the closing region "
                             "(tangled or not; default); pick: a physical pick of each top "
                             "candidate (one part / several / none)")
    parser.add_argument("--part", required=True,
                        help="built-in part (u_hook, s_hook, c_ring, j_hook, e_shape) or a "
                             "mesh file (.obj, .stl, .ply)")
    parser.add_argument("--mesh-scale", type=float, default=1.0, metavar="S",
                        help="metres per mesh unit (0.001 for millimetres; default 1)")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, metavar="N",
                        help=f"stop once the dataset holds this many (default {DEFAULT_SAMPLES})")
    parser.add_argument("--out", type=Path, required=True, help="dataset directory")
    add_seed_argument(parser, 0, help="collection seed (default 0)")
    add_worker_arguments(parser, "tasks")
    parser.add_argument("--parts-per-pile", type=int, default=None, metavar="N",
                        help="parts in each pile (default: per part, about three layers)")
    parser.add_argument("--lifts-per-pile", type=int, default=None, metavar="K",
                        help="candidates labelled per pile, drawn from the top-k (default 5)")
    parser.add_argument("--top-k", type=int, default=None, metavar="K",
                        help="graspability candidates per pile (default 5, as the paper)")
    parser.add_argument("--lift-height", type=float, default=None, metavar="M",
                        help="how far the target is lifted, m (default 0.12)")
    parser.add_argument("--rise-threshold", type=float, default=None, metavar="M",
                        help="another part rising more than this makes the pick tangled, "
                             "m (default 0.03)")
    parser.add_argument("--repeat", type=int, default=1, metavar="K",
                        help="re-run each lift K times under small perturbations and report "
                             "the label agreement (default 1: no re-runs)")
    parser.add_argument("--crop-size", type=float, default=None, metavar="M",
                        help="side of the square depth crop around each grasp, m (default: "
                             "the open hand plus 2 cm a side); resampled to 96 px")
    parser.add_argument("--full-depth", action="store_true",
                        help="also store each sample's whole depth image (~1.2 MB each)")
    parser.add_argument("--no-randomise", dest="randomise", action="store_false",
                        help="--label pick: pick under the model's physics and crop the "
                             "renderer's depth, not under a draw per pick of friction, "
                             "finger-pad stiffness, grasp error and depth noise")
    parser.add_argument("--depth-noise", type=float, default=None, metavar="M",
                        help="--label pick: each pick's crop sees the depth with Gaussian "
                             "noise of a standard deviation drawn in [0, M] per pick, m "
                             "(default 0.0005; 0: the renderer's depth)")
    parser.add_argument("--full-pick", dest="fast", action="store_false",
                        help="--label pick: run every pick to the top of its lift, as the "
                             "benchmark does (default: a grasp that closed on nothing ends "
                             "there, with the same outcome)")
    add_scenario_argument(parser, "the shipped tangle_data.yaml; with --label pick the "
                                  "benchmark's floating_gripper.yaml")
    parser.set_defaults(func=run)


def settings_from_args(args: argparse.Namespace):
    """The collection settings the arguments ask for, defaults filled in."""
    from tangle_drake.parts import load_part
    from tangle_drake.tangle_data.defaults import default_parts_per_pile
    from tangle_drake.tangle_data.settings import CollectSettings
    from tangle_drake.tangle_data.simulator import data_scenario

    settings = CollectSettings(part=args.part, mesh_scale=args.mesh_scale, seed=args.seed,
                               repeat=args.repeat, full_depth=args.full_depth)
    if args.top_k is not None:
        settings = replace(settings, top_k=args.top_k)
    if args.crop_size is not None:
        settings = replace(settings, crop=replace(settings.crop, size_m=args.crop_size))
    if args.lifts_per_pile is not None:
        settings = replace(settings, lifts_per_pile=args.lifts_per_pile)
    if args.lift_height is not None:
        settings = replace(settings, lift=replace(settings.lift, height_m=args.lift_height))
    if args.rise_threshold is not None:
        settings = replace(settings, labels=replace(settings.labels,
                                                    rise_threshold_m=args.rise_threshold))
    scenario_text = _scenario_text(args)
    if args.parts_per_pile is not None:
        settings = replace(settings, parts_per_pile=args.parts_per_pile)
    else:
        scenario = data_scenario(scenario_text, settings)
        part = load_part(args.part, mesh_scale=args.mesh_scale)
        settings = replace(settings, parts_per_pile=default_parts_per_pile(
            args.part, part, scenario.bin))
    return settings, scenario_text


def _scenario_text(args: argparse.Namespace, default: str | None = None) -> str:
    """The scenario's text, checked (a wrong field is named now, with the overlay that names
    it): its files and overlays; no file: the shipped ``default`` (tangle_data.yaml)."""
    from tangle_drake.tangle_data.collect import DATA_SCENARIO

    return scenario_from(args).with_default(default or DATA_SCENARIO).text()


def pick_settings_from_args(args: argparse.Namespace):
    """The physical-pick settings the arguments ask for (``--label pick``)."""
    from tangle_drake.common.errors import TangleDrakeError
    from tangle_drake.tangle_data.physical import PICK_SCENARIO, PickDataSettings

    given = [name for name in LIFT_ONLY if getattr(args, name) not in (None, False, 1)]
    if given:
        raise TangleDrakeError(f"--{given[0].replace('_', '-')} is an option of the force lift "
                               "(--label lift); a physical pick has none")
    settings = PickDataSettings(part=args.part, mesh_scale=args.mesh_scale, seed=args.seed,
                                parts_per_pile=args.parts_per_pile, fast=args.fast)
    if args.depth_noise is not None:
        settings = replace(settings, depth_noise_m=args.depth_noise)
    if not args.randomise:
        if args.depth_noise:
            raise TangleDrakeError("--no-randomise crops the renderer's depth: drop "
                                   "--depth-noise")
        settings = replace(settings, physics=None, depth_noise_m=0.0)
    if args.top_k is not None:
        settings = replace(settings, top_k=args.top_k)
    if args.crop_size is not None:
        settings = replace(settings, crop=replace(settings.crop, size_m=args.crop_size))
    settings.validate()
    return settings, _scenario_text(args, PICK_SCENARIO)


def run(args: argparse.Namespace) -> int:
    if args.label == "pick":
        return run_picks(args)
    pick_only = [flag for flag, given in (("--no-randomise", not args.randomise),
                                          ("--full-pick", not args.fast),
                                          ("--depth-noise", args.depth_noise is not None))
                 if given]
    if pick_only:
        from tangle_drake.common.errors import TangleDrakeError

        flag = pick_only[0]
        raise TangleDrakeError(f"{flag} is an option of --label pick; the force lift "
                               "runs the model's physics (--repeat measures its stability)")
    from tangle_drake.tangle_data.collect import collect

    settings, scenario_text = settings_from_args(args)
    print(f"collecting {args.samples} samples of {settings.part} into {args.out}: "
          f"{settings.parts_per_pile} parts per pile, {settings.lifts_per_pile} of the top "
          f"{settings.top_k} candidates lifted per pile, seed {settings.seed}")
    result = collect(settings, args.out, args.samples, workers=args.workers,
                     ray_address=args.ray, scenario_text=scenario_text)
    counts = result.counts
    print(f"{result.directory}: {counts['samples']} samples from {counts['tasks']} piles, "
          f"{counts['tangled']} tangled ({_percent(counts['tangled'], counts['samples'])}), "
          f"{counts['immediate']} labelled without a lift (two parts in the closing region), "
          f"{counts['empty_region']} candidates skipped (empty closing region), "
          f"{counts['lift_errors']} lifts failed")
    if "repeat_all_agree_fraction" in counts:
        print(f"label agreement over {counts['repeat_lifts']} lifts x {settings.repeat}: all "
              f"agree {100 * counts['repeat_all_agree_fraction']:.1f} %, majority agreement "
              f"{100 * counts['repeat_majority_agreement']:.1f} %")
    return _finish(result, "samples")


def run_picks(args: argparse.Namespace) -> int:
    from tangle_drake.tangle_data.collect import collect_picks

    settings, scenario_text = pick_settings_from_args(args)
    print(f"collecting {args.samples} physical picks of {settings.part} into {args.out}: "
          f"the top {settings.top_k} candidates of each pile picked from the same pile, seed "
          f"{settings.seed}")
    result = collect_picks(settings, args.out, args.samples, workers=args.workers,
                           ray_address=args.ray, scenario_text=scenario_text)
    c = result.counts
    print(f"{result.directory}: {c['samples']} picks from {c['tasks']} piles: one part "
          f"{c['one']} ({_percent(c['one'], c['samples'])}), several {c['tangled']} "
          f"({_percent(c['tangled'], c['samples'])}), none {c['none']} "
          f"({_percent(c['none'], c['samples'])}); {c['failed']} candidates could not be "
          "picked (no label)")
    return _finish(result, "picks")


def _finish(result, unit: str) -> int:
    """Say how fast this run was and whether it was interrupted; the exit code."""
    if result.new_tasks:
        print(f"this run: {result.new_tasks} piles, "
              f"{result.per_minute_per_worker:.1f} {unit}/min/worker")
    if result.interrupted:
        print("interrupted: every finished pile is kept; run the same command again to "
              "resume where it stopped")
        return 130
    return 0


def _percent(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f} %" if whole else "-"
