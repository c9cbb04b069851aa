"""How high the closed loop's lift goes on the benchmark's piles, and how much higher than
the fixed lift over the rim the hanging-chain rule takes it.

    python tools/lift_heights.py [--parts u_hook j_hook] [--piles 3] [--scenario FILE]

For each part's first ``--piles`` benchmark piles (the pile seeds of ``tangle-drake bench``):
the pile's top as the top camera sees it (``BinContents.top``), the chain the weighing must
see whole (``RecoverySettings.hanging_length``) and where the fingertips end the lift, over
the bin's floor.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from tangle_drake.bench.trials import pile_seed
from tangle_drake.gripper import DEFAULT_GRIPPER
from tangle_drake.parts import BUILTIN_PARTS
from tangle_drake.pick.bin_contents import bin_contents
from tangle_drake.pick.diagram import closed_loop_settings
from tangle_drake.pile import PileSettler
from tangle_drake.planning.grasp_poses import ApproachSettings
from tangle_drake.scenario import PartCount
from tangle_drake.scenario_files import resolve_scenario
from tangle_drake.scene import render_depth
from tangle_drake.station import build_station, camera_model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--parts", nargs="+", default=list(BUILTIN_PARTS))
    parser.add_argument("--piles", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0, help="the benchmark's run seed")
    parser.add_argument("--scenario", default="floating_gripper.yaml")
    args = parser.parse_args()
    base = resolve_scenario(args.scenario)
    tips_below_tcp = DEFAULT_GRIPPER.reach - DEFAULT_GRIPPER.tcp_offset
    fixed = base.bin.wall_height + ApproachSettings().lift_height - tips_below_tcp
    print(f"fixed lift: fingertips {fixed * 100:.1f} cm over the floor")
    for part in args.parts:
        scenario = replace(base, view_cameras=[], pile=replace(
            base.pile, parts=[PartCount(part, base.pile.total_count)]))
        hang = closed_loop_settings(scenario).recovery.hanging_length
        station = build_station(scenario)
        settler = PileSettler(station, scenario)
        for trial in range(args.piles):
            settler.settle(pile_seed(args.seed, part, trial))
            depth = render_depth(station, settler.simulator.get_context())
            top = bin_contents(depth, camera_model(scenario), scenario.bin).top()
            tips = max(fixed, top + hang)
            print(f"{part} pile {trial}: top {top * 100:.1f} cm, chain {hang * 100:.1f} cm, "
                  f"fingertips {tips * 100:.1f} cm over the floor (+{(tips - fixed) * 100:.1f})",
                  flush=True)


if __name__ == "__main__":
    main()
