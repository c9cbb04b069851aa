"""The benchmark's methods: how each picks a candidate, and the system that switches them.

==================== =======================================================================
method               the candidate tried first
==================== =======================================================================
``random``          one drawn uniformly among graspability's top 5 (seeded per trial): the
                    baseline that knows nothing but where a grasp is possible
``graspability``    the best graspability index (Domae et al. 2014), no CNN
``cnn``             the highest P(not tangled) from the part's tangle CNN
``harmonic``        the paper's harmonic mean of the two, with the part's tangle CNN
``model:PATH``      the harmonic mean with the checkpoint at PATH (any part of the run); a
                    success/failure checkpoint ranks by its P(success) instead
``RULE:PATH``       a rule that reads a model, with the checkpoint at PATH (one it serves)
``success-cnn``     the seed's second baseline (Matsumura et al. 2018): the highest P(success)
                    from the part's success/failure CNN, ``trained/<part>.success.pt``
``success-harmonic`` the harmonic mean of graspability and that P(success) (a pick-outcome
                    model's P(one part) serves both)
``outcome``         the part's pick-outcome model, ``trained/<part>.outcome.pt``, with the rule
                    it picks with unless told (its P(one part) with graspability, as
                    ``success-harmonic``)
``emap``            Zhang et al. 2021: graspability re-ranked by low entanglement (the
                    topological entanglement map, no training)
``emap-harmonic``   the harmonic mean of graspability, P(not tangled) and 1 - entanglement
==================== =======================================================================

The rules, what ``random`` draws from and the order the planner tries candidates in are
:mod:`tangle_drake.tangle_cnn.selection`'s, the same as the demo's. ``cnn`` and ``harmonic``
use the shipped model ``tangle_drake/trained/<part>.pt``. If the tried candidate cannot be
reached the planner goes on down the method's order (graspability's after a random draw).
One pick diagram serves every method: :class:`MethodSelector` sits between perception and the
planner and follows the method named on its ``method`` input, so a trial restores one settled
pile and runs each method on it in turn.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem, OutputPort

from tangle_drake.bin_model import inner_corners
from tangle_drake.errors import TangleDrakeError
from tangle_drake.graspability.roi import bin_roi
from tangle_drake.paths import shown_path
from tangle_drake.pick.selection import default_rule, model_objective, trained_model_path
from tangle_drake.scenario import Scenario
from tangle_drake.station import camera_model
from tangle_drake.station.perturb import offset_pose
from tangle_drake.tangle_cnn.objectives import (
    DEFAULT_RULES,
    OUTCOME,
    Objective,
    check_serves,
    rule_objective,
)
from tangle_drake.tangle_cnn.selection import (
    MODEL_RULES,
    RULES,
    ScoredCandidate,
    needs_emap,
    needs_model,
    rank_candidates,
)

DEFAULT_METHODS = ("random", "graspability", "cnn", "harmonic", "success-cnn", "outcome")
"""The methods a run compares unless told otherwise: the paper's comparison (graspability, the
seed's success/failure CNN, its tangle CNN with the harmonic mean) with the pick-outcome model
and two controls. Every rule is a method under its own name; the others (``emap``,
``success-harmonic``) on request."""
MODEL_PREFIX = "model:"
SHIPPED_MODEL_METHODS = {OUTCOME.name: OUTCOME}
"""Methods named for a shipped model other than their rule's first (``outcome``: the part's
pick-outcome model, where ``success-harmonic`` reads its success/failure CNN)."""


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

    def model_for(self, part: str) -> Path:
        """The checkpoint this method uses on ``part`` (which may not exist)."""
        return self.model if self.model is not None else \
            trained_model_path(part, self.objective.name)


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
        objective = SHIPPED_MODEL_METHODS[text]
        return Method(text, DEFAULT_RULES[objective.name], shipped=objective)
    if text not in RULES:
        raise TangleDrakeError(f"unknown method {text!r}; choose from "
                               f"{', '.join((*RULES, *SHIPPED_MODEL_METHODS))}, model:PATH or "
                               "RULE:PATH")
    return Method(text, text)


def file_digest(path: Path) -> str:
    """SHA-256 of a file, so a run's record names its models and meshes by content."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class MethodRun(NamedTuple):
    """The value of :class:`MethodSelector`'s ``method`` input: which method, which seed."""

    name: str
    seed: int
    only: int | None = None
    """Try graspability's candidate of this rank and no other (the physical-pick data's
    labels: one pick per candidate); ``None``: the method's order."""
    offset: tuple[float, float, float] | None = None
    """An error of the grasp pose the robot executes (x, y in m, a turn about the vertical in
    degrees; :class:`~tangle_drake.station.perturb.PickPhysics`): every candidate's
    ``pose`` is moved by it, what the method saw (``u``, ``v``, ``angle_deg``) is not."""


class MethodSelector(LeafSystem):
    """Orders the candidates as the method on the ``method`` input says.

    Inputs: ``candidates`` (graspability's, best first), ``method`` (a :class:`MethodRun`),
    and for each CNN method ``{name}.scored_candidates`` and ``{name}.selected_grasp`` (from
    its ``TangleCnnSystem``). Outputs ``scored_candidates`` and ``selected_grasp`` as a
    ``TangleCnnSystem`` has them; only the active method's inputs are evaluated, so the CNN
    runs for the CNN methods only.
    """

    def __init__(self, scored_outside: Sequence[str]) -> None:
        super().__init__()
        self._candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        self._method = self.DeclareAbstractInputPort(
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

    def _calc_scored(self, context: Context, value: AbstractValue) -> None:
        value.set_value(self._scored(context))

    def _calc_selected(self, context: Context, value: AbstractValue) -> None:
        method = self._method.Eval(context)
        if method.only is None and method.offset is None and method.name in self._cnn:
            value.set_value(self._cnn[method.name][1].Eval(context))
        else:
            scored = self._scored(context)
            value.set_value(scored[0].candidate if scored else None)

    def _scored(self, context: Context) -> list:
        """The active method's candidates, best first, each moved by the method's offset."""
        method = self._method.Eval(context)
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


def selection_wiring(methods: Sequence[Method], part: str, scenario: Scenario):
    """A ``build_pick_diagram`` selection: a ``TangleCnnSystem`` per CNN method and an
    ``EntanglementMapSystem`` per ``emap`` method (over the bin's region of ``scenario``'s
    camera; models loaded once each) into a :class:`MethodSelector`, whose ``method`` input
    is exported as ``method``."""
    camera = camera_model(scenario)
    intrinsics = camera.intrinsics
    roi = bin_roi(camera, inner_corners(scenario.bin))

    def wire(builder: DiagramBuilder, depth: OutputPort,
             candidates: OutputPort) -> tuple[OutputPort, OutputPort]:
        outside = [m for m in methods if m.scored_outside]
        selector = builder.AddNamedSystem("method_selector",
                                          MethodSelector([m.name for m in outside]))
        builder.Connect(candidates, selector.GetInputPort("candidates"))
        builder.ExportInput(selector.GetInputPort("method"), "method")
        models: dict[Path, Any] = {}
        for method in outside:
            model = None
            if method.needs_model:
                from tangle_drake.tangle_cnn.model import load_tangle_model  # imports torch

                path = method.model_for(part)
                model = models.setdefault(path, load_tangle_model(path))
            if needs_emap(method.rule):
                from tangle_drake.entanglement.system import add_emap_selection

                ports = add_emap_selection(builder, f"entanglement_map ({method.name})", depth,
                                           candidates, intrinsics, roi, method.rule, model)
            else:
                from tangle_drake.tangle_cnn.system import TangleCnnSystem

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
