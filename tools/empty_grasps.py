"""Why do grasps come up empty? Missed at the close, or lost as the part came up?

    python tools/empty_grasps.py --part e_shape [--trial 0] [--scenario floating_gripper.yaml]

Clears one benchmark bin closed loop (the pile of ``bench --clear``'s trial ``--trial``, the
harmonic rule) and watches the fingers' opening (``gripper.state_measured``, what a robot
reads too) every 20 ms from the close to the end of the lift. For each grasp that came up
empty it prints the opening at the end of the close (past ``empty_width``: the fingers held
something) and when, in the lift, they closed on nothing; then how many empty grasps held
something at the close.
"""

from __future__ import annotations

import argparse
import statistics
from dataclasses import dataclass, field, replace

from tangle_drake.bench.clearing import SIM_TIME_PER_PART, clearing_diagram
from tangle_drake.bench.methods import MethodRun, parse_method
from tangle_drake.bench.trials import method_seed, pile_seed
from tangle_drake.pick.diagram import closed_loop_settings
from tangle_drake.pick.episode import POLL, PickEpisode
from tangle_drake.pick.modes import Mode
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.pick.recovery import Disposition
from tangle_drake.pile import PileSettler
from tangle_drake.scenario import PartCount
from tangle_drake.scenario_files import resolve_scenario
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
    base = resolve_scenario(args.scenario)
    scenario = replace(base, view_cameras=[], pile=replace(
        base.pile, parts=[PartCount(args.part, base.pile.total_count)]))
    pick = clearing_diagram(scenario, [parse_method("harmonic")], args.part)
    settled = PileSettler(build_station(scenario), scenario).settle(
        pile_seed(args.seed, args.part, args.trial))
    episode = PickEpisode(pick)
    run = MethodRun("harmonic", method_seed(args.seed, args.part, args.trial))
    episode.start(settled.state, lambda context: pick.diagram.GetInputPort("method").FixValue(
        context, run))
    empty_width = closed_loop_settings(scenario).empty_width
    watch = FingerWatch(episode)
    records: list[PickRecord] = []

    def ended(record: PickRecord) -> None:
        records.append(record)
        watch.ended(record)

    episode.run(SIM_TIME_PER_PART * settled.report.num_in_bin, on_pick=ended, step=watch)
    graspings = [r for r in records if r.disposition is not None]
    held, lost_at = 0, []
    print(f"{args.part} bin {args.trial}: {len(graspings)} grasps; empty width "
          f"{empty_width * 1e3:.1f} mm")
    for record, grasp in zip(graspings, watch.grasps, strict=False):
        if record.disposition is not Disposition.EMPTY or grasp.at_close is None:
            continue
        lost = next((t for t, w in grasp.lift if w < empty_width), None)
        held += grasp.at_close >= empty_width
        if grasp.at_close >= empty_width and lost is not None:
            lost_at.append(lost)
        print(f"  grasp {record.index}: {grasp.at_close * 1e3:.1f} mm at the close, "
              + ("closed on nothing at the close" if grasp.at_close < empty_width else
                 f"closed on nothing {lost:.2f} s into the lift" if lost is not None else
                 "still holding at the lift's end"))
    empty = sum(r.disposition is Disposition.EMPTY for r in graspings)
    median = f", median {statistics.median(lost_at):.2f} s into the lift" if lost_at else ""
    print(f"{empty} empty: {held} held something at the close and lost it{median}; "
          f"{empty - held} missed")


if __name__ == "__main__":
    main()
