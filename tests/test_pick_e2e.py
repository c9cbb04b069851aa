"""One short pick in simulation through the whole pick diagram, recorded for Meshcat."""

from dataclasses import replace

from tangle_drake.pick.demo import DemoOptions, run_demo
from tangle_drake.pick.outcome import Outcome
from tangle_drake.scenario_files import resolve_scenario


def test_one_pick_end_to_end(tmp_path):
    scenario = resolve_scenario(None)
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[replace(scenario.pile.parts[0],
                                                                  count=6)]))
    lines: list[str] = []
    records = run_demo(DemoOptions(picks=1, scenario=scenario, seed=1,
                                   record=tmp_path / "demo.html",
                                   diagram=tmp_path / "pick_demo.dot"),
                       say=lines.append)

    assert len(records) == 1
    record = records[0]
    assert record.outcome is not Outcome.FAILED, record.reason
    assert record.candidate is not None and record.candidate.pose is not None
    assert record.lifted is not None  # the simulation's monitor was connected
    # The gripper's own check and the monitor agree on whether something came up.
    assert (record.outcome is Outcome.NONE) == (record.width < 0.0015 or record.lifted == 0)
    assert 5.0 < record.execution_s < 30.0 and record.planning_s < 5.0
    assert lines[-1].startswith("1 pick(s): ")
    left = 6 - (record.lifted if record.outcome is not Outcome.NONE else 0)
    assert f"; {left} of 6 parts left in the bin" in lines[-1]  # released outside the bin
    pick_line = next(line for line in lines if line.startswith("pick 1: "))
    assert pick_line.endswith(f" | {left} of 6 parts in the bin")

    assert "<html" in (tmp_path / "demo.html").read_text()[:1000].lower()
    dot = (tmp_path / "pick_demo.dot").read_text()
    for system in ("graspability", "pick_planner", "lift_monitor", "station"):
        assert system in dot
