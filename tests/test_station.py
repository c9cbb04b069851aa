"""The station built from the shipped pick_demo scenario: ports, robot control, the commands."""

import json
import subprocess
import sys

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from tangle_drake.cli import main
from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.robot_model.nextage import HOME, LEFT_ARM
from tangle_drake.scenario import PartCount, load_scenario, parse_scenario
from tangle_drake.station import build_station, camera_model

STATION_PORTS = {
    "inputs": ["nextage.position", "gripper.position"],
    "outputs": ["nextage.position_measured", "nextage.state_measured", "gripper.state_measured",
                "camera.rgb_image", "camera.depth_image", "camera.image_time",
                "wrist.force_torque"],
}


@pytest.fixture(scope="module")
def demo_scenario():
    scenario = load_scenario(diagrams_dir() / "pick_demo.yaml")
    scenario.pile.parts = [PartCount(part="u_hook", count=3)]
    scenario.view_cameras = []
    return scenario


def test_station_has_the_documented_ports(demo_scenario):
    station = build_station(demo_scenario)
    inputs = [station.get_input_port(i).get_name() for i in range(station.num_input_ports())]
    outputs = [station.get_output_port(i).get_name() for i in range(station.num_output_ports())]
    assert inputs == STATION_PORTS["inputs"]
    assert set(STATION_PORTS["outputs"]) <= set(outputs)
    assert all(name.startswith("sim.") for name in set(outputs) - set(STATION_PORTS["outputs"]))
    assert station.GetInputPort("nextage.position").size() == 15
    assert station.GetInputPort("gripper.position").size() == 1
    assert station.GetOutputPort("gripper.state_measured").size() == 2


def test_robot_follows_position_commands_and_the_gripper_opens_and_closes(demo_scenario):
    station = build_station(demo_scenario)
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    station.hold_still(context)
    measured = station.GetOutputPort("nextage.position_measured")
    np.testing.assert_allclose(measured.Eval(context), HOME, atol=1e-9)

    target = HOME.copy()
    target[LEFT_ARM.start] += 0.1
    station.GetInputPort("nextage.position").FixValue(context, target)
    station.GetInputPort("gripper.position").FixValue(context, [0.0])
    simulator.AdvanceTo(1.0)
    np.testing.assert_allclose(measured.Eval(context), target, atol=2e-3)
    width = station.GetOutputPort("gripper.state_measured").Eval(context)[0]
    assert width == pytest.approx(0.0, abs=0.002)

    station.GetInputPort("gripper.position").FixValue(context, [DEFAULT_GRIPPER.max_opening])
    simulator.AdvanceTo(1.6)
    width = station.GetOutputPort("gripper.state_measured").Eval(context)[0]
    assert width == pytest.approx(DEFAULT_GRIPPER.max_opening, abs=0.002)


def test_the_floating_gripper_is_the_same_station_with_a_gantry_for_carrier():
    scenario = load_scenario(diagrams_dir() / "floating_gripper.yaml")
    scenario.pile.parts = [PartCount(part="u_hook", count=2)]
    station = build_station(scenario)
    inputs = [station.get_input_port(i).get_name() for i in range(station.num_input_ports())]
    assert inputs == ["gantry.position", "gripper.position"]
    assert station.GetOutputPort("gantry.state_measured").size() == 8
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    station.hold_still(context)
    home = station.GetOutputPort("gantry.position_measured").Eval(context).copy()
    np.testing.assert_allclose(home, [scenario.bin.center[0] - 0.25, scenario.bin.center[1],
                                      1.2, 0.0])
    target = home + np.array([0.05, -0.05, -0.1, 0.5])
    station.GetInputPort("gantry.position").FixValue(context, target)
    simulator.AdvanceTo(1.0)
    np.testing.assert_allclose(station.GetOutputPort("gantry.position_measured").Eval(context),
                               target, atol=2e-3)
    # The gripper hangs straight down from the yaw link, turned with it.
    X_WG = station.plant.GetBodyByName("gripper_base").EvalPoseInWorld(
        station.plant_context(context))
    np.testing.assert_allclose(X_WG.rotation().col(2), [0, 0, -1], atol=1e-3)
    assert len(station.pile_bodies) == 2


@pytest.mark.parametrize(("drivers", "message"), [
    ("{gripper: !ParallelJawDriver {}}", "model 'nextage' has actuators but no entry"),
    ("{nextage: !NextageDriver {}, gripper: !ParallelJawDriver {}, arm2: !NextageDriver "
     "{command_channel: A, status_channel: B}}", "'model_drivers.arm2' names no model"),
])
def test_drivers_and_models_must_match(drivers, message):
    scenario = parse_scenario(f"""
directives:
- add_directives: {{file: package://nextage/nextage_with_gripper.dmd.yaml}}
model_drivers: {drivers}
pile: {{parts: [{{part: u_hook, count: 1}}]}}
""")
    with pytest.raises(TangleDrakeError, match=message):
        build_station(scenario)


