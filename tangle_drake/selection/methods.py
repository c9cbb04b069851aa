"""The methods a benchmark compares, and the one system that selects a grasp by any of them.

The methods are :mod:`.registry`'s; the rules' arithmetic, what ``random`` draws from and the
order the planner tries candidates in are :mod:`.rules`'. A rule that reads a model uses the
part's shipped model (``tangle_drake/trained/<part>.pt``, ``<part>.success.pt``, ...) unless a
checkpoint is named. If the tried candidate cannot be reached the planner goes on down the
method's order (graspability's after a random draw).

:class:`GraspSelector` sits between perception and the planner in every pick diagram: the demo
fixes its method, the benchmark switches it on its ``method`` input, so a trial restores one
settled pile and runs each method on it in turn.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem, OutputPort

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.graspability.roi import bin_roi
from tangle_drake.scenario import Scenario
from tangle_drake.selection.choice import (
    TangleChoice,
    default_rule,
    model_objective,
    trained_model_path,
)
from tangle_drake.selection.emap_system import add_emap_selection
from tangle_drake.selection.registry import (
    METHOD_NAMES,
    MODEL_PREFIX,
    MODEL_RULES,
    RULES,
    SHIPPED_MODEL_METHODS,
)
from tangle_drake.selection.rules import (
    ScoredCandidate,
    needs_emap,
    needs_model,
    rank_candidates,
)
from tangle_drake.station import camera_model
from tangle_drake.station.bin_model import inner_corners
from tangle_drake.station.perturb import offset_pose
from tangle_drake.tangle_cnn.objectives import (
    DEFAULT_RULES,
    Objective,
    check_serves,
    objective_named,
    rule_objective,
)


@dataclass(frozen=True)
class Method:
    """One way of choosing a candidate: a selection rule, and the checkpoint it needs."""

    name: str
    rule: str
    model: Path | None = None
    """The user's checkpoint (``model:PATH``); ``None``: the part's shipped model, if the
    rule needs one."""
    shipped: Objective | None = None
    """Which of the part's shipped models it reads; ``None``: the one shipped for its rule."""

    @property
    def objective(self) -> Objective:
        """What the part's shipped model for this method predicts."""
        return self.shipped or rule_objective(self.rule)

    @property
    def needs_model(self) -> bool:
        return needs_model(self.rule)

    @property
    def scored_outside(self) -> bool:
        """Whether a system of its own scores the candidates (a CNN, the entanglement map)."""
        return needs_model(self.rule) or needs_emap(self.rule)

    def model_for(self, part: str | None) -> Path:
        """The checkpoint this method uses on ``part`` (which may not exist)."""
        if self.model is not None:
            return self.model
        if part is None:
            raise TangleDrakeError(f"method {self.name!r} needs a model: name its checkpoint")
        return trained_model_path(part, self.objective.name)


def choice_method(choice: TangleChoice) -> Method:
    """The method a pick's choice of rule and model (:mod:`.choice`) selects by."""
    return Method(choice.rule, choice.rule, None if choice.model is None else Path(choice.model))


def parse_method(text: str) -> Method:
    """A rule's name, ``model:PATH`` (the rule the checkpoint's objective picks with), or
    ``RULE:PATH`` for a rule that reads a model (that rule with the checkpoint at PATH, e.g.
    ``success-cnn:u_hook.outcome.pt``: a pick-outcome model's P(one part) alone)."""
    prefix, colon, rest = text.partition(":")
    own_rule = f"{prefix}:" == MODEL_PREFIX
    if colon and (own_rule or prefix in MODEL_RULES):
        path = Path(rest).expanduser()
        if not path.is_file():
            raise TangleDrakeError(f"method {text!r}: model file not found: {path}")
        if own_rule:
            return Method(f"{MODEL_PREFIX}{shown_path(path)}", default_rule(path),
                          path.resolve())
        check_serves(prefix, model_objective(path), path)
        return Method(f"{prefix}:{shown_path(path)}", prefix, path.resolve())
    if text in SHIPPED_MODEL_METHODS:
        objective = objective_named(SHIPPED_MODEL_METHODS[text])
        return Method(text, DEFAULT_RULES[objective.name], shipped=objective)
    if text not in RULES:
        raise TangleDrakeError(f"unknown method {text!r}; choose from "
                               f"{', '.join(METHOD_NAMES)}, {MODEL_PREFIX}PATH or RULE:PATH")
    return Method(text, text)


def file_digest(path: Path) -> str:
    """SHA-256 of a file, so a run's record names its models and meshes by content."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class MethodRun(NamedTuple):
    """The value of :class:`GraspSelector`'s ``method`` input: which method, which seed."""

    name: str
    seed: int
    only: int | None = None
    """Try graspability's candidate of this rank and no other (the physical-pick data's
    labels: one pick per candidate); ``None``: the method's order."""
    offset: tuple[float, float, float] | None = None
    """An error of the grasp pose the robot executes (x, y in m, a turn about the vertical in
    degrees; :class:`~tangle_drake.station.perturb.PickPhysics`): every candidate's
    ``pose`` is moved by it, what the method saw (``u``, ``v``, ``angle_deg``) is not."""


