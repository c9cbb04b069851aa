"""Is the closed loop's shake a property of the cell or of the simulator's contact model?

Shaking thin wires can exploit the contact model (regularised friction lets a held wire creep,
point contact has no torsional friction, thin parts pass through each other at a coarse step).
This runs closed-loop clearings of dense piles (graspability, so that several parts come up
often) and, at every shake, saves the whole diagram's context and finishes that grasp four
times from the same instant: under the model's physics, with every friction ×0.7 and ×1.3, and
with the plant stepped at 1 ms instead of 2 ms (a second diagram, the saved context copied into
it). Per shake and variant it records how the grasp ended (delivered one part, delivered
several, put back) by the tray's count, what the weighing after the shake read against the
simulation's load-path count (held, and resting on the pile), and how far the parts touching
the gripper before and after the shake moved in its frame (a wire slipping or pivoting between
the pads; parts that fell from the pads are counted apart). It prints each
variant's shake success (the shake left exactly one part, delivered) with 95 % intervals, and
its per-shake agreement with the model's physics. Then the clearing goes on under the model's
physics to the next shake.

One JSON line per pile in ``--out`` (pile seeds from ``--seed``, not the benchmark's): run the
same command again to resume.

    python tools/shake_robustness.py --parts u_hook s_hook --piles 6 --out results/shakes.jsonl
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import InitializeParams
from pydrake.systems.framework import Context

from tangle_drake.bench.clearing import tray_count
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.common.stats import wilson
from tangle_drake.episode.episode import Episode
from tangle_drake.episode.run import PickEpisode, RunEnd
from tangle_drake.pick.load_path import GRIPPER_BODY, LoadPathMonitor
from tangle_drake.pick.planner import Mode
from tangle_drake.scenario import Scenario, load_scenario
from tangle_drake.selection.methods import Method, MethodRun
from tangle_drake.station import build_station
from tangle_drake.station.perturb import ContactScaler
from tangle_drake.station.pile import PileSettler
from tangle_drake.tangle_data.seeds import pile_seed

VARIANTS = {"model": (1.0, False), "friction_0.7": (0.7, False),
            "friction_1.3": (1.3, False), "step_1ms": (1.0, True)}
"""Each variant's friction factor, and whether it runs on the 1 ms plant."""
GRASP_LIMIT = 20.0
"""Simulated seconds a grasp may take from its shake to its record, s."""
SIM_LIMIT_PER_PART = 40.0
"""Simulated seconds a clearing may take per part in the pile, s."""
STEP = 0.01
"""Simulated seconds between looks at the planner's mode, s: shorter than any mode lasts
(a weighing can take 0.2 s), so a pause at a mode never runs past it."""


@dataclass
class _Rig:
    episode: PickEpisode
    contacts: ContactScaler
    load_path: LoadPathMonitor
    """The simulation's count of what the gripper holds up, and what of it rests on the pile."""
    own: Context
    """A context of this rig's diagram, for what a context copied from another diagram must
    not bring: SceneGraph's geometry (its parameters) and the plant's sampled outputs (its
    abstract state), both named by ids this diagram does not know."""


def _rig(scenario: Scenario, method: Method, part: str) -> _Rig:
    episode = Episode.clearing(scenario, [method], part).episode
    pick = episode.pick
    return _Rig(episode, ContactScaler(pick.station.plant, pick.station.scene_graph),
                pick.diagram.GetSubsystemByName("load_path_monitor (sim only)"),
                episode.context.Clone())


def _resume(rig: _Rig, base: _Rig, saved: Context, run: MethodRun, friction: float) -> None:
    """Put ``rig``'s simulator at the saved instant (no initialization events: the planner
    is mid-grasp), its method input fixed, every friction times ``friction``."""
    context = rig.episode.context
    context.SetTimeStateAndParametersFrom(saved)
    if rig is not base:
        # Another diagram: its own geometry (SceneGraph's parameters), and its own plant's
        # sampled outputs (abstract state naming the other plant's geometry ids; they are
        # what the last step's contacts were, remade at the next step).
        context.get_mutable_parameters().SetFrom(rig.own.get_parameters())
        plant = rig.episode.pick.station.plant
        mine, own = plant.GetMyMutableContextFromRoot(context), plant.GetMyContextFromRoot(rig.own)
        for i in range(mine.num_abstract_states()):
            mine.get_mutable_abstract_state(i).SetFrom(own.get_abstract_state(i))
    rig.episode.pick.diagram.GetInputPort("method").FixValue(context, run)
    rig.contacts.apply(context, friction)
    rig.episode.simulator.Initialize(InitializeParams(suppress_initialization_events=True))