def test_camera_model_looks_down_at_the_bin(demo_scenario):
    camera = camera_model(demo_scenario)
    centre = [*demo_scenario.bin.center, demo_scenario.bin.floor_height]
    u, v, depth = camera.world_to_pixel(np.array(centre))
    assert (u, v) == pytest.approx(((640 - 1) / 2, (480 - 1) / 2), abs=0.5)
    assert depth == pytest.approx(demo_scenario.camera_height)


def test_scene_command_writes_metric_images(tmp_path):
    scenario = tmp_path / "small.yaml"
    scenario.write_text((diagrams_dir() / "pile_only.yaml").read_text().replace(
        "count: 15", "count: 4"))
    out = tmp_path / "scene"
    assert main(["scene", "--scenario", str(scenario), "--out", str(out), "--seed", "2"]) == 0
    depth = np.load(out / "depth.npy")
    assert depth.dtype == np.float32 and depth.shape == (480, 640)
    camera = json.loads((out / "camera.json").read_text())
    floor = camera["X_WC"][2][3] - 0.93
    assert np.nanmax(depth) == pytest.approx(floor, abs=0.002)
    pile = json.loads((out / "pile.json").read_text())
    assert len(pile["parts"]) == 4 and pile["report"]["parked"] == []
    for name in ("depth.png", "rgb.png"):
        assert (out / name).stat().st_size > 1000


def test_scene_command_reports_a_bad_scenario_without_a_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("pile: {parts: [{part: u_hook, count: lots}]}\n")
    assert main(["scene", "--scenario", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "pile.parts[0].count" in err and "Traceback" not in err


def test_diagram_command_writes_graphviz(tmp_path):
    out = tmp_path / "station.dot"
    assert main(["diagram", "--scenario", "pile_only.yaml", "--out", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("digraph") and "camera.depth_image" in text


def test_diagram_without_graphviz_writes_dot_text_by_default(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PATH", str(tmp_path))  # no `dot` anywhere
    assert main(["diagram", "--scenario", "pile_only.yaml"]) == 0
    assert "apt-get install graphviz" in capsys.readouterr().out
    assert (tmp_path / "station.dot").read_text().startswith("digraph")
    assert main(["diagram", "--scenario", "pile_only.yaml", "--out", "station.svg"]) == 2
    assert "--out station.dot" in capsys.readouterr().err  # asked for .svg: said what to do


def test_non_editable_install_finds_models_and_scenarios(tmp_path):
    """A wheel install must carry models/ and diagrams/ and resolve package://nextage."""
    import tangle_drake

    source = tangle_drake.__file__.rsplit("/tangle_drake/", 1)[0]
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--target", str(target), source],
                   check=True, capture_output=True)
    probe = (
        "import tangle_drake, tangle_drake.common.paths as p;"
        "from pydrake.multibody.plant import MultibodyPlant;"
        "from tangle_drake.robot_model.nextage import add_nextage_with_gripper;"
        "plant = MultibodyPlant(0.002); add_nextage_with_gripper(plant); plant.Finalize();"
        "print(tangle_drake.__file__, p.models_dir(), p.diagrams_dir(), plant.num_positions())"
    )
    result = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, capture_output=True,
                            text=True, env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"})
    assert result.returncode == 0, result.stderr
    module, models, diagrams, num_positions = result.stdout.split()
    assert module.startswith(str(target)) and models.startswith(str(target))
    assert diagrams.startswith(str(target)) and int(num_positions) == 17


def test_a_tray_must_stand_beside_the_bin_out_of_the_cameras_view():
    base = (diagrams_dir() / "floating_gripper.yaml").read_text()
    over = base.replace("center: [-0.01, 0.22]", "center: [0.34, 0.22]")
    with pytest.raises(TangleDrakeError, match="'tray' must stand beside the bin"):
        parse_scenario(over)
    in_view = parse_scenario(base.replace("center: [-0.01, 0.22]", "center: [0.14, 0.50]"))
    with pytest.raises(TangleDrakeError, match="tray shows in the top camera's view"):
        build_station(in_view)


def test_scene_refuses_a_camera_that_sees_nothing_of_the_bin(tmp_path, capsys):
    text = (diagrams_dir() / "pile_only.yaml").read_text()
    away = tmp_path / "away.yaml"
    away.write_text(text.replace("camera_height: 0.5", "camera_height: null\ncamera:\n"
                                 "  X_PB: {translation: [3.0, 3.0, 1.5], rotation: !Rpy "
                                 "{deg: [180, 0, 0]}}"))  # looking down, beside the bin
    assert main(["scene", "--scenario", str(away), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "sees nothing of the bin" in err
    assert "Traceback" not in err
