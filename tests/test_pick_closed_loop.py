"""The closed loop of the pick state machine, with a stand-in manipulator and a stand-in scale:
several => shake => one => delivered; several => shake => several => put back; nothing => a
fresh look elsewhere; not sure => weighed again; K grasps without a delivery => stir the bin,
and after the stirs => give up; nothing to pick in a bin that is not empty => stir; the
put-back stops where the load rests on the pile. And the rules alone."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource
from test_pick_planner import FakeMotion, candidate

from tangle_drake.common.failures import FailureKind
from tangle_drake.pick.bin_contents import BinContents
from tangle_drake.pick.payload import PayloadEstimate, PayloadPhase, PayloadRequest
from tangle_drake.pick.planner import Mode, PickPlanner, PickSettings
from tangle_drake.pick.recovery import (
    Disposition,
    Recovery,
    RecoverySettings,
    Verdict,
    after_put_back,
    after_weighing,
    judge,
)
from tangle_drake.scenario import BinConfig

PART_WEIGHT = 0.32
GRIPPER = 4.22


class FakeScale(LeafSystem):
    """Answers each new weighing request with the next of ``weighings`` (a count, or None for
    a weighing that cannot be trusted); tares at once. Also plays the wrist sensor, whose
    support drops by ``rest_drop`` N once the planner has been putting back for 0.3 s."""

    def __init__(self, weighings, rest_drop: float = 0.0,
                 push: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        super().__init__()
        self.weighings = list(weighings)
        self.answers: dict[int, PayloadEstimate] = {}
        self.rest_drop = rest_drop
        self.push = push
        self.stir_since = None
        self.request = self.DeclareAbstractInputPort("request",
                                                     AbstractValue.Make(PayloadRequest()))
        self.mode = self.DeclareAbstractInputPort("mode", AbstractValue.Make(Mode.SETTLE))
        self.put_back_since = None
        self.DeclareAbstractOutputPort("payload", lambda: AbstractValue.Make(PayloadEstimate()),
                                       self._calc)
        self.DeclareVectorOutputPort("wrench", 6, self._wrench, {self.time_ticket(),
                                                                 self.all_input_ports_ticket()})

    def _calc(self, context, value) -> None:
        request = self.request.Eval(context)
        if request.phase is PayloadPhase.TARE:
            value.set_value(PayloadEstimate(tared=True))
        elif request.phase is PayloadPhase.WEIGH:
            if request.serial not in self.answers:
                count = self.weighings.pop(0) if self.weighings else 0
                self.answers[request.serial] = PayloadEstimate(
                    ready=True, parts=float(count if count is not None else 1.5),
                    count=1 if count is None else count, std=0.02,
                    confidence=0.5 if count is None else 0.99, trusted=count is not None,
                    samples=20, support=GRIPPER + PART_WEIGHT * (count or 0),
                    part_weight=PART_WEIGHT)
            value.set_value(self.answers[request.serial])
        else:
            value.set_value(PayloadEstimate())

    def _wrench(self, context, out) -> None:
        putting_back = self.mode.Eval(context) is Mode.PUT_BACK
        if putting_back and self.put_back_since is None:
            self.put_back_since = context.get_time()
        resting = putting_back and context.get_time() - self.put_back_since > 0.3
        stirring = self.mode.Eval(context) is Mode.STIR
        if stirring and self.stir_since is None:
            self.stir_since = context.get_time()
        force, start, end = self.push
        pushing = stirring and start < context.get_time() - self.stir_since < end
        out.SetFromVector([force if pushing else 0.0, 0,
                           GRIPPER + 2 * PART_WEIGHT - (self.rest_drop if resting else 0),
                           0, 0, 0])


class SlippingGripper(LeafSystem):
    """``gripper.state_measured`` of fingers that hold a 3 mm wire, but in the first lift
    only until ``slip_after`` s into it: then they close on nothing (the part slid out)."""

    def __init__(self, slip_after: float) -> None:
        super().__init__()
        self.slip_after = slip_after
        self.lift_since = None
        self.lifts = 0
        self.mode = self.DeclareAbstractInputPort("mode", AbstractValue.Make(Mode.SETTLE))
        self.DeclareVectorOutputPort("width", 2, self._calc, {self.time_ticket(),
                                                              self.all_input_ports_ticket()})

    def _calc(self, context, out) -> None:
        mode, t = self.mode.Eval(context), context.get_time()
        if mode is Mode.LIFT and self.lift_since is None:
            self.lift_since, self.lifts = t, self.lifts + 1
        elif mode is Mode.APPROACH:
            self.lift_since = None
        slipped = self.lifts == 1 and self.lift_since is not None \
            and t - self.lift_since >= self.slip_after
        out.SetFromVector([0.0005 if slipped else 0.003, 0.0])


def run(candidates, weighings, motion=None, width=0.003, picks=1, rest_drop=0.0,
        recovery=None, duration=60.0, contents=None, push=(0.0, 0.0, 0.0), log=None,
        slip_after=None, commands=None):
    motion = motion or FakeMotion()
    settings = PickSettings(max_picks=picks, recovery=recovery or RecoverySettings())
    builder = DiagramBuilder()
    planner = builder.AddSystem(PickPlanner(motion, settings))
    source = builder.AddSystem(_Candidates(candidates))
    builder.Connect(source.get_output_port(), planner.GetInputPort("candidates"))
    if contents is not None:
        view = builder.AddSystem(ConstantValueSource(AbstractValue.Make(contents)))
        builder.Connect(view.get_output_port(), planner.GetInputPort("bin_contents"))
    measured = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    builder.Connect(measured.get_output_port(), planner.GetInputPort("arm.state_measured"))
    if slip_after is None:
        gripper = builder.AddSystem(ConstantVectorSource(np.array([width, 0.0])))
    else:
        gripper = builder.AddSystem(SlippingGripper(slip_after))
        builder.Connect(planner.GetOutputPort("mode"), gripper.GetInputPort("mode"))
    builder.Connect(gripper.get_output_port(), planner.GetInputPort("gripper.state_measured"))
    scale = builder.AddSystem(FakeScale(weighings, rest_drop, push))
    builder.Connect(planner.GetOutputPort("payload.request"), scale.GetInputPort("request"))
    builder.Connect(planner.GetOutputPort("mode"), scale.GetInputPort("mode"))
    builder.Connect(scale.GetOutputPort("payload"), planner.GetInputPort("payload"))
    builder.Connect(scale.GetOutputPort("wrench"), planner.GetInputPort("wrist.force_torque"))
    simulator = Simulator(builder.Build())
    context = planner.GetMyContextFromRoot(simulator.get_context())
    scale_context = scale.GetMyContextFromRoot(simulator.get_context())
    modes, times = [], {}
    while simulator.get_context().get_time() < duration:
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.01)
        scale.GetOutputPort("wrench").Eval(scale_context)  # (they note when a mode begins)
        if slip_after is not None:
            gripper.get_output_port().Eval(gripper.GetMyContextFromRoot(simulator.get_context()))
        mode = planner.GetOutputPort("mode").Eval(context)
        if commands is not None:
            commands.append(planner.GetOutputPort(motion.command_port).Eval(context).copy())
        if not modes or modes[-1] is not mode:
            modes.append(mode)
            times.setdefault(mode, simulator.get_context().get_time())
            if log is not None:
                log.append((mode, simulator.get_context().get_time()))
        if mode is Mode.DONE:
            break
    return planner.GetOutputPort("picks").Eval(context), modes, motion, times


class _Candidates(LeafSystem):
    def __init__(self, candidates) -> None:
        super().__init__()
        self.DeclareAbstractOutputPort("candidates", lambda: AbstractValue.Make([]),
                                       lambda c, v: v.set_value(list(candidates)))


def test_several_are_shaken_and_one_left_is_delivered():
    records, modes, motion, _ = run([candidate(0, 0.9)], [2, 1])
    (record,) = records
    assert record.verdict is Verdict.SEVERAL and record.estimate.count == 2
    assert record.recoveries == [Recovery.SHAKE] and record.disposition is Disposition.DELIVERED
    assert motion.shakes == 1
    assert modes[:12] == [Mode.SETTLE, Mode.PERCEIVE, Mode.APPROACH, Mode.TARE, Mode.DESCEND,
                          Mode.CLOSE, Mode.LIFT, Mode.WEIGH, Mode.SHAKE, Mode.WEIGH,
                          Mode.TRANSFER, Mode.RELEASE]
    assert modes[-1] is Mode.DONE


def test_several_after_a_shake_are_put_back_and_the_gripper_weighed_open():
    records, modes, motion, _ = run([candidate(0, 0.9), candidate(1, 0.8)], [2, 2, 0, 1])
    first, second = records
    assert first.recoveries == [Recovery.SHAKE, Recovery.PUT_BACK]
    assert first.disposition is Disposition.PUT_BACK and motion.lowered == 1
    for mode in (Mode.PUT_BACK, Mode.OPEN, Mode.WEIGH_OPEN, Mode.RAISE, Mode.RETREAT):
        assert mode in modes
    assert second.disposition is Disposition.DELIVERED  # then it goes on


def test_a_part_hooked_on_an_open_finger_is_shaken_off():
    records, _, motion, _ = run([candidate(0, 0.9), candidate(1, 0.8)], [2, 2, 1, 0, 1])
    assert records[0].recoveries == [Recovery.SHAKE, Recovery.PUT_BACK, Recovery.SHAKE_OFF]
    assert motion.shakes == 2 and records[0].disposition is Disposition.PUT_BACK


def test_nothing_came_up_and_the_next_look_goes_elsewhere():
    motion = FakeMotion()
    records, modes, _, _ = run([candidate(0, 0.9), candidate(1, 0.5)], [0, 1], motion)
    first, second = records
    assert first.verdict is Verdict.NONE and first.disposition is Disposition.EMPTY
    assert Mode.RETREAT in modes and Mode.TRANSFER in modes
    assert motion.planned == [0, 1]  # the same spot is not tried again
    assert second.rejected[0].kind is FailureKind.REPEAT
    assert second.disposition is Disposition.DELIVERED


def test_fingers_closed_on_nothing_back_out_at_once_without_weighing():
    records, modes, _, times = run([candidate(i, 0.9 - 0.1 * i) for i in range(3)], [],
                                   width=0.0005, recovery=RecoverySettings(max_attempts=2))
    assert [r.disposition for r in records[:2]] == [Disposition.EMPTY] * 2
    assert Mode.WEIGH not in modes and times[Mode.RETREAT] - times[Mode.LIFT] < 0.05
    assert "closed on nothing" in records[0].reason


def test_a_part_that_slides_out_early_in_the_lift_backs_out_the_way_it_came():
    commands, log = [], []
    records, modes, _, times = run([candidate(0, 0.9), candidate(1, 0.8)], [1],
                                   slip_after=0.1, commands=commands, log=log)
    first, second = records
    assert first.disposition is Disposition.EMPTY and first.verdict is Verdict.NONE
    assert "backed out" in first.reason and second.disposition is Disposition.DELIVERED
    assert first.recoveries == [Recovery.BACK_OUT] and "| backed out, empty |" in first.describe()
    assert times[Mode.RETREAT] - times[Mode.LIFT] == pytest.approx(0.1, abs=0.03)
    assert modes.index(Mode.RETREAT) < modes.index(Mode.WEIGH)  # the first grasp is not weighed
    # The command turns back without a jump: no step larger than the moves' own (~1 rad/s).
    steps = np.abs(np.diff(np.array(commands), axis=0)).max()
    assert steps < 0.02
    # ... and the next look comes sooner than after lifting on, weighing nothing, going home.
    weighed_log = []
    run([candidate(0, 0.9), candidate(1, 0.8)], [0, 1], log=weighed_log)
    second_look = [[t for mode, t in entries if mode is Mode.PERCEIVE][1]
                   for entries in (log, weighed_log)]
    assert second_look[0] < second_look[1] - 1.0


def test_a_part_that_slides_out_past_the_slow_stretch_is_found_at_the_top():
    records, modes, _, times = run([candidate(0, 0.9), candidate(1, 0.8)], [1],
                                   slip_after=0.5)
    first = records[0]
    assert first.disposition is Disposition.EMPTY and "backed out" not in (first.reason or "")
    assert first.recoveries == []
    assert modes[modes.index(Mode.LIFT) + 1] is Mode.WEIGH
    assert times[Mode.RETREAT] - times[Mode.WEIGH] < 0.05  # closed fingers need no weighing


def test_a_doubtful_weighing_is_repeated_and_a_lasting_doubt_is_never_delivered():
    records, _, _, _ = run([candidate(0, 0.9)], [None, 1])
    assert records[0].recoveries == [Recovery.REWEIGH]
    assert records[0].disposition is Disposition.DELIVERED
    records, _, _, _ = run([candidate(0, 0.9), candidate(1, 0.8)], [None, None, None, 2, 0, 1])
    assert records[0].recoveries == [Recovery.REWEIGH, Recovery.REWEIGH, Recovery.SHAKE,
                                     Recovery.PUT_BACK]


def test_k_grasps_without_a_delivery_give_up_with_a_clear_record():
    records, modes, _, _ = run([candidate(i, 0.9 - 0.05 * i) for i in range(6)],
                               [0] * 6, recovery=RecoverySettings(max_attempts=3), picks=5)
    assert [r.disposition for r in records[:3]] == [Disposition.EMPTY] * 3
    last = records[-1]
    assert len(records) == 4 and last.failure is FailureKind.GAVE_UP
    assert "3 grasps in a row" in last.reason and modes[-1] is Mode.DONE


def test_the_put_back_stops_where_the_load_rests_on_the_pile():
    _, _, _, free = run([candidate(0, 0.9), candidate(1, 0.8)], [2, 2, 0, 1])
    _, _, _, resting = run([candidate(0, 0.9), candidate(1, 0.8)], [2, 2, 0, 1],
                           rest_drop=0.5)
    # The fake lowering takes ~1.1 s; with the load resting after 0.3 s it opens sooner.
    assert resting[Mode.OPEN] - resting[Mode.PUT_BACK] < 0.5
    assert free[Mode.OPEN] - free[Mode.PUT_BACK] > 1.0


@pytest.mark.parametrize(("width", "estimate", "verdict"), [
    (0.0005, PayloadEstimate(ready=True, count=1, trusted=True), Verdict.NONE),
    (0.003, None, Verdict.UNSURE),
    (0.003, PayloadEstimate(ready=True, count=1, trusted=False), Verdict.UNSURE),
    (0.003, PayloadEstimate(ready=True, count=0, trusted=True), Verdict.NONE),
    (0.003, PayloadEstimate(ready=True, count=1, trusted=True), Verdict.ONE),
    (0.003, PayloadEstimate(ready=True, count=3, trusted=True), Verdict.SEVERAL),
])
def test_judge(width, estimate, verdict):
    assert judge(width, estimate, 0.0015) is verdict


def test_the_rules_never_deliver_a_doubt():
    settings = RecoverySettings(max_reweighs=1, max_shakes=1)
    assert after_weighing(Verdict.UNSURE, 0, 0, settings) is Recovery.REWEIGH
    assert after_weighing(Verdict.UNSURE, 1, 0, settings) is Recovery.SHAKE
    assert after_weighing(Verdict.UNSURE, 1, 1, settings) is Recovery.PUT_BACK
    assert after_weighing(Verdict.ONE, 0, 0, settings) is Disposition.DELIVERED
    assert after_put_back(Verdict.ONE, 0, settings) is Recovery.SHAKE_OFF
    assert after_put_back(Verdict.ONE, 1, settings) is Disposition.PUT_BACK
    with pytest.raises(ValueError):
        RecoverySettings(max_attempts=0)


def test_a_simulated_closed_loop_pick_is_weighed_and_delivered_to_the_tray():
    from dataclasses import replace

    from tangle_drake.episode.run import PickEpisode
    from tangle_drake.pick.diagram import build_pick_diagram, closed_loop_settings
    from tangle_drake.planning.motions import motion_for
    from tangle_drake.scenario import PartCount
    from tangle_drake.scenario.files import resolve_scenario
    from tangle_drake.selection.choice import TangleChoice
    from tangle_drake.selection.methods import fixed_selection
    from tangle_drake.station import build_station
    from tangle_drake.station.pile import settle_pile

    scenario = resolve_scenario("floating_gripper.yaml")
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[PartCount("u_hook", 6)]))
    station = build_station(scenario)
    pile = settle_pile(station, scenario, seed=1)
    selection = fixed_selection(TangleChoice(None, "graspability"), scenario)
    pick = build_pick_diagram(scenario, motion_for(scenario), selection,
                              station=station,
                              settings=closed_loop_settings(scenario, max_picks=1))
    episode = PickEpisode(pick)
    episode.start(pile.state)
    run = episode.run(60.0)
    delivered = [r for r in run.records if r.disposition is Disposition.DELIVERED]
    assert run.end.value == "done" and len(delivered) == 1
    record = delivered[0]
    assert record.truth.lifted == 1 and record.estimate.count == 1 and record.estimate.trusted
    tray = pick.tray.GetOutputPort("tray_count").Eval(
        pick.tray.GetMyContextFromRoot(episode.simulator.get_context()))
    assert tray[0] == 1  # the simulation's count, not the estimator's
    for other in run.records[:-1]:
        assert other.disposition in (Disposition.EMPTY, Disposition.PUT_BACK)


def bin_view(occupied: bool) -> BinContents:
    """What the camera sees in the default bin: nothing, or a part lying by the +x wall."""
    heights = np.zeros((50, 70))
    if occupied:
        heights[45:48, 30:40] = 0.006
    return BinContents(heights, (0.242, 0.082), 0.004, BinConfig())


def test_a_bin_nothing_can_be_picked_from_is_stirred_and_looked_at_again():
    motion = FakeMotion()
    records, modes, _, _ = run([], [], motion, contents=bin_view(True))
    assert motion.stirs == 2  # RecoverySettings.max_stirs
    assert [r.failure for r in records] == [FailureKind.NO_CANDIDATE] * 3
    assert [r.recoveries for r in records] == [[Recovery.STIR]] * 2 + [[]]
    assert modes[:5] == [Mode.SETTLE, Mode.PERCEIVE, Mode.STIR, Mode.SETTLE, Mode.PERCEIVE]
    assert modes[-1] is Mode.DONE


def test_an_empty_bin_ends_the_run_without_a_stir():
    motion = FakeMotion()
    records, modes, _, _ = run([], [], motion, contents=bin_view(False))
    (record,) = records
    assert record.failure is FailureKind.NO_CANDIDATE and "looks empty" in record.reason
    assert motion.stirs == 0 and Mode.STIR not in modes


def test_grasps_that_keep_coming_up_empty_stir_the_bin_which_is_then_tried_afresh():
    motion = FakeMotion()
    records, modes, _, _ = run([candidate(0, 0.9), candidate(1, 0.8)], [0, 0, 1], motion,
                               recovery=RecoverySettings(max_attempts=2, max_stirs=1),
                               contents=bin_view(True))
    assert [r.disposition for r in records] == [Disposition.EMPTY, Disposition.EMPTY,
                                                Disposition.DELIVERED]
    assert records[1].recoveries == [Recovery.STIR] and motion.stirs == 1
    assert motion.planned == [0, 1, 0]  # the stir changed the pile: the spot is tried again
    assert Mode.STIR in modes


def test_stirs_without_a_delivery_end_in_giving_up():
    motion = FakeMotion()
    records, modes, _, _ = run([candidate(0, 0.9), candidate(1, 0.8)], [0] * 8, motion,
                               recovery=RecoverySettings(max_attempts=2, max_stirs=1),
                               contents=bin_view(True), picks=3)
    assert motion.stirs == 1 and len(records) == 5
    last = records[-1]
    assert last.failure is FailureKind.GAVE_UP and modes[-1] is Mode.DONE
    assert "2 grasps in a row" in last.reason and "1 stir since" in last.reason


def test_without_stirs_a_bin_nothing_can_be_picked_from_ends_the_run():
    motion = FakeMotion()
    records, _, _, _ = run([], [], motion, contents=bin_view(True),
                           recovery=RecoverySettings(max_stirs=0))
    assert len(records) == 1 and motion.stirs == 0


def test_a_stir_that_meets_too_much_force_goes_back_the_way_it_came():
    def stir_time(push: tuple[float, float, float]):
        log = []
        records, _, _, _ = run([], [], contents=bin_view(True), push=push, log=log,
                               recovery=RecoverySettings(max_stirs=1))
        start = next(t for mode, t in log if mode is Mode.STIR)
        end = next(t for mode, t in log if t > start)
        return records, end - start

    records, free = stir_time((0.0, 0.0, 0.0))
    assert "backed out" not in (records[0].reason or "")
    records, pushed = stir_time((40.0, 1.0, 9.0))
    assert "met 40 N and backed out" in records[0].reason
    assert records[0].recoveries == [Recovery.STIR]
    # The fake stir takes ~3.4 s; pushed 1 s in, in the bin, it goes back the way it came.
    assert free > 3.0 and pushed == pytest.approx(2.05, abs=0.1)
    # Felt on the way to the bin (a fast move shakes the reading), it is no reason to stop.
    records, shaken = stir_time((40.0, 0.0, 0.2))
    assert "backed out" not in (records[0].reason or "") and shaken == pytest.approx(free)


def test_the_lift_takes_a_hanging_chain_clear_of_the_pile_the_camera_saw():
    view = bin_view(True)
    view.heights[10:14, 20:24] = 0.05  # a part standing up, 5 cm tall
    view.heights[30, 30] = 0.09  # and one stray pixel, which does not count
    recovery = RecoverySettings(hanging_length=0.2)
    _, _, seen, _ = run([candidate(0, 0.9)], [1], contents=view, recovery=recovery)
    assert seen.tips_above == [pytest.approx(BinConfig().floor_height + 0.05 + 0.2)]
    _, _, blind, _ = run([candidate(0, 0.9)], [1], recovery=recovery)  # no bin view
    assert blind.tips_above == [None]
    _, _, plain, _ = run([candidate(0, 0.9)], [1], contents=view)  # no hanging length
    assert plain.tips_above == [None]
    with pytest.raises(ValueError):
        RecoverySettings(hanging_length=-0.1)
