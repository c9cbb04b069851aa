"""``tangle-drake demo``: the Nextage picks parts from a simulated pile, one at a time."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tangle_drake.commands.arguments import add_scenario_argument, add_seed_argument, scenario_from
from tangle_drake.selection.registry import RULES, help_list


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo", help="pick parts from a simulated pile with the Nextage, one at a time",
        description="Drop a pile in the simulated station, then run the whole pick diagram "
                    "(top camera, graspability index, tangle CNN, pick planner, Nextage arm "
                    "and gripper, wrist force sensor) until --picks parts are delivered to the "
                    "tray, each lift weighed and what is not one part shaken or put back; "
                    "printing each grasp's outcome (one part, several, none, or why it "
                    "failed), its weighing and timings. Uses "
                    "tangle_drake/trained/<part>.pt with the harmonic rule where it exists; "
                    "otherwise the graspability index alone, with a notice.")
    parser.add_argument("--picks", type=int, default=5, help="picks to make (default: 5)")
    parser.add_argument("--part", default=None,
                        help="fill the pile with this part: a built-in name (u_hook, s_hook, "
                             "c_ring, j_hook, e_shape) or a mesh file (default: the "
                             "scenario's)")
    add_scenario_argument(parser)
    add_seed_argument(parser, None, help="pile seed (default: the scenario's pile.seed)")
    parser.add_argument("--rule", choices=RULES, default=None,
                        help=f"selection rule (default: harmonic with a model, else "
                             f"graspability): {help_list(RULES)}")
    parser.add_argument("--model", type=Path, default=None,
                        help="tangle CNN checkpoint (default: tangle_drake/trained/<part>.pt)")
    parser.add_argument("--meshcat", action="store_true",
                        help="show the simulation live in Meshcat (on localhost)")
    parser.add_argument("--record", type=Path, default=None, metavar="HTML",
                        help="write a self-contained Meshcat replay of the picks to this "
                             ".html file")
    parser.add_argument("--diagram", type=Path, default=None,
                        help="also draw the pick diagram to this .svg/.png/.dot file")
    parser.add_argument("--hardware", action="store_true",
                        help="run the same pick diagram against the robot's LCM driver "
                             "interface on the scenario's bus (see docs/hardware.md)")
    parser.add_argument("--open-loop", action="store_true",
                        help="pick as the paper does: one look, one grasp, no weighing; "
                             "--picks counts grasps (default: closed loop, --picks counts "
                             "parts delivered to the tray, each weighed on the way)")
    parser.add_argument("--log-picks", type=Path, default=None, metavar="DIR",
                        help="append every weighed grasp (the CNN's crop, and the weighing as "
                             "its label: several = tangled) to this pick log, a dataset that "
                             "`tangle-drake train` and `evaluate` read; runs add to it, on "
                             "hardware too")
    parser.add_argument("--pictures", type=Path, default=None, metavar="DIR",
                        help="write a picture of each pick into DIR (pick_001.png, ...): the "
                             "top view with the ranked candidates and their scores, the "
                             "chosen one marked, the side view at the top of the lift with "
                             "the outcome, and the CNN's crop and target mask")
    parser.add_argument("--with-hardware-sim", action="store_true",
                        help="with --hardware: run the hardware simulator in this process, "
                             "both sides over memq:// (nothing leaves the process)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.episode.demo import DemoOptions, run_demo

    run_demo(DemoOptions(
        picks=args.picks, part=args.part, scenario=scenario_from(args), seed=args.seed,
        rule=args.rule, model=args.model, meshcat=args.meshcat, record=args.record,
        diagram=args.diagram, hardware=args.hardware,
        with_hardware_sim=args.with_hardware_sim, open_loop=args.open_loop,
        log_picks=args.log_picks, pictures=args.pictures))
    if args.meshcat and sys.stdin.isatty():
        input("Meshcat stays up until you press Enter.")
    return 0
