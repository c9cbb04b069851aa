"""The path helpers of ``tangle_drake.common.paths``: how results record the paths they were
given."""

from pathlib import Path

from tangle_drake.cli import build_parser
from tangle_drake.commands.bench import command_line
from tangle_drake.common.paths import PLACEHOLDER, shown_path

ROOT = Path(__file__).resolve().parent.parent


def test_a_recorded_path_names_nothing_of_the_machine(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # relative: as given
    assert shown_path("data/u_hook_test") == "data/u_hook_test"
    assert shown_path(Path("../runs/x.pt")) == "../runs/x.pt"
    assert shown_path("u_hook") == "u_hook"  # a built-in part's name is no path
    # inside the repository: relative to it, wherever the command ran
    assert shown_path(ROOT / "tangle_drake" / "trained" / "u_hook.pt") == \
        "tangle_drake/trained/u_hook.pt"
    assert shown_path(f"{ROOT}/docs/../diagrams/pick_demo.yaml") == "diagrams/pick_demo.yaml"
    assert shown_path(ROOT) == "."
    # inside the working directory: relative to it
    assert shown_path(tmp_path / "runs" / "closed_s41") == "runs/closed_s41"
    # elsewhere: its name under the placeholder
    monkeypatch.chdir(ROOT)
    assert shown_path(tmp_path / "runs" / "closed_s41") == f"{PLACEHOLDER}/closed_s41"
    assert shown_path("/work/runs/pickdata/u_hook_pick_test") == "DATA/u_hook_pick_test"


def test_the_benchmark_records_its_command_with_shown_paths(tmp_path, monkeypatch):
    """As the command line gives them: through the real parser, a base scenario with an overlay
    file and an overlay text (each a list, as ``nargs`` and ``append`` make them)."""
    monkeypatch.chdir(ROOT)
    args = build_parser().parse_args([
        "bench", "--methods", "graspability", f"model:{tmp_path / 'a' / 'model.pt'}",
        f"success-cnn:{ROOT / 'tangle_drake' / 'trained' / 'u_hook.outcome.pt'}",
        "--parts", "u_hook", str(tmp_path / "hook.obj"), "--trials", "2", "--workers", "2",
        "--scenario", str(ROOT / "diagrams" / "dense_bin.yaml"), str(tmp_path / "freeze.yaml"),
        "--scenario-text", "pile: {seed: 3}", "--out", str(tmp_path / "closed_s41")])
    assert command_line(args) == (
        "tangle-drake bench --methods graspability model:DATA/model.pt "
        "success-cnn:tangle_drake/trained/u_hook.outcome.pt --parts u_hook DATA/hook.obj "
        "--trials 2 --scenario diagrams/dense_bin.yaml DATA/freeze.yaml "
        "--scenario-text 'pile: {seed: 3}' --out DATA/closed_s41")