class GraspSelector(LeafSystem):
    """Orders the candidates as a method says: ``fixed`` (the demo's), or else the method on
    the ``method`` input (a :class:`MethodRun`; the benchmark switches it run by run).

    Inputs: ``candidates`` (graspability's, best first), ``method`` (unless ``fixed``), and
    for each method scored by a system of its own (a CNN, the entanglement map)
    ``{name}.scored_candidates`` and ``{name}.selected_grasp``. Outputs ``scored_candidates``
    (best first) and ``selected_grasp``; only the active method's inputs are evaluated, so a
    CNN runs for its own method only.
    """

    def __init__(self, scored_outside: Sequence[str], fixed: MethodRun | None = None) -> None:
        super().__init__()
        self._fixed = fixed
        self._candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        self._method = None if fixed is not None else self.DeclareAbstractInputPort(
            "method", AbstractValue.Make(MethodRun("graspability", 0)))
        self._cnn = {name: (self.DeclareAbstractInputPort(f"{name}.scored_candidates",
                                                          AbstractValue.Make([])),
                            self.DeclareAbstractInputPort(f"{name}.selected_grasp",
                                                          AbstractValue.Make(None)))
                     for name in scored_outside}
        self.DeclareAbstractOutputPort("scored_candidates", lambda: AbstractValue.Make([]),
                                       self._calc_scored)
        self.DeclareAbstractOutputPort("selected_grasp", lambda: AbstractValue.Make(None),
                                       self._calc_selected)

    def _run(self, context: Context) -> MethodRun:
        return self._fixed if self._method is None else self._method.Eval(context)

    def _calc_scored(self, context: Context, value: AbstractValue) -> None:
        value.set_value(self._scored(context))

    def _calc_selected(self, context: Context, value: AbstractValue) -> None:
        method = self._run(context)
        if method.only is None and method.offset is None and method.name in self._cnn:
            value.set_value(self._cnn[method.name][1].Eval(context))
        else:
            scored = self._scored(context)
            value.set_value(scored[0].candidate if scored else None)

    def _scored(self, context: Context) -> list:
        """The active method's candidates, best first, each moved by the method's offset."""
        method = self._run(context)
        if method.only is None and method.name in self._cnn:
            scored = list(self._cnn[method.name][0].Eval(context))
        else:
            scored = self._ranked(context, method)
        if method.offset is None:
            return scored
        return [s._replace(candidate=replace(s.candidate, pose=offset_pose(
            s.candidate.pose, method.offset))) if s.candidate.pose is not None else s
            for s in scored]

    def _ranked(self, context: Context, method: MethodRun) -> list:
        """The candidates of a rule that needs no system of its own, or graspability's
        candidate ``method.only`` alone (none if there are fewer)."""
        candidates = list(self._candidates.Eval(context))
        if method.only is None:
            return rank_candidates(method.name, candidates, seed=method.seed)
        if method.only >= len(candidates):
            return []
        candidate = candidates[method.only]
        return [ScoredCandidate(candidate, None, float(candidate.score))]


def selection_wiring(methods: Sequence[Method], part: str | None, scenario: Scenario,
                     fixed: MethodRun | None = None):
    """A ``build_pick_diagram`` selection: a ``TangleCnnSystem`` per CNN method and an
    ``EntanglementMapSystem`` per ``emap`` method (over the bin's region of ``scenario``'s
    camera; models loaded once each) into a :class:`GraspSelector`. With ``fixed`` it selects
    by that method; else its ``method`` input is exported as ``method``. ``part`` finds the
    shipped models of methods given none (``None``: every method that reads a model names
    its checkpoint)."""
    camera = camera_model(scenario)
    intrinsics = camera.intrinsics
    roi = bin_roi(camera, inner_corners(scenario.bin))

    def wire(builder: DiagramBuilder, depth: OutputPort,
             candidates: OutputPort) -> tuple[OutputPort, OutputPort]:
        outside = [m for m in methods if m.scored_outside]
        selector = builder.AddNamedSystem("grasp_selector",
                                          GraspSelector([m.name for m in outside], fixed))
        builder.Connect(candidates, selector.GetInputPort("candidates"))
        if fixed is None:
            builder.ExportInput(selector.GetInputPort("method"), "method")
        models: dict[Path, Any] = {}
        for method in outside:
            model = None
            if method.needs_model:
                from tangle_drake.tangle_cnn.model import load_tangle_model  # imports torch

                path = method.model_for(part)
                model = models.setdefault(path, load_tangle_model(path))
            if needs_emap(method.rule):
                ports = add_emap_selection(builder, f"entanglement_map ({method.name})", depth,
                                           candidates, intrinsics, roi, method.rule, model)
            else:
                from tangle_drake.selection.cnn_system import TangleCnnSystem  # imports torch

                cnn = builder.AddNamedSystem(f"tangle_cnn ({method.name})",
                                             TangleCnnSystem(model, intrinsics, method.rule))
                builder.Connect(depth, cnn.GetInputPort("depth_image"))
                builder.Connect(candidates, cnn.GetInputPort("candidates"))
                ports = (cnn.GetOutputPort("scored_candidates"),
                         cnn.GetOutputPort("selected_grasp"))
            for port, source in zip(("scored_candidates", "selected_grasp"), ports, strict=True):
                builder.Connect(source, selector.GetInputPort(f"{method.name}.{port}"))
        return selector.GetOutputPort("scored_candidates"), selector.GetOutputPort(
            "selected_grasp")

    return wire


def fixed_selection(choice: TangleChoice, scenario: Scenario, seed: int = 0):
    """A ``build_pick_diagram`` selection that selects as ``choice`` says (its rule, with its
    model if any); ``seed`` seeds the ``random`` rule."""
    return selection_wiring([choice_method(choice)], None, scenario, MethodRun(choice.rule, seed))
