"""``tangle-drake bench``: methods x parts x trials of simulated picks, with a report."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from tangle_drake.commands.arguments import add_scenario_argument, add_seed_argument, scenario_from
from tangle_drake.common.failures import FailureKind
from tangle_drake.common.workers import add_worker_arguments
from tangle_drake.selection.registry import DEFAULT_METHODS, help_list


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench", help="benchmark the pick methods on simulated piles (resumable, with a report)",
        description="For each part and trial, drop a fresh random pile, then let each method "
                    "pick once from that same pile with the physically simulated gripper, and "
                    "count what came up: exactly one part (success), several (tangled), none "
                    f"(empty), or failure ({', '.join(kind.value for kind in FailureKind)}). "
                    "Writes "
                    "report.md, CSV and JSON tables with 95 % confidence intervals, and PNG "
                    "plots into --out; run the same command again to resume.")
    parser.add_argument("--methods", nargs="+", default=None, metavar="METHOD",
                        help=f"{help_list()}; default: {' '.join(DEFAULT_METHODS)} (the "
                             "paper's comparison), leaving out, with a notice, a method whose "
                             "part has no trained model")
    parser.add_argument("--parts", "--part", nargs="+", default=None, metavar="PART",
                        dest="parts",
                        help="built-in parts or mesh files (default: every built-in part)")
    parser.add_argument("--mesh-scale", type=float, default=1.0, metavar="S",
                        help="metres per mesh unit of mesh parts (0.001 for millimetres)")
    parser.add_argument("--trials", type=int, default=None, metavar="N",
                        help="piles per part (default 50; a later run may raise it)")
    parser.add_argument("--mode", choices=("floating", "arm"), default=None,
                        help="floating: the gripper on a 4-axis gantry (fast; the default, "
                             "diagrams/floating_gripper.yaml); arm: the Nextage of the demo "
                             "(diagrams/pick_demo.yaml); with --scenario, the scenario's "
                             "carrier decides, and a --mode that disagrees is an error")
    add_worker_arguments(parser, "trials")
    parser.add_argument("--out", type=Path, default=Path("results/bench"),
                        help="results directory (default: results/bench)")
    add_seed_argument(parser, 0, help="seed of the piles (default 0)")
    add_scenario_argument(parser, "the --mode's: diagrams/floating_gripper.yaml or "
                                  "diagrams/pick_demo.yaml")
    parser.add_argument("--clear", action="store_true",
                        help="clear whole bins instead: each method empties the same full "
                             "piles into the tray, closed loop (weighing every lift), until "
                             "the bin is empty or it gives up; reports parts delivered, "
                             "deliveries of exactly one part, several read as one, parts per "
                             "hour (default methods: graspability harmonic)")
    parser.add_argument("--open-loop", action="store_true",
                        help="with --clear: the paper's open loop (one look, one grasp, no "
                             "weighing), to compare on the same piles")
    parser.add_argument("--gallery", action="store_true",
                        help="also write a tile of each failed pick (the top view at pick time "
                             "with the chosen grasp) into OUT/gallery, by method and failure "
                             "kind, linked from report.md")
    parser.add_argument("--perturb", action="store_true",
                        help="pick under perturbed physics: each pile's friction, finger-pad "
                             "stiffness and grasp error drawn at random (seeded, the same for "
                             "every method on the pile), so a method's lead is seen to survive "
                             "a simulator that is not the one its model learnt")
    parser.add_argument("--quick", action="store_true",
                        help="a quick check (for CI): unless given, u_hook only, random and "
                             "graspability, 2 trials; piles of 6 parts")
    parser.set_defaults(func=run)


def command_line(args: argparse.Namespace) -> str:
    """The command as given (the options that make the results; not --workers or --ray,
    which change only how fast), for the report, its paths as ``shown_path`` writes them."""
    from tangle_drake.common.paths import shown_path

    def method(text: str) -> str:  # model:PATH and RULE:PATH name a file
        prefix, colon, rest = text.partition(":")
        return f"{prefix}:{shown_path(rest)}" if colon and rest else text

    words = ["tangle-drake", "bench"]
    if args.methods is not None:
        words += ["--methods", *map(method, args.methods)]
    if args.parts is not None:
        words += ["--parts", *map(shown_path, args.parts)]
    for option, default in (("trials", None), ("mode", None), ("seed", 0),
                            ("mesh_scale", 1.0)):
        value = getattr(args, option)
        if value != default:
            words += [f"--{option.replace('_', '-')}", str(value)]
    if args.scenario:
        words += ["--scenario", *map(shown_path, args.scenario)]
    for text in args.scenario_text:
        words += ["--scenario-text", text]
    words += ["--clear"] if args.clear else []
    words += ["--open-loop"] if args.open_loop else []
    words += ["--quick"] if args.quick else []
    words += ["--gallery"] if args.gallery else []
    words += ["--perturb"] if args.perturb else []
    return shlex.join([*words, "--out", shown_path(args.out)])


def run(args: argparse.Namespace) -> int:
    from tangle_drake.bench.report import terminal_summary
    from tangle_drake.bench.runner import BenchOptions, run_bench

    outcome = run_bench(BenchOptions(
        methods=args.methods, parts=args.parts, mesh_scale=args.mesh_scale, trials=args.trials,
        workers=args.workers, ray=args.ray, out=args.out, mode=args.mode, seed=args.seed,
        scenario=scenario_from(args), quick=args.quick, clear=args.clear, open_loop=args.open_loop,
        gallery=args.gallery, perturb=args.perturb, command=command_line(args)))
    if args.clear:
        from tangle_drake.bench.clear_report import terminal_clear_summary

        print(terminal_clear_summary(outcome.summary))
    else:
        print(terminal_summary(outcome.summary))
        timings = outcome.summary["throughput"]
        if timings["cpu_s_per_pick"] is not None:
            print(f"{timings['picks']} picks, {timings['cpu_s_per_pick']:.1f} CPU s per pick "
                  "(pile included)")
    for note in outcome.notices:
        print(note)
    print(f"wrote {', '.join(path.name for path in outcome.files)} in {outcome.directory}")
    if outcome.interrupted:
        print("interrupted: every finished trial is kept; run the same command again to resume")
        return 130
    return 0
