"""The shipped tangle models: one per built-in part, made for the current crop, gripper and
network, described truthfully by the model card (validation and test figures)."""

import importlib.util
import json
import sys
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pytest

from tangle_drake.parts.catalog import BUILTIN_PARTS
from tangle_drake.perception.crops import DEFAULT_CROP
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.selection.choice import TRAINED_DIR, resolve_tangle_choice, trained_model_path
from tangle_drake.selection.methods import parse_method
from tangle_drake.tangle_cnn.card import validation_row
from tangle_drake.tangle_cnn.model import load_tangle_model
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION
from tangle_drake.tangle_cnn.objectives import DEFAULT_RULES
from tangle_drake.tangle_cnn.target_mask import TargetMask

TOOL = Path(__file__).resolve().parent.parent / "tools" / "make_trained_models.py"


def load_tool():
    """``tools/make_trained_models.py`` as a module (registered, as its dataclasses need)."""
    spec = importlib.util.spec_from_file_location("make_trained_models", TOOL)
    tool = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = tool
    spec.loader.exec_module(tool)
    return tool


@pytest.mark.parametrize("part", BUILTIN_PARTS)
def test_each_built_in_part_ships_a_model_made_for_todays_crop_and_gripper(part):
    path = trained_model_path(part)
    model = load_tangle_model(path)
    info = model.info
    assert info["part"] == part
    assert model.crop == DEFAULT_CROP  # inference crops as the data did
    mask = TargetMask.for_hand(DEFAULT_CROP, DEFAULT_GRIPPER)  # sees which part is the target
    assert model.normalisation == replace(DEFAULT_NORMALISATION, target_mask=mask)
    assert info["gripper"] == json.loads(json.dumps(asdict(DEFAULT_GRIPPER)))
    assert info["data"]["manifest"]["part"] == part
    assert 0.0 <= info["metrics"]["val_accuracy"] <= 1.0
    # It scores crops: probabilities, not constants.
    rng = np.random.default_rng(0)
    crops = 0.5 - 0.04 * rng.random((8, DEFAULT_CROP.size_px, DEFAULT_CROP.size_px))
    p = model.predict(crops.astype(np.float32), np.full(8, 0.5, np.float32))
    assert p.shape == (8,) and np.all((p >= 0) & (p <= 1)) and np.ptp(p) > 0
    # The demo and the benchmark pick it up with the paper's rule.
    assert resolve_tangle_choice(part) == resolve_tangle_choice(part, "harmonic", path)


def test_the_model_card_says_what_the_shipped_files_hold():
    tool = load_tool()
    card = (TRAINED_DIR / "README.md").read_text()
    for part in BUILTIN_PARTS:
        assert validation_row(trained_model_path(part)) in card, part
        tested = tool.test_rows(tool.KINDS["tangled"], part)  # raises for another file's figures
        assert tested is not None, f"{part}: the shipped model was not tested"
        assert tested[0] in card, part


def test_the_model_card_is_what_card_only_writes_with_its_hand_written_sections(tmp_path):
    """Every figure of the card comes from the files: rewriting it changes nothing, and the
    sections written by hand are kept (a card without them is refused, not half-written)."""
    tool = load_tool()
    committed = (TRAINED_DIR / "README.md").read_text()
    card = tmp_path / "README.md"
    card.write_text(committed)
    tool.write_card(list(BUILTIN_PARTS), card)
    assert card.read_text() == committed
    assert "## The physical-pick data" in tool.hand_written(card)
    card.write_text(committed.replace("<!-- /hand-written -->", ""))
    with pytest.raises(tool.TangleDrakeError, match="hand-written"):
        tool.write_card(list(BUILTIN_PARTS), card)
    assert "<!-- /hand-written -->" not in card.read_text()


@pytest.mark.parametrize("objective", ["success", "outcome"])
@pytest.mark.parametrize("part", BUILTIN_PARTS)
def test_a_shipped_physical_pick_model_picks_with_its_rule_and_the_card_describes_it(part,
                                                                                   objective):
    """The success/failure CNN (the seed's baseline) and the pick-outcome model, where
    shipped: learnt from physical picks, picked with by their rules, tested on the card."""
    path = trained_model_path(part, objective)
    if not path.is_file():
        pytest.skip(f"no {objective} model is shipped for {part}")
    model = load_tangle_model(path)
    assert model.objective.name == objective and model.info["part"] == part
    assert model.network.config.classes == {"success": 2, "outcome": 3}[objective]
    assert model.crop == DEFAULT_CROP
    assert model.info["data"]["manifest"]["label"] == "pick"  # learnt from physical picks
    if objective == "success":
        assert resolve_tangle_choice(part, "success-cnn").model == path
    assert parse_method(f"model:{path}").rule == DEFAULT_RULES[objective]
    tool = load_tool()
    card = (TRAINED_DIR / "README.md").read_text()
    assert validation_row(path) in card
    tested = tool.tested(tool.KINDS[objective], part)
    assert tested is not None, f"{part}: the {objective} model was not tested"
    assert tool.card_test_row(tool.KINDS[objective], part, tested) in card


def test_a_part_file_picks_with_the_model_teach_wrote_beside_it(tmp_path):
    import shutil

    part_file = tmp_path / "part.json"
    part_file.write_text(json.dumps({"mesh": "ring.stl", "mesh_scale": 0.001}))
    missing = resolve_tangle_choice(str(part_file))
    assert missing.model is None and str(tmp_path / "model.pt") in missing.notice
    shutil.copy(trained_model_path("c_ring"), tmp_path / "model.pt")
    choice = resolve_tangle_choice(str(part_file))
    assert (choice.model, choice.rule, choice.notice) == (tmp_path / "model.pt", "harmonic", None)


def _strings(value: object):
    """Every string inside a checkpoint's nested dicts and lists."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list | tuple):
        for item in value:
            yield from _strings(item)


def test_no_shipped_checkpoint_names_a_path_of_the_machine_that_made_it():
    import torch

    for path in sorted(TRAINED_DIR.glob("*.pt")):
        checkpoint = torch.load(path, weights_only=True)
        absolute = [text for text in _strings(checkpoint) if text.startswith("/")]
        assert absolute == [], f"{path.name}: {absolute}"
