"""Benchmark the tangle CNN on this machine's CPU: scoring one image, and training throughput.

Inference: the 5 grasp candidates of one 640x480 depth image, crop extraction + normalisation
(with the target mask, as ``tangle-drake train`` makes models by default) + forward pass
(``TangleModel.predict_candidates``), on one CPU core; median and p95 over ``--runs``.
Target: at most 5 ms.

Training: one epoch of ``tangle-drake train``'s own loop on a synthetic dataset of 96 px
crops, in samples per second, and from it the time of a paper-sized training: 5,100 samples,
4,590 training x 8 augmentations = 36,720 per epoch plus 510 validation, for ``--epochs``
(default 30, the train command's maximum; early stopping usually ends sooner).
Target: at most 30 minutes.

    python tools/bench_cnn.py [--model models/u_hook.pt] [--runs 200] [--train-threads 2]

(with the package installed, e.g. `make install`, or from the repository root with
``PYTHONPATH=.``).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import torch

from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import DEFAULT_CROP, candidate_crops
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.tangle_cnn.checkpoint import read_checkpoint
from tangle_drake.tangle_cnn.model import TangleModel, load_tangle_model
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet, parameter_count
from tangle_drake.tangle_cnn.normalise import Normalisation
from tangle_drake.tangle_cnn.synthetic import write_synthetic_dataset
from tangle_drake.tangle_cnn.target_mask import TargetMask
from tangle_drake.tangle_cnn.train import TrainSettings, train

PAPER_TRAIN = 4590 * 8
PAPER_VALIDATION = 510


@dataclass(frozen=True)
class Candidate:
    u: float
    v: float
    angle_deg: float
    depth_m: float


def pile_image(rng: np.random.Generator) -> np.ndarray:
    """A 640x480 depth image of wire-like bars on a floor, with missing pixels."""
    depth = np.full((480, 640), 0.80, dtype=np.float32)
    for _ in range(60):
        start, end = rng.uniform((0, 0), (640, 480), (2, 2)).astype(int)
        cv2.line(depth, tuple(map(int, start)), tuple(map(int, end)),
                 float(rng.uniform(0.74, 0.79)), 5)
    depth[rng.random(depth.shape) < 0.02] = np.nan
    return depth


def timings_ms(function, runs: int) -> np.ndarray:
    for _ in range(20):
        function()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return np.array(times) * 1e3


def bench_inference(model: TangleModel, runs: int) -> None:
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    intrinsics = CameraIntrinsics.from_fov_y(640, 480, 45)
    depth = pile_image(rng)
    candidates = [Candidate(*rng.uniform((60, 60, -90), (580, 420, 90)), 0.785)
                  for _ in range(5)]
    total = timings_ms(lambda: model.predict_candidates(depth, intrinsics, candidates), runs)
    crops_only = timings_ms(lambda: candidate_crops(depth, intrinsics, candidates, model.crop),
                            runs)
    print(f"inference, 5 candidates of a 640x480 image, 1 thread, {runs} runs: median "
          f"{np.median(total):.2f} ms, p95 {np.percentile(total, 95):.2f} ms (target <= 5 ms); "
          f"of which crop extraction median {np.median(crops_only):.2f} ms")


def bench_training(samples: int, threads: int, epochs: int) -> None:
    torch.set_num_threads(threads)
    with tempfile.TemporaryDirectory() as scratch:
        data = Path(scratch) / "data"
        write_synthetic_dataset(data, samples, DEFAULT_CROP.size_px, DEFAULT_CROP.size_m)
        out = Path(scratch) / "model.pt"
        train(data, out, TrainSettings(epochs=1), device="cpu", log=lambda line: None)
        checkpoint = read_checkpoint(out)
    record, summary = checkpoint["metrics"], checkpoint["data"]
    pairs = summary["train_samples"] * 8
    per_second = (pairs + summary["validation_samples"]) / record["seconds"]
    paper_epoch = (PAPER_TRAIN + PAPER_VALIDATION) / per_second
    print(f"training, {pairs} augmented samples of 96 px on {threads} thread(s): "
          f"{per_second:.0f} samples/s; a paper-sized epoch ({PAPER_TRAIN} + "
          f"{PAPER_VALIDATION}) takes {paper_epoch / 60:.1f} min, {epochs} epochs "
          f"{epochs * paper_epoch / 60:.1f} min (target <= 30 min)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, help="checkpoint (default: untrained network)")
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--train-samples", type=int, default=1024,
                        help="synthetic samples for the training measurement")
    parser.add_argument("--train-threads", type=int, default=os.cpu_count())
    parser.add_argument("--epochs", type=int, default=TrainSettings().epochs,
                        help="epochs of the paper-sized estimate")
    args = parser.parse_args()
    if args.model:
        model = load_tangle_model(args.model)
    else:
        torch.manual_seed(0)
        normalisation = Normalisation(target_mask=TargetMask.for_hand(DEFAULT_CROP,
                                                                      DEFAULT_GRIPPER))
        config = NetworkConfig(input_size=DEFAULT_CROP.size_px,
                               input_channels=normalisation.channels)
        model = TangleModel(TangleNet(config), DEFAULT_CROP, normalisation)
    count = parameter_count(model.network)
    print(f"network: {count} parameters, {count * 4 / 1e6:.2f} MB of float32 weights; load "
          f"average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    bench_inference(model, args.runs)
    bench_training(args.train_samples, args.train_threads, args.epochs)


if __name__ == "__main__":
    main()
