"""The top-k oracle of physical-pick data: how far re-ranking graspability's candidates can go.

For each dataset of ``tangle-drake collect --label pick`` (one per part), prints the first-pick
success of graspability alone, of the oracle that picks the best of each pile's candidates,
their gap, and each rank's success rate (:mod:`tangle_drake.tangle_data.ceiling`).

    python tools/pick_ceiling.py data/picks_u_hook data/picks_c_ring ... [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from tangle_drake.dataset import load_samples, read_manifest
from tangle_drake.errors import TangleDrakeError
from tangle_drake.tangle_data.ceiling import pick_ceiling


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="+", type=Path, help="physical-pick dataset directories")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    rows = {}
    print("| part | piles | graspability [95 % CI] | top-k oracle [95 % CI] | gap | by rank |")
    print("|---|---|---|---|---|---|")
    for directory in args.data:
        try:
            if read_manifest(directory).get("label") != "pick":
                raise TangleDrakeError(f"{directory} is not physical-pick data (collect "
                                       "--label pick)")
            ceiling = pick_ceiling(load_samples(directory, ("task", "rank", "outcome")))
        except (TangleDrakeError, ValueError) as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        part = read_manifest(directory).get("part", directory.name)
        rows[part] = asdict(ceiling)

        def rate(value: float, interval: tuple[float, float]) -> str:
            return f"{100 * value:.1f} % [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"

        ranks = ", ".join(f"{r}: {100 * s:.0f} %" for r, (s, _) in ceiling.by_rank.items())
        print(f"| {part} | {ceiling.piles} | "
              f"{rate(ceiling.graspability, ceiling.graspability_interval)} | "
              f"{rate(ceiling.oracle, ceiling.oracle_interval)} | "
              f"{100 * ceiling.gap:+.1f} | {ranks} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
