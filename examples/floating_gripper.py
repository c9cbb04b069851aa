"""Example: the project's systems in a diagram of your own, with a free-floating gripper.

No Nextage here: the parallel-jaw gripper hangs from a 4-axis gantry (the shipped
``diagrams/floating_gripper.yaml``: x, y, z slides and a yaw turn, so it always points
straight down), over a smaller bin under a camera placed differently from the station's. The
station comes from that scenario with its bin, camera and pile changed in code (a YAML file
of your own does the same); the pick diagram is the project's own (``build_pick_diagram``:
``GraspabilitySystem``, ``TangleCnnSystem`` given a model, ``PickPlanner``, ``LiftMonitor``).
Only the planner's ``Motion`` differs, and the scenario's carrier chooses it
(``motion_for``): ``GantryMotion`` turns a grasp pose straight into gantry coordinates, where
the Nextage's ``ArmMotion`` solves IK.

    python examples/floating_gripper.py [--picks 2] [--parts 6] [--seed 0]
                                            [--model PATH] [--rule harmonic]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import replace

from pydrake.systems.sensors import CameraConfig

from tangle_drake.episode.run import PickEpisode
from tangle_drake.pick.diagram import build_pick_diagram, pick_settings
from tangle_drake.pick.outcome import PickRecord, summarize
from tangle_drake.planning.motions import motion_for
from tangle_drake.scenario import BinConfig, PartCount, PileConfig, Scenario
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.choice import resolve_tangle_choice
from tangle_drake.selection.methods import fixed_selection
from tangle_drake.station import build_station
from tangle_drake.station.pile import settle_pile


def example_scenario(parts: int) -> Scenario:
    """The shipped floating-gripper scenario with a wider, shallower bin, further from the
    origin, under a camera 0.6 m up with a narrower view and a smaller image."""
    camera = CameraConfig(name="camera", width=480, height=360, rgb=False, depth=True,
                          label=False, z_near=0.05, z_far=2.0,
                          renderer_class="RenderEngineVtk")
    camera.focal = CameraConfig.FovDegrees(y=40)
    return replace(resolve_scenario("floating_gripper.yaml"),
                   bin=BinConfig(center=[0.6, 0.0], floor_height=0.85,
                                 inner_size=[0.22, 0.22], wall_height=0.06),
                   pile=PileConfig(parts=[PartCount("u_hook", parts)], seed=0),
                   camera=camera, camera_height=0.6, view_cameras=[])


def run(picks: int = 2, parts: int = 6, seed: int = 0, model: str | None = None,
        rule: str | None = None) -> list[PickRecord]:
    """Build, drop a pile, pick; prints each pick and returns the records."""
    start = time.perf_counter()
    scenario = example_scenario(parts)
    choice = resolve_tangle_choice("u_hook", rule, model)
    if choice.notice:
        print(choice.notice)
    station = build_station(scenario)
    pile = settle_pile(station, scenario, seed)  # the gantry parked at home

    pick = build_pick_diagram(scenario, motion_for(scenario),
                              fixed_selection(choice, scenario, seed), station=station,
                              settings=pick_settings(scenario, max_picks=picks))
    episode = PickEpisode(pick)
    episode.start(pile.state)
    run = episode.run(30.0 * picks, on_pick=lambda record: print(record.describe()))
    print(f"{summarize(run.records)}; wall time {time.perf_counter() - start:.0f} s")
    return run.records


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--picks", type=int, default=2)
    parser.add_argument("--parts", type=int, default=6, help="U-hooks in the pile")
    parser.add_argument("--seed", type=int, default=0, help="pile seed")
    parser.add_argument("--model", default=None, help="tangle CNN checkpoint")
    parser.add_argument("--rule", default=None, help="selection rule")
    args = parser.parse_args(argv)
    run(args.picks, args.parts, args.seed, args.model, args.rule)
    return 0


if __name__ == "__main__":
    sys.exit(main())
