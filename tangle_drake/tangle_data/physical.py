"""Physical-pick data (``tangle-drake collect --label pick``): the outcome of real picks.

The seed paper's second baseline (Matsumura et al. 2018) learns from simulated picks with the
physical gripper, not from a force that lifts one part. A task here is one settled pile of the
benchmark's scenario (the floating gripper by default): graspability's first ``top_k``
candidates are picked one by one, each from the same settled pile restored
(:meth:`~tangle_drake.episode.episode.Episode.single_pick`, the benchmark's own pick), and each is
stored with what came up, counted by the simulation: ``outcome`` 1 = exactly one part, 2 =
several, 0 = none, in the codes of the pick log (:mod:`tangle_drake.pick.pick_log`), and
``label`` (tangled) 1 = several, 0 = one, -1 = none. A candidate that could not be picked
(unreachable, in collision) is no label: the task's record lists it with its reason. So the
dataset says, per pile, what each of the five candidates would have done: the top-5 oracle.
Each pick runs under its own draw of the physics (friction, the pads' stiffness, a few mm and
degrees of grasp error; :class:`~tangle_drake.station.perturb.PhysicsSpread`), recorded in the
task's record, and its crop is cut from the depth image with the camera's noise added
(:func:`noisy_depth`): a real sensor's depth is never the renderer's.

Pile seeds come from the collection seed (:mod:`.seeds`), not the benchmark's, so a model
trained on these piles is tested on others.
"""

from __future__ import annotations

import math
import resource
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from tangle_drake.common.errors import TangleDrakeError, check_seed
from tangle_drake.common.failures import FailureKind
from tangle_drake.dataset import rows_to_arrays
from tangle_drake.dataset.store import TaskResult
from tangle_drake.episode.episode import Episode, PhysicalPick
from tangle_drake.parts import load_part
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import DEFAULT_CROP, CropSpec, extract_crop
from tangle_drake.pick import pick_log
from tangle_drake.pick.outcome import Outcome
from tangle_drake.pick.recovery import Verdict
from tangle_drake.planning.motions import scenario_mode
from tangle_drake.scenario import Scenario, parse_scenario
from tangle_drake.selection.methods import Method, MethodRun
from tangle_drake.station.perturb import PhysicsSpread, PickPhysics
from tangle_drake.tangle_data.seeds import depth_noise_rng, physics_rng, pile_seed

LABEL = "pick"
"""The ``--label`` of physical-pick data (the auto-lift's is ``lift``)."""
PICK_SCENARIO = "floating_gripper.yaml"
"""The default scenario: the benchmark's floating gripper, so the data's picks are its picks."""
OUTCOME_CODES = {outcome: pick_log.OUTCOME_CODES[verdict] for outcome, verdict in (
    (Outcome.NONE, Verdict.NONE), (Outcome.ONE, Verdict.ONE), (Outcome.SEVERAL, Verdict.SEVERAL))}
"""The ``outcome`` field, in the pick log's codes."""
MAX_TOP_K = 20