def _step(mode: Mode) -> float:
    return STEP


def _gripper_frame_positions(rig: _Rig, context: Context) -> np.ndarray:
    """The pile's part origins in the gripper's frame, (N, 3) m."""
    station = rig.episode.pick.station
    plant = station.plant
    X_WG = plant.GetBodyByName(GRIPPER_BODY).EvalPoseInWorld(station.plant_context(context))
    poses = station.part_poses(context)
    return (X_WG.inverse().GetAsMatrix4() @ np.c_[poses[:, :3, 3],
                                                  np.ones(len(poses))].T).T[:, :3]


def _in_pads(rig: _Rig, context: Context) -> set[int]:
    """Pile indices of the parts touching the gripper itself (held in or against the pads)."""
    monitor = rig.load_path
    touching = monitor.touching(monitor.GetInputPort("contact_results").Eval(
        monitor.GetMyContextFromRoot(context)))
    gripper = monitor.gripper_bodies
    pile = [int(b.index()) for b in rig.episode.pick.station.pile_bodies]
    return {i for i, body in enumerate(pile) if touching.get(body, set()) & gripper}


def _finish_grasp(rig: _Rig, base: _Rig, saved: Context, run: MethodRun, friction: float,
                  grasps_before: int) -> dict:
    """From a saved shake (a context of ``base``'s diagram), finish the grasp on ``rig``:
    what it did, what the weighing after the shake read, and how far the parts the pads kept
    moved in the gripper's frame over the shake."""
    _resume(rig, base, saved, run, friction)
    context = rig.episode.context
    before = _gripper_frame_positions(base, saved)
    in_pads = _in_pads(base, saved)
    tray = tray_count(rig.episode.pick, context)
    wall = time.perf_counter()
    rig.episode.run(GRASP_LIMIT, pause_at=Mode.WEIGH, step=_step)  # the shake is over
    kept = in_pads & _in_pads(rig, context)
    moved = np.linalg.norm(_gripper_frame_positions(rig, context) - before, axis=1)
    slip = float(max((moved[i] for i in kept), default=float("nan")))
    picks = rig.episode.pick.diagram.GetOutputPort("picks")
    mode = rig.episode.pick.diagram.GetOutputPort("mode")
    held = rig.load_path.GetOutputPort("held_count")
    payload = rig.episode.pick.payload
    weighing = None
    while mode.Eval(context) is Mode.WEIGH:  # the weighing after the shake, and its truth
        estimate = payload.GetOutputPort("payload").Eval(payload.GetMyContextFromRoot(context))
        count = held.Eval(rig.load_path.GetMyContextFromRoot(context))
        weighing = {"weighed": None if not estimate.ready else round(estimate.parts, 3),
                    "held": int(count[0]), "resting": int(count[1])}
        rig.episode.simulator.AdvanceTo(context.get_time() + STEP)
    while len(records := picks.Eval(context)) <= grasps_before:
        if mode.Eval(context) in (Mode.DONE, Mode.STOPPED) \
                or context.get_time() > saved.get_time() + GRASP_LIMIT:
            return {"end": "no record", "in_pads": len(in_pads),
                    "dropped_from_pads": len(in_pads - kept), "slip_mm": round(1e3 * slip, 2)}
        rig.episode.simulator.AdvanceTo(context.get_time() + 0.05)
    record = records[grasps_before]
    # What the grasp released is in the tray once it has landed.
    rig.episode.simulator.AdvanceTo(context.get_time() + 0.5)
    return {"end": record.disposition.name if record.disposition else record.outcome.name,
            "landed": tray_count(rig.episode.pick, context) - tray,
            "recoveries": [r.name for r in record.recoveries], "after_shake": weighing,
            "in_pads": len(in_pads), "dropped_from_pads": len(in_pads - kept),
            "slip_mm": round(1e3 * slip, 2), "wall_s": round(time.perf_counter() - wall, 1)}


