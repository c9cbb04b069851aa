"""``tangle-drake teach``: a user's mesh to a trained, tested and benchmarked model (resumable)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tangle_drake.commands.arguments import add_seed_argument
from tangle_drake.common.workers import add_worker_arguments


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "teach", help="teach a new part: mesh check, labels, training, test, benchmark",
        description="From a mesh file to a tangle CNN for it, in one resumable command: "
                    "check the mesh (size, mass, repairs, convex pieces, pictures; a mesh "
                    "that is not a pickable part is refused with the reason), collect the "
                    "auto-lift's labels, train, test on fresh piles of another seed, and "
                    "benchmark it against graspability alone on paired piles. Writes into "
                    "--out the part file, the model (.pt, and .onnx with the onnx extra), its "
                    "card and the benchmark's report. Ctrl-C, then the same command, resumes "
                    "at the stage and sample where it stopped.")
    parser.add_argument("mesh", type=Path,
                        help="the part's mesh (.stl, .ply, .obj), or a built-in part's name "
                             "(made by the shipped models' recipe: the same labels and "
                             "training give the same weights)")
    parser.add_argument("--mesh-scale", type=float, default=1.0, metavar="S",
                        help="metres per mesh unit (0.001 for millimetres; default 1)")
    parser.add_argument("--mass", type=float, default=None, metavar="KG",
                        help="the part's weighed mass, kg (default: from the mesh at steel's "
                             "density)")
    parser.add_argument("--out", type=Path, required=True, help="the run's directory")
    parser.add_argument("--samples", type=int, default=None, metavar="N",
                        help="labels to collect (default 1800: docs/results/learning_curve shows "
                             "more, up to the paper's 5100, give no measurably better model)")
    parser.add_argument("--test-samples", type=int, default=None, metavar="N",
                        help="labels from piles of the next seed to test the model on "
                             "(default 500; the shipped models' card tests on 1000)")
    add_seed_argument(parser, 0, help="seed of everything (default 0)")
    parser.add_argument("--quick", action="store_true",
                        help="every stage, as small as still says something: a check that "
                             "the whole run works (minutes), not a model to use")
    add_worker_arguments(parser, "label and benchmark tasks")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from tangle_drake.common.errors import TangleDrakeError
    from tangle_drake.teach.pipeline import Teacher, TeachSettings

    make = TeachSettings.quick if args.quick else TeachSettings
    settings = make(str(args.mesh), args.mesh_scale, args.mass, seed=args.seed)
    for option, field in (("--samples", "samples"), ("--test-samples", "test_samples")):
        value = getattr(args, field)
        if value is not None:
            if value < 1:
                raise TangleDrakeError(f"{option} must be at least 1, got {value}")
            settings = replace(settings, **{field: value})
    try:
        check = Teacher(settings, args.out, workers=args.workers, ray=args.ray).run()
    except KeyboardInterrupt:
        print(f"interrupted: what is finished is kept in {args.out}; run the same command "
              "again to resume", file=sys.stderr)
        return 130
    if not check.accepted:  # one line, like every refusal (--out is left as it was)
        raise TangleDrakeError(" ".join(f"{args.mesh} is refused: {check.refusal}".split()))
    print(f"taught: {Path(args.out) / 'model.pt'}, its card {Path(args.out) / 'card.md'}")
    return 0