@dataclass(frozen=True)
class PickDataSettings:
    """One physical-pick collection."""

    part: str
    """A built-in part name, or a mesh file path."""
    mesh_scale: float = 1.0
    parts_per_pile: int | None = None
    """``None``: the scenario's pile size (15 in the benchmark's scenario)."""
    top_k: int = 5
    """Graspability's first candidates picked per pile (the paper's top five)."""
    seed: int = 0
    crop: CropSpec = DEFAULT_CROP
    physics: PhysicsSpread | None = field(default_factory=PhysicsSpread)
    """Each pick's friction, pad stiffness and grasp error drawn from this (seeded per pick),
    so a model learns picking, not one simulator's gripper; ``None``: the model's physics."""
    depth_noise_m: float = 0.0005
    """Each pick's crop sees the depth image with Gaussian noise per pixel, of a standard
    deviation drawn uniform in [0, this] per pick (seeded), m: an industrial structured-light
    sensor's ~0.1-0.5 mm at half a metre. The graspability candidates, which the pick
    executes, come from the clean image. 0: the renderer's depth."""
    fast: bool = True
    """The rig's shortcut (:meth:`~tangle_drake.episode.episode.Episode.single_pick`): a grasp that
    closed on nothing ends at the close, with the outcome the lift would have ended with."""

    def validate(self) -> None:
        if not (math.isfinite(self.mesh_scale) and self.mesh_scale > 0):
            raise TangleDrakeError(f"--mesh-scale must be positive, got {self.mesh_scale}")
        if self.parts_per_pile is not None and self.parts_per_pile < 1:
            raise TangleDrakeError(f"--parts-per-pile must be at least 1, got "
                                   f"{self.parts_per_pile}")
        if not 1 <= self.top_k <= MAX_TOP_K:
            raise TangleDrakeError(f"--top-k must be between 1 and {MAX_TOP_K}, got "
                                   f"{self.top_k}")
        check_seed(self.seed, "--seed")
        if not (math.isfinite(self.depth_noise_m) and self.depth_noise_m >= 0):
            raise TangleDrakeError(f"--depth-noise must be >= 0, got {self.depth_noise_m}")
        if not (math.isfinite(self.crop.size_m) and self.crop.size_m > 0):
            raise TangleDrakeError(f"--crop-size must be positive, got {self.crop.size_m}")

    def identity(self) -> dict:
        """What a dataset is bound to (JSON-ready): appending needs the same."""
        return {"label": LABEL, **asdict(self)}


def pick_data_scenario(scenario_text: str, settings: PickDataSettings) -> Scenario:
    """The scenario with its pile made of the part alone (its size kept unless set)."""
    settings.validate()
    scenario = parse_scenario(scenario_text, source="the pick-data scenario")
    pile = scenario.pile.alone(settings.part, settings.mesh_scale, settings.parts_per_pile)
    if pile.total_count < 1:
        raise TangleDrakeError("the pick-data scenario's pile has no parts: pass "
                               "--parts-per-pile")
    return replace(scenario, pile=pile)


PICK_SHARES = (("one", "one part"), ("tangled", "several"), ("none", "none"))
"""The task counts a pick collection's progress shows as shares of the samples (``tangled``:
several)."""