def run_pile(rigs: dict[str, _Rig], settler: PileSettler, part: str, seed: int,
             max_shakes: int) -> dict:
    """One pile cleared under the model's physics, each shake finished under every variant."""
    base = rigs["model"]
    settled = settler.settle(seed)
    run = MethodRun("graspability", 0)
    episode = base.episode
    episode.start(settled.state, lambda c: episode.pick.diagram.GetInputPort("method")
                  .FixValue(c, run))
    limit = SIM_LIMIT_PER_PART * settled.report.num_in_bin
    shakes = []
    while len(shakes) < max_shakes:
        result = episode.run(limit - episode.context.get_time(), pause_at=Mode.SHAKE,
                             step=_step)
        if result.end is not RunEnd.PAUSED:
            break
        saved = episode.context.Clone()
        grasps = len(result.records)
        row = {"grasp": grasps, "t": round(saved.get_time(), 3)}
        for name, (friction, fine) in VARIANTS.items():
            if name != "model":
                row[name] = _finish_grasp(rigs["fine" if fine else "model"], base, saved,
                                          run, friction, grasps)
        row["model"] = _finish_grasp(base, base, saved, run, 1.0, grasps)  # goes on from here
        shakes.append(row)
        print(f"  {part} pile {seed}: shake {len(shakes)}: "
              + ", ".join(f"{n} {row[n]['end']}/{row[n].get('landed')}" for n in VARIANTS),
              file=sys.stderr, flush=True)
    return {"part": part, "pile_seed": seed, "shakes": shakes}


def _success(row: dict) -> bool:
    return row["end"] == "DELIVERED" and row.get("landed") == 1


def report(piles: list[dict]) -> None:
    rows = [s for pile in piles for s in pile["shakes"]]
    n = len(rows)
    print(f"{len(piles)} piles, {n} shakes")
    if not n:
        return
    for name in VARIANTS:
        ok = sum(_success(r[name]) for r in rows)
        several = sum(r[name]["end"] == "DELIVERED" and r[name].get("landed", 0) > 1
                      for r in rows)
        low, high = wilson(ok, n)
        agree = sum(_success(r[name]) == _success(r["model"]) for r in rows)
        slips = np.array([r[name]["slip_mm"] for r in rows if "in_pads" in r[name]])
        slips = slips[np.isfinite(slips)]
        slip = (f"slip of the parts kept in the pads over {len(slips)} shakes: median "
                f"{np.median(slips):.2f} mm, max {slips.max():.2f} mm, > 2 mm in "
                f"{int((slips > 2).sum())}") if len(slips) else "no slip measured"
        ends = Counter(r[name]["end"] for r in rows)
        print(f"  {name}: shake left one part, delivered: {ok}/{n} = {100 * ok / n:.1f} % "
              f"[{100 * low:.1f}, {100 * high:.1f}]; several delivered {several}; "
              f"agrees with the model's physics {agree}/{n}; ends {dict(ends)}; {slip}")
        for r in rows:
            if r[name]["end"] == "DELIVERED" and r[name].get("landed", 0) > 1:
                print(f"    several delivered: {r[name]['landed']} landed, the weighing after "
                      f"the shake {r[name].get('after_shake', 'not recorded')}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", default=["u_hook", "s_hook"])
    parser.add_argument("--piles", type=int, default=4, help="piles per part")
    parser.add_argument("--shakes", type=int, default=4, help="at most, per pile")
    parser.add_argument("--seed", type=int, default=1, help="seed of the pile seeds")
    parser.add_argument("--scenario", type=Path, default=diagrams_dir() / "dense_bin.yaml")
    parser.add_argument("--out", type=Path, required=True, help="JSON lines, one per pile")
    args = parser.parse_args()
    done = [json.loads(line) for line in args.out.read_text().splitlines()] \
        if args.out.exists() else []
    finished = {(p["part"], p["pile_seed"]) for p in done}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    method = Method("graspability", "graspability")
    try:
        for part in args.parts:
            scenario = load_scenario(args.scenario)
            scenario = replace(scenario, pile=scenario.pile.alone(part))
            fine_config = copy.deepcopy(scenario.plant_config)
            fine_config.time_step = 0.001
            fine = replace(scenario, plant_config=fine_config)
            rigs = {"model": _rig(scenario, method, part), "fine": _rig(fine, method, part)}
            settler = PileSettler(build_station(scenario), scenario)
            for task in range(args.piles):
                seed = pile_seed(args.seed, task)
                if (part, seed) in finished:
                    continue
                done.append(run_pile(rigs, settler, part, seed, args.shakes))
                with args.out.open("a") as out:
                    out.write(json.dumps(done[-1]) + "\n")
                print(f"{part}: pile {task + 1}/{args.piles} done", file=sys.stderr, flush=True)
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    report(done)
    return 0


if __name__ == "__main__":
    sys.exit(main())
