"""Overlays: a base scenario with files and texts merged onto it, as Drake's ``hardware_sim``
takes ``--scenario_text``. An overlay changes exactly the fields it names, a field it names
wrongly is refused with the overlay's name, and the clearings' overlays give back the very
scenarios their results ran on."""

import hashlib
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import yaml
from pydrake.common.yaml import yaml_dump_typed

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.pick.diagram import (
    closed_loop_settings,
    default_graspability_params,
    payload_settings,
)
from tangle_drake.scenario import load_scenario
from tangle_drake.scenario.files import scenario_source
from tangle_drake.scenario.yaml_io import Tagged, TaggedLoader

ROOT = Path(__file__).resolve().parent.parent
OVERLAYS = ROOT / "docs" / "results" / "clearing" / "overlays"


def leaves(tree: object, prefix: str = "") -> dict[str, object]:
    """Every scalar of a YAML tree by its dotted path (a variant's tag as ``PATH.!``)."""
    if isinstance(tree, Tagged):
        return {f"{prefix}.!": tree.tag, **leaves(tree.value, prefix)}
    if isinstance(tree, dict):
        return {path: value for key, item in tree.items()
                for path, value in leaves(item, f"{prefix}.{key}" if prefix else key).items()}
    if isinstance(tree, list):
        return {path: value for i, item in enumerate(tree)
                for path, value in leaves(item, f"{prefix}[{i}]").items()}
    return {prefix: tree}


def typed(scenario) -> dict[str, object]:
    return leaves(yaml.load(yaml_dump_typed(scenario), Loader=TaggedLoader))


@pytest.mark.parametrize(("base", "overlay", "changed"), [
    ("pick_demo.yaml", "model_drivers: {nextage: {planning_slow_speed: 0.06}}",
     {"model_drivers.nextage.planning_slow_speed": 0.06}),
    ("floating_gripper.yaml", "pile: {seed: 7}\nrandom_seed: 3",
     {"pile.seed": 7, "random_seed": 3}),
    ("pick_demo.yaml", "force_torque_sensors: {wrist: {force_noise: 0.5}}",
     {"force_torque_sensors.wrist.force_noise": 0.5}),
    ("pick_demo.yaml", "bin: {floor_height: 0.95}", {"bin.floor_height": 0.95}),
])
def test_an_overlay_changes_exactly_the_fields_it_names(base, overlay, changed):
    before = typed(scenario_source(base).load())
    after = typed(scenario_source(base, [overlay]).load())
    differing = {path: after[path] for path in before.keys() | after.keys()
                 if before.get(path) != after.get(path)}
    assert differing == changed


def test_overlays_merge_in_order_files_first_then_texts(tmp_path):
    first = tmp_path / "first.yaml"
    first.write_text("pile: {seed: 1, parts: [{part: c_ring, count: 4}]}\n")
    second = tmp_path / "second.yaml"
    second.write_text("pile: {seed: 2}\n")
    scenario = scenario_source(["pick_demo.yaml", first, second], ["pile: {seed: 3}"]).load()
    assert scenario.pile.seed == 3
    assert [(p.part, p.count) for p in scenario.pile.parts] == [("c_ring", 4)]  # lists replaced


def test_one_file_is_its_own_text_so_its_digest_is_the_files():
    source = scenario_source("floating_gripper.yaml")
    assert source.text() == (diagrams_dir() / "floating_gripper.yaml").read_text()
    assert source.name == "floating_gripper.yaml"


@pytest.mark.parametrize(("overlay", "field"), [
    ("bin: {floor_hieght: 0.9}", "bin.floor_hieght"),
    ("random_seed: -1", "random_seed"),
    ("model_drivers: {nextage: {planning_slow_sped: 0.1}}", "planning_slow_sped"),
])
def test_a_wrong_field_is_refused_with_the_overlay_and_the_field(overlay, field, tmp_path):
    path = tmp_path / "variant.yaml"
    path.write_text(overlay + "\n")
    with pytest.raises(TangleDrakeError) as refused:
        scenario_source(["pick_demo.yaml", path]).load()
    message = str(refused.value)
    assert message.startswith(f"{path} (overlaid on pick_demo.yaml):") and field in message


def test_the_command_line_takes_overlays_and_refuses_a_wrong_one_in_one_line(tmp_path):
    command = [sys.executable, "-m", "tangle_drake.cli", "scene", "--out", str(tmp_path / "s"),
               "--scenario", "pile_only.yaml", "--scenario-text", "pile: {sede: 3}"]
    refused = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert refused.stderr.strip().splitlines() == [
        "error: --scenario-text (overlaid on pile_only.yaml): scenario field 'pile.sede': "
        "The fields ['sede'] were unknown to the schema"]


