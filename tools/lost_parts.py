"""Replay one bin of a clearing and show how each part it lost left the bin.

    python tools/lost_parts.py e_shape 3 [--seed 0] [--every 0.1]

Clears bin (part, trial) as ``tangle-drake bench --clear --methods harmonic`` does (same pile,
same seeds, so the same run), looking every ``--every`` simulated seconds instead of the
clearing's 0.5 s, and prints, for each lost part, its centre and the planner's mode from when
it first moved in the grasp it was lost in to when it fell below the bin: enough to tell a part
flung by the fingers from one dragged over a wall or one leaking through the bin's geometry.
"""

from __future__ import annotations

import argparse

import numpy as np

from tangle_drake.bench import clearing
from tangle_drake.bench.runner import BenchOptions, plan
from tangle_drake.bench.trials import part_scenario
from tangle_drake.pick.modes import Mode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("part")
    parser.add_argument("trial", type=int)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--every", type=float, default=0.1, help="simulated s between looks")
    args = parser.parse_args()
    config, _, _ = plan(BenchOptions(methods=["harmonic"], parts=[args.part],
                                     trials=args.trial + 1, clear=True, seed=args.seed,
                                     out="results/lost_parts", workers=1))
    track: list[tuple[int, float, str, np.ndarray]] = []  # (grasps recorded, t, mode, centres)

    class Tracking(clearing.EscapeWatch):
        def __call__(self, mode: Mode) -> float:
            centres = self._pick.station.part_poses(self._context)[:, :3, 3].copy()
            track.append((len(self._grasps), self._context.get_time(), mode.value, centres))
            super().__call__(mode)
            return args.every

    clearing.EscapeWatch = Tracking  # the worker builds its watch from the module
    row = clearing.ClearWorker(config).run_task((0, args.trial))
    run = row["runs"][0]
    print(f"{args.part} bin {args.trial} (pile digest {row['pile']['digest']}): "
          f"{run['delivered']} delivered, {run['left_in_bin']} left, {run['lost']} lost")
    floor = part_scenario(config, config.parts[0]).bin.floor_height
    for escape in run["escapes"]:
        part = escape["part"]
        print(f"part {part}: lost in grasp {escape['grasp'] + 1} ({escape['mode']}, from the "
              f"{escape['source']})")
        grasp = [look for look in track if look[0] == escape["grasp"]]
        start = next((i for i, look in enumerate(grasp)
                      if np.linalg.norm(look[3][part] - grasp[0][3][part]) > 0.003), 0)
        for _, time, mode, centres in grasp[max(start - 3, 0):]:
            print(f"  t={time:7.2f} {mode:10s} centre {np.round(centres[part], 3)}")
            if centres[part][2] < floor - 0.05:
                break


if __name__ == "__main__":
    main()
