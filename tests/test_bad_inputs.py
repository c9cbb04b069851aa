"""The bad inputs a new user meets: each gets one clear line naming it (exit 2), or is done
right; never a traceback, never a silent success. Run through the real command line."""

from pathlib import Path

import pytest

from tangle_drake.cli import main
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.tangle_cnn.synthetic import write_synthetic_dataset


def _refused(argv: list[str], capsys) -> str:
    """The one error line of a refused command (argparse's or the project's)."""
    try:
        code = main(argv)
    except SystemExit as exit_:  # argparse refuses with its usage and one error line
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    (line,) = [line for line in err.splitlines() if "error:" in line]
    return line


def _scenario(tmp_path: Path, text: str, base: str = "floating_gripper.yaml") -> Path:
    path = tmp_path / "bad.yaml"
    path.write_text((diagrams_dir() / base).read_text() + text)
    return path


@pytest.mark.parametrize("command", [["scene"], ["demo"], ["bench", "--quick"],
                                     ["teach", "part.obj"], ["hardware-sim"], ["train",
                                     "--data", "d", "--out", "m.pt"]])
def test_a_negative_seed_is_refused_by_every_command(command, capsys):
    line = _refused([*command, "--seed", "-1"], capsys)
    assert "--seed" in line and "non-negative" in line and "'-1'" in line


@pytest.mark.parametrize("text, field", [
    ("lcm_buses: {default: {lcm_url: 'bogus://x'}}\n", "lcm_buses.default.lcm_url"),
    ("lcm_buses: {default: {lcm_url: 'udpm://999.1.2.3'}}\n", "lcm_buses.default.lcm_url"),
    ("tray: {center: [0.0, 0.2]}\ntray: {center: [0.1, 0.2]}\n", "line"),
    ("initial_positions: {x: 1.0}\n", None),  # a valid scenario for the commands below
])
@pytest.mark.parametrize("command", [["hardware-sim"], ["demo", "--hardware"]])
def test_a_bus_that_cannot_be_opened_and_a_key_given_twice_are_refused(text, field, command,
                                                                       tmp_path, capsys):
    path = _scenario(tmp_path, text)
    if field is None:  # a sound scenario on memq:// is refused too: no other process hears it
        line = _refused([*command, "--scenario", str(path)], capsys)
        assert "'memq://', which no other process can reach" in line
        return
    line = _refused([*command, "--scenario", str(path)], capsys)
    assert str(path) in line and field in line


def test_a_negative_pile_seed_in_a_scenario_is_refused(tmp_path, capsys):
    text = (diagrams_dir() / "floating_gripper.yaml").read_text().replace("seed: 0", "seed: -4")
    path = tmp_path / "negative.yaml"
    path.write_text(text)
    line = _refused(["scene", "--scenario", str(path), "--out", str(tmp_path / "s")], capsys)
    assert "'pile.seed' must be a non-negative 63-bit integer" in line
    assert not (tmp_path / "s").exists()


def test_a_model_added_twice_is_refused_naming_it(tmp_path, capsys):
    path = _scenario(tmp_path, "")
    text = path.read_text().replace(
        "    file: package://gantry/floating_gripper.dmd.yaml\n",
        "    file: package://gantry/floating_gripper.dmd.yaml\n"
        "- add_model: {name: gripper, file: package://gantry/gantry.sdf}\n")
    path.write_text(text)
    line = _refused(["diagram", "--scenario", str(path)], capsys)
    assert "'directives' add the model 'gripper' more than once" in line


def test_a_refused_scene_leaves_no_output_folder(tmp_path, capsys):
    path = _scenario(tmp_path, "")  # a camera 5 m beside the bin, looking down
    path.write_text(path.read_text().replace("camera_height: 0.5", "camera_height: null")
                    .replace("  renderer_class: RenderEngineVtk\n",
                             "  renderer_class: RenderEngineVtk\n"
                             "  X_PB: {translation: [5.0, 0.0, 1.5], rotation: !Rpy "
                             "{deg: [180.0, 0.0, 0.0]}}\n", 1))
    out = tmp_path / "deep" / "scene"
    line = _refused(["scene", "--scenario", str(path), "--out", str(out)], capsys)
    assert "the top camera sees nothing of the bin" in line
    assert not (tmp_path / "deep").exists()


def test_diagram_depth_must_not_be_negative(capsys):
    assert "--depth must be 0 or more, got -1" in _refused(["diagram", "--depth", "-1"], capsys)


def test_hardware_sim_duration_must_be_positive(capsys):
    line = _refused(["hardware-sim", "--duration", "-5"], capsys)
    assert "--duration must be positive, got -5" in line


def test_train_refuses_an_out_it_cannot_write_before_training(tmp_path, capsys, monkeypatch):
    data = tmp_path / "data"
    write_synthetic_dataset(data, 40, size_px=32, size_m=0.05, seed=1)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    from tangle_drake.tangle_cnn import train as train_module

    def no_epoch(*args, **kwargs):
        raise AssertionError("an epoch ran before --out was checked")

    monkeypatch.setattr(train_module, "_run_epoch", no_epoch)
    line = _refused(["train", "--data", str(data), "--out", str(blocker / "m.pt")], capsys)
    assert f"--out {blocker / 'm.pt'}: {blocker} is not a directory" in line
