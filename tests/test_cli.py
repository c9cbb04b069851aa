"""The ``tangle-drake`` entry point's own behaviour (each subcommand has its own tests)."""

import subprocess
import sys

import pytest

import tangle_drake.commands.diagram as diagram_command
from tangle_drake.cli import SIGPIPE_EXIT, main


def test_a_reader_that_goes_away_ends_the_command_quietly(tmp_path):
    """``tangle-drake ... | head``: the reader closes the pipe before the command prints."""
    out = tmp_path / "station.dot"
    process = subprocess.Popen(
        [sys.executable, "-m", "tangle_drake.cli", "diagram", "--scenario", "pile_only.yaml",
         "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    process.stdout.close()  # long before the command prints "wrote ..."
    err = process.stderr.read().decode()
    assert process.wait(timeout=300) == SIGPIPE_EXIT
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert out.read_text().startswith("digraph")  # the work itself was done


def test_a_broken_pipe_elsewhere_is_not_hidden(monkeypatch):
    def broken(args):
        raise BrokenPipeError("a worker's pipe")

    monkeypatch.setattr(diagram_command, "run", broken)
    with pytest.raises(BrokenPipeError, match="a worker's pipe"):
        main(["diagram"])


def test_a_path_that_cannot_be_written_is_named_without_a_traceback(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["scene", "--scenario", "pile_only.yaml", "--out", str(blocker / "x")]) == 2
    err = capsys.readouterr().err
    assert f"--out {blocker / 'x'}: {blocker} is not a directory" in err
    assert "Traceback" not in err
