"""The pick state machine with a stand-in manipulator and hand-made candidates."""

from dataclasses import dataclass

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

from tangle_drake.common.failures import FailureKind
from tangle_drake.pick.outcome import Outcome, summarize
from tangle_drake.pick.planner import Mode, PickPlanner, PickSettings, rank_scored
from tangle_drake.pick.truth import PickTruth, with_truth
from tangle_drake.planning.motion import PickMotion, PlanningError, StirMotion
from tangle_drake.planning.trajectory import chain, rest_to_rest
from tangle_drake.selection.rules import ScoredCandidate


@dataclass(frozen=True, eq=False)
class Candidate:
    u: float
    v: float
    angle_deg: float
    score: float
    pose: np.ndarray
    depth_m: float = 0.5
    width_m: float = 0.045


def candidate(index: int, score: float) -> Candidate:
    pose = np.eye(4)
    pose[0, 3] = index  # the fake motion reads the candidate's index from x
    return Candidate(10.0 * index, 20.0, 45.0, score, pose)


class FakeMotion:
    """A 2-joint manipulator; candidates whose index is in ``unreachable`` cannot be
    reached, those in ``colliding`` would collide."""

    command_port = "arm.position"
    command_size = 2
    measured_port = "arm.state_measured"
    measured_size = 4

    def __init__(self, unreachable: tuple[int, ...] = (),
                 colliding: tuple[int, ...] = ()) -> None:
        self.unreachable = unreachable
        self.colliding = colliding
        self.planned: list[int] = []
        self.tips_above: list[float | None] = []
        self.shakes = self.lowered = self.stirs = 0

    def hold_command(self, measured: np.ndarray) -> np.ndarray:
        return np.asarray(measured[:2]).copy()

    def plan_pick(self, X_WT: np.ndarray, measured: np.ndarray,
                  tips_above: float | None = None) -> PickMotion:
        index = int(X_WT[0, 3])
        if index in self.unreachable:
            raise PlanningError(FailureKind.UNREACHABLE, f"candidate {index} is out of reach")
        if index in self.colliding:
            raise PlanningError(FailureKind.COLLISION, f"candidate {index} hits the bin")
        self.planned.append(index)
        self.tips_above.append(tips_above)
        home, there = np.zeros(2), np.array([0.3, -0.2])
        go, back = (rest_to_rest(home, there, 1.0, 1.5),
                    rest_to_rest(there, home, 1.0, 1.5))
        # The lift and the back-out share their first, slow leg (~0.27 s), as a real one's do.
        slow_top = np.array([0.02, 0.0])
        up_slowly = rest_to_rest(home, slow_top, 0.1, 1.5)
        lift = chain([up_slowly, rest_to_rest(slow_top, there, 1.0, 1.5)])
        back_out = chain([up_slowly, rest_to_rest(slow_top, home, 1.0, 1.5)])
        return PickMotion(go, back, lift, back, rest_to_rest(home, home, 1.0, 1.5), back,
                          back_out, X_WT)

    def plan_shake(self, hold):
        self.shakes += 1
        return rest_to_rest(hold, np.asarray(hold) + 0.01, 1.0, 1.5)

    def plan_lower(self, hold, X_WT, clearance):
        self.lowered += 1
        return rest_to_rest(hold, np.asarray(hold) - 0.1, 0.1, 1.5)  # ~1.1 s

    def plan_line(self, start, end):
        return rest_to_rest(start, end, 1.0, 1.5)

    def plan_stir(self, hold, poses, speed):
        self.stirs += 1
        above, end = np.asarray(hold) + 0.05, np.asarray(hold) + 0.55
        return StirMotion(rest_to_rest(hold, above, 1.0, 1.5),  # ~0.4 s
                          rest_to_rest(above, end, 0.2, 1.5),  # ~2.6 s
                          rest_to_rest(end, hold, 1.0, 1.5))


class CountingCandidates(LeafSystem):
    """A candidate list that counts how often it is computed (each look is at a new time)."""

    def __init__(self, candidates: list) -> None:
        super().__init__()
        self.candidates = candidates
        self.calls = 0
        self.times: list[float] = []
        self.DeclareAbstractOutputPort("candidates", lambda: AbstractValue.Make([]), self._calc,
                                       {self.time_ticket()})

    def _calc(self, context, value) -> None:
        self.calls += 1
        self.times.append(context.get_time())
        value.set_value(list(self.candidates))


