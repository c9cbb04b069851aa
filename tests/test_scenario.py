"""Scenario YAML: the shipped files load, and every malformed field is named in the error."""

import difflib
import re

import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.scenario import Scenario, load_scenario, parse_scenario


@pytest.mark.parametrize("name", ["pick_demo.yaml", "floating_gripper.yaml", "pile_only.yaml",
                                  "tangle_data.yaml", "dense_bin.yaml", "factory_bin.yaml"])
def test_shipped_scenarios_load(name):
    scenario = load_scenario(diagrams_dir() / name)
    assert isinstance(scenario, Scenario)
    assert scenario.pile.total_count > 0
    assert scenario.camera.depth


def test_the_dense_bin_differs_from_the_benchmarks_only_in_its_pile():
    def lines(name: str) -> list[str]:
        text = (diagrams_dir() / name).read_text()
        return [line for line in text.splitlines() if not line.lstrip().startswith("#")]

    changed = [line for line in difflib.ndiff(lines("floating_gripper.yaml"),
                                              lines("dense_bin.yaml")) if line[0] in "+-"]
    assert changed == ["-     count: 15", "+     count: 40"]


def test_a_part_alone_fills_the_pile_with_its_own_count():
    """A deep bin holds fewer long parts than short ones: where one part replaces the pile's
    (the benchmark's --parts, the demo's --part, collect, teach), ``part_counts`` sizes it."""
    from dataclasses import replace

    from tangle_drake.bench.trials import BenchConfig, PartSpec, part_scenario
    from tangle_drake.episode.demo import with_part

    text = "pile: {parts: [{part: u_hook, count: 30}], part_counts: {j_hook: 12}}"
    scenario = parse_scenario(text)
    assert [(p.part, p.count) for p in scenario.pile.alone("j_hook").parts] == [("j_hook", 12)]
    assert [(p.part, p.count) for p in scenario.pile.alone("s_hook").parts] == [("s_hook", 30)]
    assert scenario.pile.alone("j_hook", count=3).parts[0].count == 3  # a count given wins
    assert with_part(scenario, "j_hook").pile.total_count == 12
    config = BenchConfig(text, (), {}, "floating", 0, None)
    assert part_scenario(config, PartSpec("j_hook", "j_hook", 1.0)).pile.total_count == 12
    assert part_scenario(replace(config, pile_size=2),
                         PartSpec("j_hook", "j_hook", 1.0)).pile.total_count == 2
    with pytest.raises(TangleDrakeError, match=r"pile\.part_counts\[j_hook\]"):
        parse_scenario("pile: {part_counts: {j_hook: 0}}")


def test_the_factory_bin_holds_each_parts_pile_by_the_fill_estimate():
    """Its counts were measured to stay below the rim (tools/bin_fill.py); the estimate that
    warns before a pile is dropped agrees for every built-in part."""
    from dataclasses import replace

    from tangle_drake.parts import BUILTIN_PARTS
    from tangle_drake.station.pile import check_pile

    scenario = load_scenario(diagrams_dir() / "factory_bin.yaml")
    assert set(scenario.pile.part_counts) | {scenario.pile.parts[0].part} == set(BUILTIN_PARTS)
    for part in BUILTIN_PARTS:
        assert check_pile(replace(scenario, pile=scenario.pile.alone(part))) == [], part


def test_values_from_yaml_override_defaults():
    scenario = parse_scenario("""
bin: {center: [0.5, 0.1], inner_size: [0.3, 0.3]}
pile: {parts: [{part: c_ring, count: 4}, {part: s_hook, count: 2}], seed: 7}
camera: {focal: !FovDegrees {y: 40}}
""")
    assert scenario.bin.center == [0.5, 0.1]
    assert scenario.bin.floor_height == Scenario().bin.floor_height
    assert [(p.part, p.count) for p in scenario.pile.parts] == [("c_ring", 4), ("s_hook", 2)]
    assert scenario.pile.total_count == 6
    assert scenario.camera.focal.y == 40


@pytest.mark.parametrize(("text", "field"), [
    ("bin: {centre: [1, 2]}", "bin.centre"),
    ("bin: {wall_height: high}", "bin.wall_height"),
    ("bin: {inner_size: [0.2, -0.1]}", "bin.inner_size"),
    ("bin: {center: [1, 2, 3]}", "bin.center"),
    ("pile: {parts: [{part: u_hook, count: many}]}", "pile.parts[0].count"),
    ("pile: {parts: [{part: u_hook, count: 2}, {prt: s_hook}]}", "pile.parts[1].prt"),
    ("pile: {parts: [{part: u_hook, count: -3}]}", "pile.parts[0].count"),
    ("plant_config: {time_step: 0.01}", "plant_config.time_step"),
    ("plant_config: {discrete_contact_approximation: tamsi}",
     "plant_config.discrete_contact_approximation"),
    ("camera_height: 0.05", "camera_height"),
    ("camera: {depth: false}", "camera.depth"),
    ("camera: {width: -640}", "camera"),
    ("no_such_field: 1", "no_such_field"),
    ("model_drivers: {nextage: {}}", "model_drivers.nextage"),
    ("model_drivers: {nextage: !TeleportDriver {}}", "model_drivers"),
    ("model_drivers: {nextage: !NextageDriver {lcm_bus: nowhere}}",
     "model_drivers.nextage.lcm_bus"),
    ("model_drivers: {nextage: !NextageDriver {planning_velocity_limit: 0}}",
     "model_drivers.nextage.planning_velocity_limit"),
    ("model_drivers: {nextage: !NextageDriver {planning_acceleration_limit: .inf}}",
     "model_drivers.nextage.planning_acceleration_limit"),
    ("model_drivers: {nextage: !NextageDriver {planning_slow_speed: -0.03}}",
     "model_drivers.nextage.planning_slow_speed"),
])
def test_malformed_field_is_named(text, field):
    with pytest.raises(TangleDrakeError, match=re.escape(f"'{field}'")):
        parse_scenario(text)


@pytest.mark.parametrize("text", ["[1, 2]", "bin: [", "just a string"])
def test_not_a_mapping_or_not_yaml(text):
    with pytest.raises(TangleDrakeError):
        parse_scenario(text)


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(TangleDrakeError, match="cannot read scenario file"):
        load_scenario(tmp_path / "nope.yaml")


def test_the_two_picking_scenarios_differ_only_in_the_carrier():
    arm = load_scenario(diagrams_dir() / "pick_demo.yaml")
    floating = load_scenario(diagrams_dir() / "floating_gripper.yaml")
    assert [type(d).__name__ for d in arm.model_drivers.values()] == [
        "NextageDriver", "ParallelJawDriver"]
    assert [type(d).__name__ for d in floating.model_drivers.values()] == [
        "GantryDriver", "ParallelJawDriver"]
    for name in ("bin", "pile", "camera", "camera_height", "plant_config"):
        assert repr(getattr(arm, name)) == repr(getattr(floating, name)), name
