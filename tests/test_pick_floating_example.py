"""``examples/floating_gripper.py``: the planner with another ``Motion``, in another
diagram, with the tangle CNN wired in (an untrained one: the wiring is what is tested)."""

import importlib.util
from pathlib import Path

import torch

from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.outcome import Outcome
from tangle_drake.tangle_cnn.checkpoint import model_checkpoint, save_atomic
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "floating_gripper.py"


def load_example():
    spec = importlib.util.spec_from_file_location("floating_gripper", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_floating_gripper_picks_with_the_shared_state_machine(tmp_path, capsys):
    torch.manual_seed(0)
    config = NetworkConfig(input_size=32)
    model = tmp_path / "untrained.pt"
    save_atomic(model_checkpoint(config, CropSpec(0.05, 32), DEFAULT_NORMALISATION,
                                 TangleNet(config).state_dict(), part="u_hook"), model)

    records = load_example().run(picks=1, parts=5, seed=0, model=str(model), rule="harmonic")

    assert len(records) == 1
    record = records[0]
    assert record.outcome is not Outcome.FAILED, record.reason
    assert record.p_model is not None  # the CNN scored the candidates
    assert record.truth.lifted is not None
    assert "1 pick(s): " in capsys.readouterr().out
