"""Do faster physics settings pick what the shipped ones pick?

For each pile (the physical-pick data's pile seeds, not the benchmark's) and each of
graspability's first ``--top-k`` candidates, picks three times from the same settled pile
under the model's physics: with the scenario as shipped (or under ``--old`` overlays: the
settings compared against), the same with the grasp moved 0.1 mm (the simulator's own re-run
agreement: contact is chaotic, a pick's outcome is a draw), and with the scenario under
``--new`` overlays (e.g. ``simulation: {pick_time_step: 0.003,
freeze_beyond_radii: 2}``), with ``--fast`` as the physical-pick data's fast pick
(:meth:`~tangle_drake.episode.episode.Episode.single_pick`). Prints, against the shipped
pick, each one's outcome agreement with its 95 % interval and the new settings' against the
re-run's (McNemar); McNemar's test of a one-sided shift of the new settings on several-vs-not
and none-vs-not (the tangled label is several); the parts that left the bin; each one's CPU
seconds per pick; and the verdict: the new settings pass where none of those differs at
p < 0.05 against them. One JSON line per pile in
``--out`` after a first line naming the settings: run the same command again to resume;
other settings are refused. ``--baseline FILE``: an earlier check of the same part, piles and
``--top-k`` gives the shipped and re-run picks of its piles, so only the new ones run.

    python tools/physics_agreement.py --part e_shape --piles 40 \\
        --new "simulation: {pick_time_step: 0.003, freeze_beyond_radii: 2}" --out FILE
    python tools/physics_agreement.py --part u_hook --piles 8 --fast --out FILE
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.failures import FailureKind
from tangle_drake.common.stats import paired_difference, wilson
from tangle_drake.episode.episode import Episode, PhysicalPick
from tangle_drake.pick.outcome import Outcome
from tangle_drake.planning.motions import scenario_mode
from tangle_drake.scenario.files import scenario_source
from tangle_drake.selection.methods import Method, MethodRun
from tangle_drake.station.bin_model import inside_bin
from tangle_drake.tangle_data.physical import PICK_SCENARIO, PickDataSettings, pick_data_scenario
from tangle_drake.tangle_data.seeds import pile_seed

RERUN_OFFSET = (1e-4, 0.0, 0.0)
"""The re-run's grasp error (x, y in m, degrees): 0.1 mm, far below anything a robot holds."""
KINDS = ("shipped", "rerun", "new")
ALPHA = 0.05
"""A difference counts where a paired test gives p below this."""


def escaped(rig: Episode, pick: PhysicalPick) -> int:
    """Parts outside the bin after the pick, less those it brought up."""
    station = rig.pick_diagram.station
    centres = station.part_poses(rig.episode.context)[:, :3, 3]
    out = int((~inside_bin(rig.scenario.bin, centres)).sum())
    lifted = pick.record.truth.lifted if pick.record is not None else None
    return max(0, out - (lifted or 0))


def run_pile(rigs: dict[str, Episode], settings: PickDataSettings, task: int,
             baseline: dict | None = None) -> dict:
    """One pile's picks: per rank, each kind's outcome, escaped parts and CPU seconds (the
    shipped and re-run ones from ``baseline``, the same pile's earlier check, if given)."""
    seed = pile_seed(settings.seed, task)
    kinds = KINDS if baseline is None else ("new",)
    states = {rig: rigs[rig].settle(seed).state
              for rig in (("shipped", "new") if baseline is None else ("new",))}
    earlier = {} if baseline is None else {row["rank"]: row for row in baseline["ranks"]}
    ranks = []
    for rank in range(settings.top_k):
        row: dict = {"rank": rank}
        if baseline is not None:
            if rank not in earlier:
                break  # the shipped pick found no candidate here
            row.update({key: value for key, value in earlier[rank].items()
                        if not key.startswith("new")})
        for kind in kinds:
            rig = rigs["new" if kind == "new" else "shipped"]
            run = MethodRun("graspability", 0, only=rank,
                            offset=RERUN_OFFSET if kind == "rerun" else None)
            cpu = time.process_time()
            pick = rig.pick(states["new" if kind == "new" else "shipped"], run)
            record = pick.record
            row[kind] = "timeout" if record is None else (
                record.failure.value if record.failure else record.outcome.value)
            row[f"{kind}_cpu_s"] = round(time.process_time() - cpu, 3)
            row[f"{kind}_escaped"] = escaped(rig, pick)
            if record is not None and record.failure is FailureKind.NO_CANDIDATE:
                return {"task": task, "pile_seed": seed, "ranks": ranks}
        ranks.append(row)
    return {"task": task, "pile_seed": seed, "ranks": ranks}


