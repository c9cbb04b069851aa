"""Short demo runs in simulation through the whole pick diagram: one open-loop pick, recorded
for Meshcat, and a closed-loop run to one delivery into the tray."""

import base64
import re
from dataclasses import replace

from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.pick.outcome import Outcome
from tangle_drake.scenario.files import resolve_scenario


def test_one_pick_end_to_end(tmp_path):
    scenario = resolve_scenario(None)
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[replace(scenario.pile.parts[0],
                                                                  count=6)]))
    lines: list[str] = []
    records = run_demo(DemoOptions(picks=1, scenario=scenario, seed=1,
                                   record=tmp_path / "demo.html",
                                   diagram=tmp_path / "pick_demo.dot", open_loop=True),
                       say=lines.append)

    assert len(records) == 1
    record = records[0]
    assert record.outcome is not Outcome.FAILED, record.reason
    assert record.candidate is not None and record.candidate.pose is not None
    assert record.truth.lifted is not None  # the simulation's monitor was connected
    # The gripper's own check and the monitor agree on whether something came up.
    assert (record.outcome is Outcome.NONE) == (record.width < 0.0015 or record.truth.lifted == 0)
    assert 5.0 < record.timing.execution_s < 30.0 and record.timing.planning_s < 5.0
    assert lines[-1].startswith("1 pick(s): ")
    left = 6 - (record.truth.lifted if record.outcome is not Outcome.NONE else 0)
    # Released outside the bin: into the tray, where the last line counts it.
    assert f"; now {left} of 6 parts in the bin, {6 - left} in the tray" in lines[-1]
    pick_line = next(line for line in lines if line.startswith("pick 1: "))
    assert f" | {left} of 6 parts in the bin" in pick_line

    replay = (tmp_path / "demo.html").read_text()
    assert "<html" in replay[:1000].lower()
    commands = [base64.b64decode(text) for text in re.findall(r'base64,([A-Za-z0-9+/=]+)"',
                                                               replay)]
    assert any(b"set_target" in c for c in commands)  # framed on the work
    assert any(b"/candidates/pick_1/0/closing" in c for c in commands)  # its candidates drawn
    dot = (tmp_path / "pick_demo.dot").read_text()
    for system in ("graspability", "pick_planner", "lift_monitor", "station"):
        assert system in dot


def test_the_closed_loop_demo_weighs_and_delivers_one_part_into_the_tray():
    from tangle_drake.pick.recovery import Disposition

    scenario = resolve_scenario(None)
    scenario = replace(scenario, view_cameras=[],
                       pile=replace(scenario.pile, parts=[replace(scenario.pile.parts[0],
                                                                  count=6)]))
    lines: list[str] = []
    records = run_demo(DemoOptions(picks=1, scenario=scenario, seed=1, rule="graspability"),
                       say=lines.append)
    delivered = [r for r in records if r.disposition is Disposition.DELIVERED]
    assert len(delivered) == 1 and delivered[0].estimate.count == 1
    assert delivered[0].truth.lifted == 1  # the simulation agrees with the scale
    assert all(r.estimate is not None or r.disposition is Disposition.EMPTY for r in records)
    assert "1 in the tray" in lines[-1] and "delivered" in lines[-1]
