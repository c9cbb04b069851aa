"""``tangle-drake export-onnx``: a trained tangle CNN as one ONNX file, checked against torch."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export-onnx", help="export a trained tangle CNN to ONNX",
        description="Write the model of a `tangle-drake train` checkpoint as one ONNX file: "
                    "inputs crops (N, S, S) metres and grasp_depths (N,), and for a model "
                    "with a target mask (the default of `train`) target_masks (N, S, S), "
                    "computed outside the graph (tangle_drake.tangle_cnn.target_mask); output "
                    "p_not_tangled (N,) (p_success or p_one_part for a pick model), "
                    "normalisation included. Then compare it with torch on "
                    "random crops (needs onnxruntime). Needs the onnx extra.")
    parser.add_argument("--model", type=Path, required=True, help="checkpoint (.pt)")
    parser.add_argument("--out", type=Path, required=True, help="ONNX file to write")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tangle_drake.tangle_cnn.model import load_tangle_model
    from tangle_drake.tangle_cnn.onnx_export import export_onnx, onnx_disagreement

    model = load_tangle_model(args.model)
    export_onnx(model, args.out)
    difference = onnx_disagreement(model, args.out)
    print(f"wrote {args.out}; largest difference from torch on random crops: {difference:.2e}")
    return 0
