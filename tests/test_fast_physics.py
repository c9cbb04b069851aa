"""The scenario's ``simulation`` settings: the pick's own time step, and freezing the parts a
grasp cannot reach, for every caller of the episode (a single pick and a whole run alike)."""

import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.episode.episode import Episode
from tangle_drake.pick.planner import Mode
from tangle_drake.scenario.files import scenario_source
from tangle_drake.selection.methods import Method, MethodRun

FAST = "simulation: {pick_time_step: 0.003, freeze_beyond_radii: 1.5}"
SMALL = "pile: {parts: [{part: u_hook, count: 6}], seed: 4}"
METHODS = [Method("graspability", "graspability")]


@pytest.mark.parametrize(("overlay", "field"), [
    ("simulation: {pick_time_step: 0.004}", "simulation.pick_time_step"),
    ("simulation: {freeze_beyond_radii: 0.5}", "simulation.freeze_beyond_radii"),
    ("simulation: {pick_time_stepp: 0.003}", "simulation.pick_time_stepp"),
])
def test_settings_out_of_the_checked_range_are_refused_naming_them(overlay, field):
    with pytest.raises(TangleDrakeError, match=field.replace(".", r"\.")):
        scenario_source("floating_gripper.yaml", [overlay]).load()


def test_the_pick_runs_at_its_own_step_and_the_pile_settles_at_the_plants():
    scenario = scenario_source("floating_gripper.yaml", [SMALL, FAST]).load()
    episode = Episode.single_pick(scenario, METHODS, "u_hook", floating=True)
    assert episode.pick_diagram.station.plant.time_step() == 0.003
    assert episode.settler.station.plant.time_step() == scenario.plant_config.time_step == 0.002


def test_a_run_freezes_far_parts_from_each_descent_until_the_lift_is_judged():
    """A clearing's grasps: parts out of reach are frozen while the gripper is in the pile, and
    awake whenever anything else moves (the transfer, the release, the next look)."""
    scenario = scenario_source("floating_gripper.yaml", [SMALL, FAST]).load()
    episode = Episode.clearing(scenario, METHODS, "u_hook", open_loop=True)
    frozen_in: dict[Mode, set[int]] = {}

    def watch(mode: Mode) -> float:
        frozen_in.setdefault(mode, set()).add(len(episode._freeze.frozen))
        return 0.05

    episode.start(episode.settle(scenario.pile.seed).state, MethodRun("graspability", 0))
    run = episode.run(40.0, step=watch, on_pick=lambda _: None)
    assert run.records, "no grasp was made"
    assert max(frozen_in[Mode.CHECK]) > 0  # far parts frozen while the lift is judged
    assert max(frozen_in.get(Mode.TRANSFER, {0}) | frozen_in[Mode.SETTLE]
               | frozen_in[Mode.PERCEIVE]) == 0
    assert not episode._freeze.frozen  # awake after the run
