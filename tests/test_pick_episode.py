"""The episode API: a pile settled once, picked from again and again by one pick diagram, with
the same result each time; the run ends when the planner is done or the time runs out."""

from dataclasses import replace

import pytest

from tangle_drake.episode.run import PickEpisode, RunEnd
from tangle_drake.pick.diagram import build_pick_diagram, pick_settings
from tangle_drake.planning.motions import motion_for
from tangle_drake.scenario import PartCount
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.choice import TangleChoice
from tangle_drake.selection.methods import fixed_selection
from tangle_drake.station import build_station
from tangle_drake.station.pile import PileSettler, settle_pile


@pytest.fixture(scope="module")
def rig():
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[PartCount("u_hook", 4)]))
    station = build_station(scenario)
    pile = settle_pile(station, scenario, seed=3)
    selection = fixed_selection(TangleChoice(None, "graspability"), scenario)
    pick = build_pick_diagram(scenario, motion_for(scenario, return_home=False),
                              selection, station=station,
                              settings=pick_settings(scenario, max_picks=1))
    return scenario, pile, PickEpisode(pick)


def test_a_settled_pile_depends_on_its_seed_alone(rig):
    scenario, pile, _ = rig
    settler = PileSettler(build_station(scenario), scenario)
    other = settler.settle(4)
    again = settler.settle(3)
    assert (again.state == pile.state).all()
    assert not (other.state == pile.state).all()
    assert again.report.num_in_bin == 4


def test_the_episode_restarts_from_the_pile_and_repeats_the_pick(rig):
    _, pile, episode = rig
    results, seen = [], []
    for _ in range(2):
        episode.start(pile.state)
        run = episode.run(20.0, on_pick=seen.append)
        assert run.end is RunEnd.DONE and len(run.records) == 1
        record = run.records[0]
        results.append((record.outcome, record.candidate.u, record.candidate.v, record.width,
                        record.truth.lifted, run.time))
    assert results[0] == results[1]
    assert [r.index for r in seen] == [1, 1]  # each pick reported once, as it ended


def test_the_run_stops_at_its_time_limit(rig):
    _, pile, episode = rig
    episode.start(pile.state)
    run = episode.run(1.0)
    assert run.end is RunEnd.TIMEOUT and run.records == []
    assert run.time == pytest.approx(1.0, abs=0.5)
