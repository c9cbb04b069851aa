"""The labelling simulator: one station built once, then one task (one pile) after another.

A task: reset the station's context to its initial state (so a task's result never depends
on the tasks the worker ran before it), drop and settle a random pile with the task's seed,
render the top depth image, rank grasp candidates with the graspability index, draw
``lifts_per_pile`` of the top-k at random, and label each with the rules of
:mod:`.labels`, restoring the settled state before every lift.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from tangle_drake.dataset.store import TaskResult
from tangle_drake.graspability import GraspabilityParams, GraspCandidate, bin_roi
from tangle_drake.graspability import compute_candidates as graspability_candidates
from tangle_drake.parts import load_part
from tangle_drake.perception.crops import extract_crop
from tangle_drake.scenario import Scenario, parse_scenario
from tangle_drake.station import build_station, camera_model
from tangle_drake.station.bin_model import inner_corners, inside_bin
from tangle_drake.station.perturb import ContactScaler, Perturbation, jiggle_parts
from tangle_drake.station.pile import PileSettler
from tangle_drake.station.pile_freeze import PileFreeze
from tangle_drake.station.scene import render_depth
from tangle_drake.tangle_data.closing_region import RegionBox, parts_in_region, surface_points
from tangle_drake.tangle_data.labels import PickLabel, label_pick
from tangle_drake.tangle_data.lift import ForceLift, LiftResult
from tangle_drake.tangle_data.pile_stats import pile_depth
from tangle_drake.tangle_data.samples import SampleRows
from tangle_drake.tangle_data.seeds import choice_rng, perturbation_rng, pile_seed
from tangle_drake.tangle_data.settings import CollectSettings


def data_scenario(scenario_text: str, settings: CollectSettings) -> Scenario:
    """The data scenario with its pile replaced by ``parts_per_pile`` copies of the part."""
    scenario = parse_scenario(scenario_text, source="the data scenario")
    scenario.pile = scenario.pile.alone(settings.part, settings.mesh_scale,
                                        settings.parts_per_pile)
    settings.validate(scenario.plant_config.time_step)
    return scenario


class TangleDataSimulator:
    """Builds the robot-less station once and runs tasks on it (one per settled pile)."""

    def __init__(self, scenario_text: str, settings: CollectSettings) -> None:
        self.settings = settings
        self.scenario = data_scenario(scenario_text, settings)
        self.part = load_part(settings.part, mesh_scale=settings.mesh_scale)
        self.station = build_station(self.scenario)
        self.settler = PileSettler(self.station, self.scenario)
        self.simulator = self.settler.simulator
        self.plant = self.station.plant
        self.bodies = self.station.pile_bodies
        self.camera = camera_model(self.scenario)
        self.roi = bin_roi(self.camera, inner_corners(self.scenario.bin))
        self.params = GraspabilityParams(top_k=settings.top_k)
        self.points = surface_points(self.part)
        self.region = RegionBox.of_gripper(settings.gripper, settings.labels.region_margin_m)
        self.lifter = ForceLift(self.simulator, self.plant,
                                PileFreeze(self.plant, self.station.scene_graph, self.bodies),
                                self.part, self.points, self.scenario.bin, settings.lift)
        self.contacts = ContactScaler(self.plant, self.station.scene_graph)
        self.perturbation = Perturbation()
        self.lifts_run = 0
        """Lifts simulated so far (tests check that immediate labels simulate nothing)."""

    # -- one task ---------------------------------------------------------------------------

    def run_task(self, task: int) -> TaskResult:
        """Make task ``task``'s pile and label its chosen candidates."""
        cpu, wall = time.process_time(), time.perf_counter()
        s = self.settings
        seed = pile_seed(s.seed, task)
        report = self.make_pile(seed)
        pile_cpu = time.process_time() - cpu
        poses = self.part_poses()
        in_bin = inside_bin(self.scenario.bin, poses[:, :3, 3])
        depth_info = pile_depth(poses, self.points, self.scenario.bin.floor_height, in_bin)
        depth = render_depth(self.station, self.simulator.get_context())
        candidates = self.candidates(depth)
        count = min(s.lifts_per_pile, len(candidates))
        chosen = sorted(int(r) for r in choice_rng(s.seed, task).choice(
            len(candidates), size=count, replace=False))
        settled = self.simulator.get_context().Clone()
        rows = SampleRows(s, self.part.name, depth if s.full_depth else None)
        stats = {"task": task, "pile_seed": seed, "candidates": len(candidates),
                 "chosen": count, "empty_region": 0, "immediate": 0, "lifts": 0,
                 "lift_errors": 0, "lift_steps": 0, "tangled": 0, "samples": 0,
                 "repeat_lifts": 0, "repeat_all_agree": 0, "repeat_majority": 0.0}
        for rank in chosen:
            candidate = candidates[rank]
            region = parts_in_region(candidate.pose, poses, self.points, self.region)
            try:
                label = label_pick(region, lambda target: self.lift(settled, target))
                votes = self.repeat_votes(settled, task, rank, label)
            except RuntimeError as error:  # the contact solver gave up on this lift
                stats["lift_errors"] += 1
                stats.setdefault("errors", []).append(str(error).splitlines()[0][:200])
                continue
            if not label.is_sample:
                stats["empty_region"] += 1
                continue
            crop = extract_crop(depth, self.camera.intrinsics, candidate.u, candidate.v,
                                candidate.angle_deg, candidate.depth_m, s.crop)
            rows.add(crop, candidate, rank, seed, task, label, votes)
            stats["immediate"] += label.lift is None
            stats["lifts"] += label.lift is not None
            stats["lift_steps"] += 0 if label.lift is None else label.lift.steps
            stats["tangled"] += label.tangled
            stats["samples"] += 1
            if votes is not None:
                majority = max(votes, s.repeat - votes)
                stats["repeat_lifts"] += 1
                stats["repeat_all_agree"] += majority == s.repeat
                stats["repeat_majority"] += majority / s.repeat
        stats["pile"] = {"settled": report.settled, "parked": len(report.parked),
                         "redrawn": len(report.redrawn), "settle_time_s": report.settle_time,
                         "layers": depth_info.layers, "max_layers": depth_info.max_layers,
                         "height_m": depth_info.height_m}
        stats["pile_cpu_s"] = pile_cpu
        stats["cpu_s"] = time.process_time() - cpu
        stats["wall_s"] = time.perf_counter() - wall
        stats["max_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        return TaskResult(task, rows.arrays(), stats)

    # -- the steps, also used on their own by tests and the benchmark ----------------------

    def make_pile(self, seed: int):
        """Reset the station and drop a settled pile made with ``seed``."""
        return self.settler.settle(seed).report

    def restore(self, saved) -> None:
        """Put the simulator back into a saved context's time, state and parameters."""
        self.simulator.get_mutable_context().SetTimeStateAndParametersFrom(saved)
        self.simulator.Initialize()

    def candidates(self, depth: np.ndarray) -> list[GraspCandidate]:
        return graspability_candidates(depth, self.camera, self.settings.gripper, self.params,
                                       self.roi)

    def part_poses(self) -> np.ndarray:
        """(N, 4, 4) world poses of the pile's parts in the current state."""
        return self.station.part_poses(self.simulator.get_context())

    def lift(self, settled, target: int) -> LiftResult:
        """Restore the settled pile and lift part ``target``."""
        self.restore(settled)
        self.lifts_run += 1
        labels = self.settings.labels
        return self.lifter.run(target, labels.rise_threshold_m, labels.stall_fraction)

    def repeat_votes(self, settled, task: int, rank: int, label: PickLabel) -> int | None:
        """With ``repeat`` > 1: how many of the lift and its perturbed re-runs said tangled."""
        repeats = self.settings.repeat
        if repeats == 1 or label.lift is None:  # no lift, nothing to repeat
            return None
        votes = int(label.tangled)
        plant_context = self.plant.GetMyMutableContextFromRoot(self.simulator.get_context())
        p = self.perturbation
        labels = self.settings.labels
        for r in range(1, repeats):
            # Restoring the context restores the friction too (SceneGraph keeps geometry
            # properties in the context's parameters).
            self.restore(settled)
            rng = perturbation_rng(self.settings.seed, task, rank, r)
            context = self.simulator.get_mutable_context()
            self.contacts.apply(context, friction=rng.uniform(1 - p.friction_spread,
                                                              1 + p.friction_spread))
            jiggle_parts(self.plant, plant_context, self.bodies, p, rng)
            self.simulator.AdvanceTo(context.get_time() + p.resettle_s)
            self.lifts_run += 1
            result = self.lifter.run(label.target, labels.rise_threshold_m,
                                     labels.stall_fraction)
            votes += int(PickLabel(label.in_region, result).tangled)
        return votes
