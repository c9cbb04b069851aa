"""``tangle-drake demo``'s refusals, and which model and rule a part gets."""

from functools import partial

import pytest
from cli_run import run_command

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.selection import choice as selection
from tangle_drake.selection.choice import resolve_tangle_choice

run_demo_command = partial(run_command, "demo")


@pytest.mark.parametrize(("argv", "message"), [
    (["--part", "no_such_part"], "unknown part 'no_such_part'"),
    (["--model", "missing.pt"], "model file not found: missing.pt"),
    (["--rule", "cnn"], "rule 'cnn' needs a tangle model"),
    (["--picks", "0"], "--picks must be at least 1"),
    (["--record", "demo.txt"], "--record must name an .html file"),
    (["--scenario", "no/such.yaml"], "cannot read scenario file"),
    (["--scenario", "pile_only.yaml"], "picking needs a robot: .* exactly one !NextageDriver"),
    (["--with-hardware-sim"], "--with-hardware-sim goes with --hardware"),
    (["--hardware", "--meshcat"], "with --hardware there is none in the controller"),
    (["--hardware"], "'memq://', which no other process can reach"),
])
def test_bad_arguments_are_refused_with_a_clear_message(argv, message, tmp_path, monkeypatch):
    monkeypatch.setattr(selection, "TRAINED_DIR", tmp_path)  # no shipped models
    with pytest.raises(TangleDrakeError, match=message):
        run_demo_command(*argv)


def test_an_unknown_rule_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit):
        run_demo_command("--rule", "best")
    assert "invalid choice: 'best'" in capsys.readouterr().err


def test_without_a_trained_model_the_graspability_rule_is_used_with_a_notice(tmp_path,
                                                                           monkeypatch):
    monkeypatch.setattr(selection, "TRAINED_DIR", tmp_path)
    choice = resolve_tangle_choice("u_hook")
    assert choice.model is None and choice.rule == "graspability"
    assert "no trained tangle model for part 'u_hook'" in choice.notice
    # Asking for graspability explicitly needs no notice; random needs no model either.
    assert resolve_tangle_choice("u_hook", "graspability").notice is None
    assert resolve_tangle_choice("u_hook", "random") == selection.TangleChoice(None, "random")


def test_a_shipped_model_is_used_with_the_harmonic_rule(tmp_path, monkeypatch):
    monkeypatch.setattr(selection, "TRAINED_DIR", tmp_path)
    (tmp_path / "u_hook.pt").write_bytes(b"weights")
    choice = resolve_tangle_choice("u_hook")
    assert choice.model == tmp_path / "u_hook.pt" and choice.rule == "harmonic"
    assert choice.notice is None
    assert resolve_tangle_choice("u_hook", "random").rule == "random"


def test_an_explicit_model_wins(tmp_path):
    model = tmp_path / "mine.pt"
    model.write_bytes(b"weights")
    assert resolve_tangle_choice("c_ring", "cnn", model) == selection.TangleChoice(model, "cnn")


def test_the_closed_loop_needs_a_tray_and_says_how_to_pick_without(tmp_path, monkeypatch):
    monkeypatch.setattr(selection, "TRAINED_DIR", tmp_path)
    text = (diagrams_dir() / "pick_demo.yaml").read_text()
    start = text.index("tray:")
    no_tray = text[:start] + text[text.index("pile:"):]
    (tmp_path / "no_tray.yaml").write_text(no_tray)
    with pytest.raises(TangleDrakeError, match=r"needs a 'tray'.*--open-loop"):
        run_demo(DemoOptions(scenario=tmp_path / "no_tray.yaml"), say=lambda _: None)