def report(identity: dict, piles: list[dict]) -> None:
    rows = [r for pile in piles for r in pile["ranks"]]
    n = len(rows)
    print(f"{identity['part']}: {len(piles)} piles, {n} paired picks; new: {identity['new']}"
          + (", the fast pick" if identity["fast"] else ""))
    for kind in ("rerun", "new"):
        agree = sum(r[kind] == r["shipped"] for r in rows)
        low, high = wilson(agree, n)
        print(f"  {kind} agrees with shipped: {agree}/{n} = {100 * agree / max(n, 1):.1f} % "
              f"[{100 * low:.1f}, {100 * high:.1f}]")
    agreement = paired_difference([r["new"] == r["shipped"] for r in rows],
                                  [r["rerun"] == r["shipped"] for r in rows])
    print(f"  new against re-run agreement: {agreement.a_only} picks only new agrees, "
          f"{agreement.b_only} only the re-run (McNemar p = {agreement.p_value:.3f})")
    failures = []
    if agreement.difference < 0 and agreement.p_value < ALPHA:
        failures.append("agrees less often than the re-run")
    for outcome in (Outcome.SEVERAL, Outcome.NONE):
        test = paired_difference([r["new"] == outcome.value for r in rows],
                                 [r["shipped"] == outcome.value for r in rows])
        print(f"  {outcome.value} vs not: new {100 * test.rate_a:.1f} %, shipped "
              f"{100 * test.rate_b:.1f} % ({test.a_only} only new, {test.b_only} only shipped; "
              f"McNemar p = {test.p_value:.3f})")
        if test.p_value < ALPHA:
            failures.append(f"shifts {outcome.value} one way")
    escapes = paired_difference([r["new_escaped"] > 0 for r in rows],
                                [r["shipped_escaped"] > 0 for r in rows])
    if escapes.difference > 0 and escapes.p_value < ALPHA:
        failures.append("pushes parts out of the bin more often")
    for kind in KINDS:
        counts = Counter(r[kind] for r in rows)
        rates = ", ".join(f"{name} {100 * c / max(n, 1):.1f} %"
                          for name, c in sorted(counts.items()))
        cpu = sum(r[f"{kind}_cpu_s"] for r in rows)
        print(f"  {kind}: {rates}; {sum(r[f'{kind}_escaped'] for r in rows)} parts left the "
              f"bin; {cpu / max(n, 1):.2f} CPU s per pick")
    shipped = sum(r["shipped_cpu_s"] for r in rows)
    print(f"  speed: new {shipped / max(sum(r['new_cpu_s'] for r in rows), 1e-9):.2f}x shipped "
          "(CPU)")
    print("  verdict: " + (f"fails: it {', '.join(failures)} (p < {ALPHA})" if failures else
                           f"passes at p < {ALPHA}: agreement no lower than the re-run's, no "
                           "one-sided shift, no more parts out of the bin"))


def read_baseline(path: Path | None, identity: dict) -> dict[int, dict]:
    """An earlier check's piles by task; refused unless of the same part, piles and top-k."""
    if path is None:
        return {}
    try:
        first, *piles = path.read_text().splitlines()
    except (OSError, ValueError) as error:
        raise TangleDrakeError(f"--baseline {path}: cannot read a check there") from error
    same = ("part", "top_k", "seed", "old")
    if any(json.loads(first).get(key) != identity.get(key) for key in same):
        raise TangleDrakeError(f"--baseline {path} checked other piles: {first}")
    return {pile["task"]: pile for pile in map(json.loads, piles)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="u_hook")
    parser.add_argument("--piles", type=int, default=20)
    parser.add_argument("--top-k", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0, help="collection seed of the piles")
    parser.add_argument("--new", action="append", default=[], metavar="YAML",
                        help="an overlay of the new settings (repeatable)")
    parser.add_argument("--old", action="append", default=[], metavar="YAML",
                        help="an overlay of the settings compared against (repeatable; "
                             "default: as shipped)")
    parser.add_argument("--fast", action="store_true",
                        help="the new side picks as collect --label pick does")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="an earlier check of the same piles: its shipped picks")
    parser.add_argument("--out", type=Path, required=True,
                        help="JSON lines: the settings, then one line per pile")
    args = parser.parse_args()
    identity = {"part": args.part, "top_k": args.top_k, "seed": args.seed, "new": args.new,
                "fast": args.fast, **({"old": args.old} if args.old else {})}
    try:
        settings = PickDataSettings(args.part, top_k=args.top_k, seed=args.seed, physics=None)
        shipped = pick_data_scenario(scenario_source(PICK_SCENARIO, args.old).text(), settings)
        new = pick_data_scenario(scenario_source(PICK_SCENARIO, args.new).text(), settings)
        floating = scenario_mode(shipped, "the scenario") == "floating"
        methods = [Method("graspability", "graspability")]
        rigs = {"shipped": Episode.single_pick(shipped, methods, args.part, floating),
                "new": Episode.single_pick(new, methods, args.part, floating, fast=args.fast)}
        lines = args.out.read_text().splitlines() if args.out.exists() else []
        if lines and json.loads(lines[0]) != identity:
            raise TangleDrakeError(f"{args.out} holds a check of other settings: "
                                   f"{lines[0]}; use another --out")
        baseline = read_baseline(args.baseline, identity)
    except TangleDrakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    done = [json.loads(line) for line in lines[1:]]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("a") as out:
        if not lines:
            out.write(json.dumps(identity) + "\n")
        for task in range(len(done), args.piles):
            done.append(run_pile(rigs, settings, task, baseline.get(task)))
            out.write(json.dumps(done[-1]) + "\n")
            out.flush()
            print(f"pile {task + 1}/{args.piles}", file=sys.stderr, flush=True)
    report(identity, done)
    return 0


if __name__ == "__main__":
    sys.exit(main())