class PhysicalPickSimulator:
    """Builds the part's pick rig once and runs tasks on it (one per settled pile)."""

    def __init__(self, scenario_text: str, settings: PickDataSettings) -> None:
        self.settings = settings
        self.scenario = pick_data_scenario(scenario_text, settings)
        self.part = load_part(settings.part, mesh_scale=settings.mesh_scale)
        mode = scenario_mode(self.scenario, "the pick-data scenario")
        self.rig = Episode.single_pick(self.scenario, [Method("graspability", "graspability")],
                           self.part.name, floating=mode == "floating", fast=settings.fast)

    def run_task(self, task: int) -> TaskResult:
        """Settle task ``task``'s pile and pick each of its first candidates from it."""
        cpu, wall = time.process_time(), time.perf_counter()
        s = self.settings
        seed = pile_seed(s.seed, task)
        settled = self.rig.settle(seed)
        rows = PickRows(s, self.part.name, self.rig.intrinsics)
        stats = {"task": task, "pile_seed": seed, "samples": 0, "tangled": 0, "one": 0,
                 "none": 0, "failed": 0, "failures": [], "physics": [], "depth_noise_m": [],
                 "sim_s": 0.0,
                 "pile": {"settled": settled.report.settled,
                          "in_bin": settled.report.num_in_bin,
                          "settle_time_s": settled.report.settle_time}}
        for rank in range(s.top_k):
            physics = None if s.physics is None else \
                PickPhysics.draw(s.physics, physics_rng(s.seed, task, rank))
            pick = self.rig.pick(settled.state, MethodRun("graspability", 0, only=rank),
                                 physics)
            record = pick.record
            stats["sim_s"] += pick.sim_s
            if record is not None and record.failure is FailureKind.NO_CANDIDATE:
                break  # fewer candidates than top_k
            if record is None or record.outcome not in OUTCOME_CODES:
                why = FailureKind.TIMEOUT if record is None else record.failure
                stats["failed"] += 1
                stats["failures"].append({"rank": rank, "failure": why.value})
                continue
            rng = depth_noise_rng(s.seed, task, rank)
            noise = float(rng.uniform(0, s.depth_noise_m))
            rows.add(pick, rank, seed, task, noisy_depth(pick.depth, noise, rng))
            stats["depth_noise_m"].append(round(noise, 9))
            if physics is not None:
                stats["physics"].append({"rank": rank, **physics.to_dict()})
            stats["samples"] += 1
            stats["tangled"] += record.outcome is Outcome.SEVERAL
            stats["one"] += record.outcome is Outcome.ONE
            stats["none"] += record.outcome is Outcome.NONE
        stats["candidates"] = stats["samples"] + stats["failed"]
        stats["cpu_s"] = time.process_time() - cpu
        stats["wall_s"] = time.perf_counter() - wall
        stats["max_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        return TaskResult(task, rows.arrays(), stats)


def noisy_depth(depth: np.ndarray, sigma_m: float, rng: np.random.Generator) -> np.ndarray:
    """``depth`` with Gaussian noise of ``sigma_m`` on every pixel (``depth`` itself for 0)."""
    if sigma_m == 0:
        return depth
    return depth + rng.normal(0.0, sigma_m, depth.shape).astype(depth.dtype)


class PickRows:
    """A task's picks as the dataset's arrays, one row per pick with an outcome."""

    FIELDS = ("crop", "label", "score", "u", "v", "angle_deg", "depth_m", "width_m", "rank",
              "pile_seed", "task", "num_in_region", "num_lifted", "num_hanging", "target",
              "outcome", "sim_lifted", "sim_held", "pose", "part")

    def __init__(self, settings: PickDataSettings, part: str,
                 intrinsics: CameraIntrinsics) -> None:
        self.settings = settings
        self.part = part
        self.intrinsics = intrinsics
        self.rows: dict[str, list] = {name: [] for name in self.FIELDS}

    def add(self, pick: PhysicalPick, rank: int, pile_seed: int, task: int,
            depth: np.ndarray) -> None:
        """The pick's row, its crop cut from ``depth`` (the image the pick was chosen on, or
        that with the camera's noise)."""
        record = pick.record
        c = record.candidate
        crop = extract_crop(depth, self.intrinsics, c.u, c.v, c.angle_deg,
                            c.depth_m, self.settings.crop)
        code = OUTCOME_CODES[record.outcome]
        row = {"crop": crop, "label": pick_log.tangled_label(code), "score": c.score,
               "u": c.u, "v": c.v, "angle_deg": c.angle_deg, "depth_m": c.depth_m,
               "width_m": c.width_m,
               "rank": rank, "pile_seed": pile_seed, "task": task,
               # What the auto-lift labeller counts; a physical pick does not.
               "num_in_region": -1, "num_lifted": -1, "num_hanging": -1, "target": -1,
               "outcome": code,
               "sim_lifted": -1 if record.truth.lifted is None else record.truth.lifted,
               "sim_held": -1 if record.truth.held is None else record.truth.held,
               "pose": np.asarray(c.pose, dtype=np.float64), "part": self.part}
        for name in self.FIELDS:
            self.rows[name].append(row[name])

    def arrays(self) -> dict[str, np.ndarray]:
        """The shard's arrays, with the right dtypes and shapes even when empty."""
        return rows_to_arrays(self.rows, {"crop": (self.settings.crop.size_px,) * 2,
                                          "pose": (4, 4)})
