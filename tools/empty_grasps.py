"""Why do grasps come up empty? Missed at the close, or lost as the part came up?

    python tools/empty_grasps.py --part e_shape [--trial 0] [--scenario floating_gripper.yaml]

Clears one benchmark bin closed loop (the pile of ``bench --clear``'s trial ``--trial``, the
harmonic rule) and watches the fingers' opening (``gripper.state_measured``, what a robot
reads too) every 20 ms from the close to the end of the lift. For each grasp that came up
empty it prints the opening at the end of the close (past ``empty_width``: the fingers held
something) and when, in the lift, they closed on nothing; then how many empty grasps held
something at the close and lost it in the lift, and how many missed.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from dataclasses import dataclass, field

from tangle_drake.bench.clearing import SIM_TIME_PER_PART, clearing_diagram
from tangle_drake.bench.methods import MethodRun
from tangle_drake.bench.runner import BenchOptions, plan
from tangle_drake.bench.trials import method_seed, part_scenario, pile_seed
from tangle_drake.errors import TangleDrakeError
from tangle_drake.pick.diagram import closed_loop_settings
from tangle_drake.pick.episode import POLL, PickEpisode
from tangle_drake.pick.modes import Mode
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.pick.recovery import Disposition
from tangle_drake.pile import PileSettler
from tangle_drake.station import build_station

WATCH = 0.02
"""Simulated seconds between looks at the fingers from the close to the end of the lift."""


@dataclass
class Grasp:
    """The fingers' opening over one grasp: at the end of the close, and the lift's samples."""

    at_close: float | None = None
    lift: list[tuple[float, float]] = field(default_factory=list)


class FingerWatch:
    """``step`` of :func:`~tangle_drake.pick.episode.run_picks`: samples the opening."""

    def __init__(self, episode: PickEpisode) -> None:
        self.episode = episode
        self.port = episode.pick.station.GetOutputPort("gripper.state_measured")
        self.grasps: list[Grasp] = [Grasp()]
        self.mode = Mode.SETTLE
        self.lift_since = 0.0

    def __call__(self, mode: Mode) -> float:
        context = self.episode.simulator.get_context()
        now = context.get_time()
        width = float(self.port.Eval(self.episode.pick.station.GetMyContextFromRoot(
            context))[0])
        grasp = self.grasps[-1]
        if self.mode is Mode.CLOSE and mode is not Mode.CLOSE:
            grasp.at_close, self.lift_since = width, now
        if self.mode is Mode.LIFT or (self.mode is Mode.CLOSE and mode is Mode.LIFT):
            grasp.lift.append((now - self.lift_since, width))
        self.mode = mode
        return WATCH if mode in (Mode.DESCEND, Mode.CLOSE, Mode.LIFT) else POLL

    def ended(self, record: PickRecord) -> None:
        """A grasp's record came: the next samples are the next grasp's."""
        if record.disposition is not None:
            self.grasps.append(Grasp())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", default="e_shape")
    parser.add_argument("--trial", type=int, default=0)
    parser.add_argument("--seed", type=int, default=0, help="the benchmark's run seed")
    parser.add_argument("--scenario", default="floating_gripper.yaml")
    args = parser.parse_args()
    try:
        watch, records, empty_width = clear(args)
    except TangleDrakeError as error:
        sys.exit(f"error: {error}")
    graspings = [r for r in records if r.disposition is not None]
    lost_at, missed = [], 0
    print(f"{args.part} bin {args.trial}: {len(graspings)} grasps; empty width "
          f"{empty_width * 1e3:.1f} mm")
    for record, grasp in zip(graspings, watch.grasps, strict=False):
        if record.disposition is not Disposition.EMPTY or grasp.at_close is None:
            continue
        lost = next((t for t, w in grasp.lift if w < empty_width), None)
        if grasp.at_close < empty_width:
            missed += 1
            what = "closed on nothing at the close"
        elif lost is not None:
            lost_at.append(lost)
            what = f"closed on nothing {lost:.2f} s into the lift"
        else:
            what = "still holding at the lift's end"
        print(f"  grasp {record.index}: {grasp.at_close * 1e3:.1f} mm at the close, {what}")
    empty = sum(r.disposition is Disposition.EMPTY for r in graspings)
    median = f", median {statistics.median(lost_at):.2f} s into the lift" if lost_at else ""
    print(f"{empty} empty: {len(lost_at)} held something at the close and lost it in the "
          f"lift{median}; {missed} missed; {empty - len(lost_at) - missed} lost later")


def clear(args: argparse.Namespace) -> tuple[FingerWatch, list[PickRecord], float]:
    """Clear the benchmark's bin (its scenario and pile, as ``bench --clear`` makes them)
    with the fingers watched; the watch, the records and the empty width."""
    config, _, _ = plan(BenchOptions(methods=["harmonic"], parts=[args.part], trials=1,
                                     seed=args.seed, scenario=args.scenario, clear=True))
    spec = config.parts[0]
    scenario = part_scenario(config, spec)
    pick = clearing_diagram(scenario, config.methods[spec.name], spec.name)
    settled = PileSettler(build_station(scenario), scenario).settle(
        pile_seed(args.seed, spec.name, args.trial))
    episode = PickEpisode(pick)
    run = MethodRun("harmonic", method_seed(args.seed, spec.name, args.trial))
    episode.start(settled.state, lambda context: pick.diagram.GetInputPort("method").FixValue(
        context, run))
    watch = FingerWatch(episode)
    records: list[PickRecord] = []

    def ended(record: PickRecord) -> None:
        records.append(record)
        watch.ended(record)

    episode.run(SIM_TIME_PER_PART * settled.report.num_in_bin, on_pick=ended, step=watch)
    return watch, records, closed_loop_settings(scenario).empty_width


if __name__ == "__main__":
    main()
