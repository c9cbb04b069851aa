"""Example: the project's systems in a diagram of your own, with a free-floating gripper.

No Nextage here: the parallel-jaw gripper hangs from a 4-axis gantry
(``tangle_drake.floating_gripper``: x, y, z slides and a yaw turn, so it always points
straight down), over a smaller bin under a camera placed differently from the station's. The
pick diagram is the project's own (``build_pick_diagram``: ``GraspabilitySystem``,
``TangleCnnSystem`` given a model, ``PickPlanner``, ``LiftMonitor``); only the station and the
planner's ``Motion`` differ: ``GantryMotion`` turns a grasp pose straight into gantry
coordinates, where the Nextage's ``ArmMotion`` solves IK.

    python tools/example_floating_gripper.py [--picks 2] [--parts 6] [--seed 0]
                                            [--model PATH] [--rule harmonic]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from pydrake.systems.analysis import Simulator
from pydrake.systems.sensors import CameraConfig

from tangle_drake.floating_gripper import GantryMotion, build_floating_station
from tangle_drake.pick.demo import empty_width
from tangle_drake.pick.diagram import build_pick_diagram
from tangle_drake.pick.outcome import PickRecord, summarize
from tangle_drake.pick.planner import Mode, PickSettings
from tangle_drake.pick.selection import resolve_tangle_choice
from tangle_drake.pile import PileDropper
from tangle_drake.scenario import BinConfig, PartCount, PileConfig, Scenario
from tangle_drake.station import PLANT_NAME


def example_scenario(parts: int) -> Scenario:
    """A wider, shallower bin than the station's, further from the origin, under a camera
    0.6 m up with a narrower view and a smaller image."""
    camera = CameraConfig(name="camera", width=480, height=360, rgb=False, depth=True,
                          label=False, z_near=0.05, z_far=2.0,
                          renderer_class="RenderEngineVtk")
    camera.focal = CameraConfig.FovDegrees(y=40)
    return Scenario(bin=BinConfig(center=[0.6, 0.0], floor_height=0.85,
                                  inner_size=[0.22, 0.22], wall_height=0.06),
                    pile=PileConfig(parts=[PartCount("u_hook", parts)], seed=0),
                    camera=camera, camera_height=0.6)


def run(picks: int = 2, parts: int = 6, seed: int = 0, model: str | None = None,
        rule: str | None = None) -> list[PickRecord]:
    """Build, drop a pile, pick; prints each pick and returns the records."""
    start = time.perf_counter()
    scenario = example_scenario(parts)
    choice = resolve_tangle_choice("u_hook", rule, model)
    if choice.notice:
        print(choice.notice)
    station = build_floating_station(scenario)
    state, _ = PileDropper(station, scenario).drop(seed)  # the gantry parked at home

    settings = PickSettings(max_picks=picks, empty_width=empty_width(scenario.pile))
    pick = build_pick_diagram(scenario, choice, GantryMotion(scenario.bin), station=station,
                              settings=settings, seed=seed)
    diagram = pick.diagram
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant = station.GetSubsystemByName(PLANT_NAME)
    plant.SetPositionsAndVelocities(plant.GetMyMutableContextFromRoot(context), state)
    simulator.Initialize()
    mode, records = diagram.GetOutputPort("mode"), diagram.GetOutputPort("picks")
    shown = 0
    while mode.Eval(context) is not Mode.DONE and context.get_time() < 30.0 * picks:
        simulator.AdvanceTo(context.get_time() + 0.5)
        for record in records.Eval(context)[shown:]:
            print(record.describe())
            shown += 1
    result = list(records.Eval(context))
    print(f"{summarize(result)}; wall time {time.perf_counter() - start:.0f} s")
    return result


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
