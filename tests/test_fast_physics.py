"""The scenario's ``simulation`` settings: the pick's own time step, and freezing the parts a
grasp cannot reach, for every caller of the episode (a single pick and a whole run alike)."""

import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.episode.episode import Episode, freeze_change
from tangle_drake.pick.planner import Mode
from tangle_drake.scenario.files import scenario_source
from tangle_drake.selection.methods import Method, MethodRun

FAST = "simulation: {pick_time_step: 0.003, freeze_beyond_radii: 1.5}"
SMALL = "pile: {parts: [{part: u_hook, count: 12}], seed: 4}"
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


def test_a_run_keeps_what_no_grasp_reaches_frozen_and_wakes_it_after():
    """A clearing's grasps: the settled pile is frozen until the first descent, then the parts
    out of each grasp's reach, also while the robot is away (the transfer), and once it is
    home, every part at rest (the next look); nothing is left frozen after the run."""
    scenario = scenario_source("floating_gripper.yaml", [SMALL, FAST]).load()
    episode = Episode.clearing(scenario, METHODS, "u_hook", open_loop=True)
    frozen_in: dict[Mode, list[int]] = {}
    seen: list[tuple[Mode, int]] = []

    def watch(mode: Mode) -> float:
        frozen_in.setdefault(mode, []).append(len(episode._freeze.frozen))
        seen.append((mode, len(episode._freeze.frozen)))
        return 0.05

    pile = episode.settle(scenario.pile.seed)
    episode.start(pile.state, MethodRun("graspability", 0))
    run = episode.run(25.0, step=watch)
    assert len(run.records) >= 2, "fewer than two grasps"
    in_bin = pile.report.num_in_bin
    assert frozen_in[Mode.SETTLE][0] == in_bin  # before the first look: all of the pile
    for mode in (Mode.CHECK, Mode.TRANSFER):
        assert 0 < min(frozen_in[mode]) < in_bin  # the parts out of the grasp's reach
    modes = [mode for mode, _ in seen]
    after_home = seen[modes.index(Mode.SETTLE, modes.index(Mode.HOME))][1]
    assert after_home > frozen_in[Mode.TRANSFER][0]  # home: the parts at rest too
    assert not episode._freeze.frozen


@pytest.mark.parametrize(("mode", "grasp", "frozen_for", "frozen", "rested", "change"), [
    (Mode.PERCEIVE, None, set(), False, False, "pile"),  # the settled pile, before any grasp
    (Mode.APPROACH, 1, set(), True, True, None),
    (Mode.DESCEND, 1, set(), True, True, "grasp"),  # wake, freeze what it cannot reach
    (Mode.DESCEND, 1, {1}, True, False, None),  # once per grasp
    (Mode.TRANSFER, 1, {1}, True, False, None),  # the robot is away: it stays frozen
    (Mode.HOME, None, {1}, True, False, "rest"),  # home: what has come to rest, too
    (Mode.HOME, None, {1}, True, True, None),  # once per grasp
    (Mode.SHAKE, 1, {1}, True, False, "wake"),  # a shake, a put-back or a stir wakes it
    (Mode.PUT_BACK, 1, {1}, True, False, "wake"),
    (Mode.STIR, None, {1}, True, True, "wake"),
    (Mode.PERCEIVE, None, {1}, False, True, None),  # woken: awake until the next descent
    (Mode.DESCEND, 2, {1}, False, True, "grasp"),
])
def test_what_wakes_and_what_freezes_the_pile(mode, grasp, frozen_for, frozen, rested, change):
    assert freeze_change(mode, grasp, frozen_for, frozen, rested) == change


def test_the_agreement_check_compares_two_settings_and_resumes(tmp_path):
    """The check as its users run it: a process, settings against settings, a file that a
    second run resumes, and another run's settings refused."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    out = tmp_path / "check.jsonl"
    command = [sys.executable, str(root / "tools" / "physics_agreement.py"), "--part", "c_ring",
               "--piles", "1", "--top-k", "1", "--old", "simulation: {freeze_beyond_radii: 3}",
               "--new", "simulation: {freeze_beyond_radii: 2}", "--out", str(out)]
    first = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    identity, pile = map(json.loads, out.read_text().splitlines())
    assert identity["old"] == ["simulation: {freeze_beyond_radii: 3}"]
    (row,) = pile["ranks"]
    assert {row["shipped"], row["rerun"], row["new"]} <= {"one part", "several", "none"}
    assert "c_ring: 1 piles, 1 paired picks" in first.stdout
    assert "verdict: passes" in first.stdout or "verdict: fails" in first.stdout
    again = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert again.returncode == 0 and "pile 1/1" not in again.stderr  # nothing run again
    assert len(out.read_text().splitlines()) == 2
    other = subprocess.run([*command[:-4], "--out", str(out)], capture_output=True, text=True,
                           timeout=600, cwd=tmp_path)
    assert other.returncode == 2 and "holds a check of other settings" in other.stderr
