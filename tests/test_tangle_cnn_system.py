"""TangleCnnSystem in a tiny diagram: constant depth image, hand-made candidates."""

from dataclasses import dataclass

import numpy as np
import pytest
import torch
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.perception.crops import CropSpec
from tangle_drake.selection.cnn_system import TangleCnnSystem
from tangle_drake.selection.methods import GraspSelector, MethodRun
from tangle_drake.selection.rules import ScoredCandidate, rank
from tangle_drake.tangle_cnn.model import TangleModel
from tangle_drake.tangle_cnn.network import NetworkConfig, TangleNet
from tangle_drake.tangle_cnn.normalise import DEFAULT_NORMALISATION

INTRINSICS = CameraIntrinsics.from_fov_y(80, 60, 45)


@dataclass(frozen=True)
class Candidate:
    u: float
    v: float
    angle_deg: float
    width_m: float
    depth_m: float
    score: float
    X_WT: object = None


CANDIDATES = [Candidate(20, 30, 0, 0.03, 0.785, 0.9), Candidate(50, 20, 45, 0.03, 0.79, 0.6),
              Candidate(60, 45, -30, 0.03, 0.78, 0.3)]


@pytest.fixture(scope="module")
def model() -> TangleModel:
    torch.manual_seed(0)
    return TangleModel(TangleNet(NetworkConfig(input_size=32)), CropSpec(0.05, 32),
                       DEFAULT_NORMALISATION)


@pytest.fixture(scope="module")
def depth() -> np.ndarray:
    rng = np.random.default_rng(0)
    return (0.8 - 0.03 * rng.random((60, 80))).astype(np.float32)


def build(model, depth, candidates, rule="harmonic", seed=0):
    builder = DiagramBuilder()
    system = builder.AddSystem(TangleCnnSystem(model, INTRINSICS, rule, seed))
    image = ImageDepth32F(INTRINSICS.width, INTRINSICS.height)
    image.mutable_data[:, :, 0] = depth
    image_source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(image)))
    candidate_source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(candidates)))
    builder.Connect(image_source.get_output_port(), system.GetInputPort("depth_image"))
    builder.Connect(candidate_source.get_output_port(), system.GetInputPort("candidates"))
    diagram = builder.Build()
    context = system.GetMyContextFromRoot(diagram.CreateDefaultContext())
    return system, context


@pytest.mark.parametrize("rule", ["harmonic", "cnn", "graspability"])
def test_scores_every_candidate_and_selects_by_the_rule(model, depth, rule):
    system, context = build(model, depth, CANDIDATES, rule)
    scored = system.GetOutputPort("scored_candidates").Eval(context)
    p = model.predict_candidates(depth, INTRINSICS, CANDIDATES)
    expected = rank(rule, np.array([c.score for c in CANDIDATES]), p)
    # Best first, in the rule's order: the order the planner tries them in.
    assert [s.candidate for s in scored] == [CANDIDATES[i] for i in expected.order]
    assert all(isinstance(s, ScoredCandidate) for s in scored)
    assert np.allclose([s.p_model for s in scored], p[expected.order])
    assert {s.p_model_name for s in scored} == {"P(not tangled)"}  # what the model predicts
    assert np.allclose([s.score for s in scored], expected.scores[expected.order])
    # Drake copies abstract values between ports: equal, not identical.
    assert system.GetOutputPort("selected_grasp").Eval(context) == CANDIDATES[expected.order[0]]


def test_random_draws_as_the_grasp_selector_does_without_a_cnn(model, depth):
    """The CNN system and the grasp selector without a CNN draw the same candidate per seed
    (the rule is ``rules.rank``'s in both), and the seed changes the draw."""
    picks = []
    for seed in range(8):
        system, context = build(model, depth, CANDIDATES, "random", seed=seed)
        drawn = system.GetOutputPort("selected_grasp").Eval(context)
        selector = GraspSelector([], MethodRun("random", seed))
        selector_context = selector.CreateDefaultContext()
        selector.GetInputPort("candidates").FixValue(selector_context, CANDIDATES)
        assert selector.GetOutputPort("selected_grasp").Eval(selector_context) == drawn
        picks.append(CANDIDATES.index(drawn))
    assert len(set(picks)) > 1 and max(picks) < 5


def test_no_candidates_select_none(model, depth):
    system, context = build(model, depth, [])
    assert system.GetOutputPort("scored_candidates").Eval(context) == []
    assert system.GetOutputPort("selected_grasp").Eval(context) is None


def test_bad_arguments(model, depth, tmp_path):
    with pytest.raises(TangleDrakeError, match="unknown selection rule"):
        TangleCnnSystem(model, INTRINSICS, "best")
    with pytest.raises(TangleDrakeError, match="not found"):
        TangleCnnSystem(tmp_path / "missing.pt", INTRINSICS)


def test_the_cnn_runs_once_for_both_outputs(model, depth, monkeypatch):
    calls = []
    real = model.predict_candidates
    monkeypatch.setattr(model, "predict_candidates", lambda *args: calls.append(1) or real(*args))
    system, context = build(model, depth, CANDIDATES)
    system.GetOutputPort("selected_grasp").Eval(context)
    system.GetOutputPort("scored_candidates").Eval(context)
    system.GetOutputPort("selected_grasp").Eval(context)
    assert len(calls) == 1