@pytest.mark.parametrize(("result", "files"), [
    ("arm_brisk", ["pick_demo.yaml", "arm_brisk.yaml"]),
    ("arm_brisk_6cm", ["pick_demo.yaml", "arm_brisk.yaml", "slow_stretch_6cm.yaml"]),
    ("noise_x2", ["floating_gripper.yaml", "wrist_noise_x2.yaml"]),
    ("noise_x5", ["floating_gripper.yaml", "wrist_noise_x5.yaml"]),
])
def test_the_clearings_overlays_give_the_scenarios_their_results_ran_on(result, files):
    folder = ROOT / "docs" / "results" / "clearing" / result
    recorded = (folder / "scenario.yaml").read_bytes()
    assert hashlib.sha256(recorded).hexdigest() in (folder / "bench.json").read_text()
    paths = [files[0], *(OVERLAYS / name for name in files[1:])]
    assert typed(scenario_source(paths).load()) == typed(load_scenario(folder / "scenario.yaml"))


def test_the_scenario_holds_how_the_run_picks():
    """``pick``: closed or open loop, the lift's hanging chain, the demo's rule and model."""
    default = scenario_source("pick_demo.yaml").load()
    assert default.pick.closed_loop and default.pick.hanging_parts == 2.0
    fixed_lift = scenario_source("pick_demo.yaml", ["pick: {hanging_parts: 0}"]).load()
    assert closed_loop_settings(fixed_lift).recovery.hanging_length == 0.0
    assert closed_loop_settings(default).recovery.hanging_length > 0.1
    with pytest.raises(TangleDrakeError, match=r"'pick\.hanging_parts' must be >= 0"):
        scenario_source("pick_demo.yaml", ["pick: {hanging_parts: -1}"]).load()


@pytest.mark.parametrize(("overlay", "refusal"), [
    ("pick: {closed_loop: false}", "--log-picks labels each grasp with its weighing"),
    ("pick: {rule: sideways}", "scenario field 'pick.rule': unknown selection rule 'sideways'"),
])
def test_the_demo_reads_the_scenarios_pick_settings(overlay, refusal, tmp_path):
    command = [sys.executable, "-m", "tangle_drake.cli", "demo", "--picks", "1",
               "--scenario-text", overlay, "--log-picks", str(tmp_path / "log")]
    refused = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2 and refusal in refused.stderr, refused.stderr
    assert not (tmp_path / "log").exists()


def test_the_scenario_tunes_the_pick_diagrams_systems():
    """``pick.planner``, ``recovery``, ``payload``, ``graspability``: a value given replaces
    that one setting; what is left out stays the system's default or what the pile gives."""
    base = scenario_source("pick_demo.yaml").load()
    tuned = scenario_source("pick_demo.yaml", [
        "pick: {planner: {close_delay: 0.5}, recovery: {max_shakes: 3},"
        " payload: {min_confidence: 0.95}, graspability: {top_k: 7}}"]).load()
    before, after = closed_loop_settings(base), closed_loop_settings(tuned)
    assert after == replace(before, close_delay=0.5,
                            recovery=replace(before.recovery, max_shakes=3))
    assert payload_settings(tuned) == replace(payload_settings(base), min_confidence=0.95)
    assert default_graspability_params(tuned) == replace(default_graspability_params(base),
                                                         top_k=7)
    assert after.empty_width == before.empty_width < 0.006  # still the pile's wire's


@pytest.mark.parametrize(("overlay", "refusal"), [
    ("pick: {recovery: {max_shakess: 2}}", "'pick.recovery.max_shakess'"),
    ("pick: {planner: {close_time: -1}}", "'pick.planner.close_time' must be >= 0"),
])
def test_a_wrong_tuning_is_refused_naming_it(overlay, refusal):
    with pytest.raises(TangleDrakeError, match=re.escape(refusal)):
        scenario_source("pick_demo.yaml", [overlay]).load()


def test_a_tuning_its_system_refuses_is_refused_naming_the_field():
    scenario = scenario_source("pick_demo.yaml", ["pick: {payload: {min_confidence: 1.5}}"]).load()
    with pytest.raises(TangleDrakeError, match=r"scenario field 'pick\.payload': .*min_confidence"):
        payload_settings(scenario)


@pytest.mark.parametrize(("tuning", "settings"), [
    ("PlannerTuning", "tangle_drake.pick.modes:PickSettings"),
    ("RecoveryTuning", "tangle_drake.pick.recovery:RecoverySettings"),
    ("PayloadTuning", "tangle_drake.pick.payload:PayloadSettings"),
    ("GraspabilityTuning", "tangle_drake.graspability.params:GraspabilityParams"),
])
def test_every_tuning_names_a_setting_of_its_system(tuning, settings):
    """The scenario's sections list their systems' settings by name: a name the settings
    class lacks would fail only when a scenario set it."""
    import dataclasses
    import importlib

    from tangle_drake.scenario import pick

    module, name = settings.split(":")
    known = {f.name for f in dataclasses.fields(getattr(importlib.import_module(module), name))}
    assert {f.name for f in dataclasses.fields(getattr(pick, tuning))} <= known