class FaultWindow(LeafSystem):
    """A ``safety.fault`` that is 1 between ``start`` and ``end`` (s), else 0."""

    def __init__(self, start: float, end: float) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("fault", 1, lambda context, out: out.SetAtIndex(
            0, float(start <= context.get_time() < end)), {self.time_ticket()})


class Camera(LeafSystem):
    """``camera.image_time`` of a camera whose images arrive ``lag`` s late and that freezes
    (sends no new image) from ``frozen_at`` s on."""

    def __init__(self, lag: float = 0.0, frozen_at: float = np.inf) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("image_time", 1, lambda context, out: out.SetAtIndex(
            0, min(context.get_time(), frozen_at) - lag), {self.time_ticket()})


def run(candidates, motion=None, width=0.003, lifted=None, scored=None, picks=2,
        duration=30.0, fault=None, camera=None):
    """Simulate the planner alone; returns (records, modes visited, gripper command on entering
    each mode, source)."""
    motion = motion or FakeMotion()
    builder = DiagramBuilder()
    planner = builder.AddSystem(PickPlanner(motion, PickSettings(max_picks=picks)))
    source = builder.AddSystem(CountingCandidates(candidates))
    builder.Connect(source.get_output_port(), planner.GetInputPort("candidates"))
    measured = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    builder.Connect(measured.get_output_port(), planner.GetInputPort("arm.state_measured"))
    gripper = builder.AddSystem(ConstantVectorSource(np.array([width, 0.0])))
    builder.Connect(gripper.get_output_port(), planner.GetInputPort("gripper.state_measured"))
    truth = None
    if lifted is not None:  # the simulation's truth, beside the planner as the diagram has it
        truth = builder.AddSystem(PickTruth(planner.settings.update_period))
        for port, value in (("lifted_count", [lifted]), ("held_count", [lifted, 0])):
            count = builder.AddSystem(ConstantVectorSource(np.array(value, dtype=float)))
            builder.Connect(count.get_output_port(), truth.GetInputPort(port))
        for port in ("current_pick", "picks"):
            builder.Connect(planner.GetOutputPort(port), truth.GetInputPort(port))
    if fault is not None:
        window = builder.AddSystem(FaultWindow(*fault))
        builder.Connect(window.get_output_port(), planner.GetInputPort("safety.fault"))
    if camera is not None:
        builder.AddSystem(camera)
        builder.Connect(camera.get_output_port(), planner.GetInputPort("camera.image_time"))
    if scored is not None:
        scores = builder.AddSystem(ConstantValueSource(AbstractValue.Make(scored)))
        builder.Connect(scores.get_output_port(), planner.GetInputPort("scored_candidates"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = planner.GetMyContextFromRoot(simulator.get_context())
    modes, widths = [], {}
    while simulator.get_context().get_time() < duration:
        simulator.AdvanceTo(simulator.get_context().get_time() + 0.01)
        mode = planner.GetOutputPort("mode").Eval(context)
        if not modes or modes[-1] is not mode:
            modes.append(mode)
            widths.setdefault(mode, planner.GetOutputPort("gripper.position").Eval(context)[0])
        if mode is Mode.DONE:
            break
    records = planner.GetOutputPort("picks").Eval(context)
    if truth is not None:
        found = truth.GetOutputPort("truth").Eval(truth.GetMyContextFromRoot(
            simulator.get_context()))
        records = [with_truth(r, found, planner.settings.empty_width) for r in records]
    return records, modes, widths, source


PICK_MODES = [Mode.SETTLE, Mode.PERCEIVE, Mode.APPROACH, Mode.DESCEND, Mode.CLOSE, Mode.LIFT,
              Mode.CHECK, Mode.TRANSFER, Mode.RELEASE, Mode.HOME]


def test_a_pick_passes_every_mode_in_order_and_looks_once_per_pick():
    records, modes, _, source = run([candidate(0, 0.9)], lifted=1, picks=2)
    assert modes == PICK_MODES + PICK_MODES + [Mode.DONE]
    assert [r.outcome for r in records] == [Outcome.ONE, Outcome.ONE]
    assert source.calls == 2  # perception ran only when perceiving
    record = records[0]
    assert record.rank == 0 and record.width == pytest.approx(0.003)
    assert record.truth.lifted == 1
    first, second = record.timing, records[1].timing
    assert first.execution_s > 0 and first.planning_s > 0
    assert second.started_at > first.started_at + first.execution_s > 0  # in turn
    assert summarize(records) == "2 pick(s): 2 one part"


def test_the_gripper_opens_for_the_approach_closes_to_zero_and_releases():
    _, _, widths, _ = run([candidate(0, 0.9)], lifted=1, picks=1)
    open_width = PickSettings().open_width
    assert widths[Mode.APPROACH] == open_width
    assert widths[Mode.CLOSE] == open_width  # first the arm settles at the bottom
    assert widths[Mode.LIFT] == widths[Mode.TRANSFER] == 0.0
    assert widths[Mode.RELEASE] == open_width


def test_a_safety_fault_fails_the_pick_in_progress_and_the_planner_resumes_once_it_clears():
    # The first pick's approach starts at 0.3 s (after settling); the fault hits during it.
    records, modes, _, _ = run([candidate(0, 0.9)], lifted=1, picks=2, fault=(0.5, 1.5))
    assert modes[:4] == [Mode.SETTLE, Mode.PERCEIVE, Mode.APPROACH, Mode.STOPPED]
    assert modes[4:] == [*PICK_MODES, Mode.DONE]  # a fresh look once the fault cleared
    first, second = records
    assert first.outcome is Outcome.FAILED and first.reason == "safety stop during approach"
    assert first.failure is FailureKind.SAFETY_STOP
    assert second.outcome is Outcome.ONE


def test_a_frozen_camera_stops_the_planner_instead_of_driving_a_pick():
    # The first look is at 0.3 s; the camera sends nothing new from 0.5 s on.
    records, modes, _, source = run([candidate(0, 0.9)], lifted=1, picks=2,
                                    camera=Camera(frozen_at=0.5))
    assert modes == [*PICK_MODES, Mode.SETTLE, Mode.DONE]  # no look at the pile as it was
    first, stale = records
    assert first.outcome is Outcome.ONE and source.calls == 1
    assert stale.failure is FailureKind.STALE_IMAGE and "camera frozen" in stale.reason


def test_a_camera_that_lags_delays_the_look_until_its_image_shows_the_arm_stopped():
    on_time, _, _, prompt = run([candidate(0, 0.9)], lifted=1, picks=2, camera=Camera())
    late, _, _, lagging = run([candidate(0, 0.9)], lifted=1, picks=2, camera=Camera(lag=0.5))
    assert [r.outcome for r in late] == [Outcome.ONE, Outcome.ONE]
    # (the same to one planner tick, which the later start may round the other way)
    assert [r.timing.execution_s for r in late] == pytest.approx(
        [r.timing.execution_s for r in on_time], abs=PickSettings().update_period)
    # Each look waits for an image that arrived after the arm stopped: 0.5 s after, less the
    # 0.3 s settle the wait overlaps, so each look is 0.2 s later than the one before it.
    delays = np.diff([0.0, *lagging.times]) - np.diff([0.0, *prompt.times])
    np.testing.assert_allclose(delays, 0.2, atol=0.021)


def test_a_fault_while_idle_records_nothing_and_a_lasting_fault_stays_stopped():
    records, modes, _, _ = run([candidate(0, 0.9)], lifted=1, picks=1, fault=(0.1, 99.0),
                               duration=5.0)
    assert modes == [Mode.SETTLE, Mode.STOPPED]
    assert records == []


def test_fingers_closed_past_the_threshold_mean_an_empty_grasp():
    records, modes, _, _ = run([candidate(0, 0.9)], width=0.0005, lifted=1, picks=1)
    assert records[0].outcome is Outcome.NONE
    assert Mode.TRANSFER in modes and modes[-1] is Mode.DONE  # it still goes home


@pytest.mark.parametrize(("lifted", "outcome"), [(2, Outcome.SEVERAL), (0, Outcome.NONE),
                                                 (None, Outcome.HELD)])
def test_the_simulations_count_classifies_a_held_grasp(lifted, outcome):
    records, _, _, _ = run([candidate(0, 0.9)], lifted=lifted, picks=1)
    assert records[0].outcome is outcome


def test_an_unreachable_candidate_is_recorded_and_the_next_one_tried():
    motion = FakeMotion(unreachable=(0,))
    records, _, _, _ = run([candidate(0, 0.9), candidate(1, 0.5)], motion, lifted=1, picks=1)
    record = records[0]
    assert record.outcome is Outcome.ONE
    assert record.rank == 1 and record.candidate.u == 10.0
    assert [r.rank for r in record.rejected] == [0]
    assert record.rejected[0].kind is FailureKind.UNREACHABLE
    assert record.rejected[0].reason == "unreachable: candidate 0 is out of reach"
    assert record.failure is None
    assert motion.planned == [1]


@pytest.mark.parametrize(("unreachable", "colliding", "kind", "reason"), [
    ((0, 1), (), FailureKind.UNREACHABLE, "no candidate can be picked (2 unreachable)"),
    ((), (0, 1), FailureKind.COLLISION, "no candidate can be picked (2 collision)"),
    ((1,), (0,), FailureKind.UNREACHABLE,
     "no candidate can be picked (1 collision, 1 unreachable)"),
])
def test_no_plannable_candidate_fails_the_pick_with_its_kind_and_stops(unreachable, colliding,
                                                                       kind, reason):
    motion = FakeMotion(unreachable, colliding)
    records, modes, _, _ = run([candidate(0, 0.9), candidate(1, 0.5)], motion, picks=3)
    assert len(records) == 1
    assert records[0].outcome is Outcome.FAILED
    assert records[0].failure is kind and records[0].reason == reason
    assert modes == [Mode.SETTLE, Mode.PERCEIVE, Mode.DONE]


def test_no_candidate_fails_the_pick_and_stops():
    records, modes, _, _ = run([], picks=3)
    assert [r.outcome for r in records] == [Outcome.FAILED]
    assert records[0].failure is FailureKind.NO_CANDIDATE
    assert modes[-1] is Mode.DONE


def test_scored_candidates_set_the_order():
    low, high = candidate(0, 0.9), candidate(1, 0.5)
    scored = [ScoredCandidate(high, 0.95, 0.7, "P(success)"),  # best first
              ScoredCandidate(low, 0.1, 0.2, "P(success)")]
    motion = FakeMotion()
    records, _, _, _ = run([low, high], motion, lifted=1, scored=scored, picks=1)
    assert motion.planned == [1]
    assert records[0].p_model == pytest.approx(0.95)
    assert "(graspability 0.50, P(success) 0.95)" in records[0].describe()  # the model's words


def test_rank_scored_keeps_the_selection_order_with_the_selected_grasp_first():
    a, b, c = candidate(0, 0.9), candidate(1, 0.8), candidate(2, 0.7)
    scored = [ScoredCandidate(c, 0.9, 0.8), ScoredCandidate(a, 0.5, 0.6),
              ScoredCandidate(b, 0.5, 0.6)]
    assert [s.candidate.u for s in rank_scored(scored)] == [20.0, 0.0, 10.0]
    selected = Candidate(b.u, b.v, b.angle_deg, b.score, b.pose)  # a copy, as ports deliver
    assert [s.candidate.u for s in rank_scored(scored, selected)] == [10.0, 20.0, 0.0]


def test_settings_refuse_nonsense():
    with pytest.raises(ValueError, match="max_picks"):
        PickSettings(max_picks=0)
    with pytest.raises(ValueError, match="empty_width"):
        PickSettings(empty_width=0.0)


def test_a_grasp_that_came_up_empty_is_not_repeated():
    motion = FakeMotion()
    records, _, _, _ = run([candidate(0, 0.9), candidate(1, 0.5)], motion, width=0.0005,
                           picks=2)
    assert [r.outcome for r in records] == [Outcome.NONE, Outcome.NONE]
    assert motion.planned == [0, 1]
    assert records[1].rank == 1 and "repeat" in records[1].rejected[0].reason
