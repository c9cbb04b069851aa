"""Synthetic tangle data: crossing bars vs separate bars, for tests and the benchmark.

Not a model of real piles: a separable stand-in with the dataset's exact on-disk format, so
training, resuming and timing can be checked without running the physics simulation. Each
crop shows the target bar across the closing direction (vertical, through the centre) on a
flat floor; a *tangled* sample has a second bar lying across the target at a random angle, a
*not tangled* one a short bar off to one side.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.dataset import SAMPLE_FIELDS, write_manifest, write_shard
from tangle_drake.perception.crops import CropSpec
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER

FLOOR_M = 0.80
GRASP_DEPTH_M = 0.79
TARGET_TOP_M = 0.776
OTHER_TOP_M = 0.770


def synthetic_crop(tangled: bool, size_px: int, rng: np.random.Generator) -> np.ndarray:
    """One (size_px, size_px) metric crop, float32."""
    centre = (size_px - 1) / 2
    thickness = max(1, size_px // 12)
    crop = np.full((size_px, size_px), FLOOR_M, dtype=np.float32)
    target = crop.copy()
    x = round(centre + rng.uniform(-1, 1))
    cv2.line(target, (x, 0), (x, size_px - 1), TARGET_TOP_M, thickness)
    other = crop.copy()
    angle = np.radians(rng.uniform(25, 155))
    direction = np.array([np.cos(angle), np.sin(angle)])
    if tangled:
        middle = centre + rng.uniform(-size_px / 8, size_px / 8, 2)
        half = size_px
    else:
        middle = np.array([rng.choice([size_px * 0.12, size_px * 0.88]),
                           rng.uniform(size_px * 0.2, size_px * 0.8)])
        direction = np.array([0.3 * direction[0], direction[1]])  # steep: stays on its side
        half = size_px * 0.15
    ends = [tuple(int(c) for c in np.rint(middle + sign * half * direction)) for sign in (-1, 1)]
    cv2.line(other, ends[0], ends[1], OTHER_TOP_M, thickness)
    noise = rng.normal(0, 0.0005, crop.shape).astype(np.float32)
    return np.minimum(target, other) + noise


def synthetic_samples(count: int, size_px: int, seed: int,
                      samples_per_pile: int = 8) -> dict[str, np.ndarray]:
    """``count`` samples with every ``SAMPLE_FIELDS`` array, alternating the two classes."""
    rng = np.random.default_rng(seed)
    labels = np.arange(count) % 2
    piles = seed * 1_000_000 + np.arange(count) // samples_per_pile
    samples = {name: np.zeros(count, dtype=dtype) for name, dtype in SAMPLE_FIELDS.items()}
    samples.update(
        crop=np.stack([synthetic_crop(bool(label), size_px, rng) for label in labels]),
        label=labels, score=rng.uniform(0.2, 1.0, count), u=rng.uniform(0, 640, count),
        v=rng.uniform(0, 480, count), angle_deg=rng.uniform(-90, 90, count),
        depth_m=np.full(count, GRASP_DEPTH_M), width_m=np.full(count, 0.03),
        rank=np.arange(count) % 5, pile_seed=piles, task=piles - piles[0],
        num_in_region=1 + labels, num_lifted=labels, target=np.full(count, -1))
    return samples


def write_synthetic_dataset(directory: Path, count: int, size_px: int = 32,
                            size_m: float = 0.05, seed: int = 0,
                            outcomes: bool = False) -> CropSpec:
    """A dataset directory in the collector's format: one shard per pile, a manifest.

    ``outcomes``: as physical picks record them (``collect --label pick``): crossing bars
    brought up several parts (``outcome`` 2), separate bars one (1), except every other of
    those, whose crop is the bare floor, where the fingers close on nothing (0, no tangle
    label)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    samples = synthetic_samples(count, size_px, seed)
    if outcomes:
        empty = np.arange(count) % 4 == 0  # of the separate bars (even rows)
        rng = np.random.default_rng((seed, 1))
        samples["crop"][empty] = FLOOR_M + rng.normal(0, 0.0005, (int(empty.sum()), size_px,
                                                                   size_px))
        samples["outcome"] = np.where(samples["label"] == 1, 2, np.where(empty, 0, 1)
                                      ).astype(np.int8)
        samples["label"] = np.where(empty, -1, samples["label"])
    for task in np.unique(samples["task"]):
        rows = samples["task"] == task
        write_shard(directory, int(task), {name: array[rows] for name, array in samples.items()})
    crop = CropSpec(size_m, size_px)
    write_manifest(directory, {"part": "synthetic_bars", "crop": asdict(crop),
                               "gripper": asdict(DEFAULT_GRIPPER), "samples": count})
    return crop
