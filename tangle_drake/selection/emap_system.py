"""``EntanglementMapSystem``: the entanglement map and the ``emap`` rules as a Drake system.

========================= ====== ==========================================================
port                      dir    value
========================= ====== ==========================================================
``depth_image``           in     ``ImageDepth32F``, metres (``camera.depth_image``)
``candidates``            in     graspability's candidates, best first
``cnn_scored``            in     ``emap-harmonic`` only: a ``TangleCnnSystem``'s
                                 ``scored_candidates`` (for each candidate's P(not tangled))
``entanglement_map``      out    the image's :class:`~.emap.EntanglementMap` (``None``
                                 without candidates)
``scored_candidates``     out    ``ScoredCandidate`` list in the rule's order, best first
``selected_grasp``        out    the chosen candidate, or ``None``
========================= ====== ==========================================================

One cache entry on the inputs computes the map and the ranking, so both run once per look.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    LeafSystem,
    OutputPort,
    ValueProducer,
)
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.entanglement.emap import EmapParams, EntanglementMap, entanglement_map
from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.selection.rules import (
    EMAP_RULES,
    ScoredCandidate,
    needs_model,
    rank_candidates,
)


class _Result(NamedTuple):
    emap: EntanglementMap | None
    scored: list[ScoredCandidate]
    selected: Any


def _pose(candidate: Any) -> tuple[float, float, float]:
    return (float(candidate.u), float(candidate.v), float(candidate.angle_deg))


class EntanglementMapSystem(LeafSystem):
    """Maps a depth image's entanglement and ranks the candidates by an ``emap`` rule."""

    def __init__(self, intrinsics: CameraIntrinsics, roi: np.ndarray | None = None,
                 rule: str = "emap", params: EmapParams | None = None) -> None:
        """``roi``: the bin's region mask (default: the whole image)."""
        super().__init__()
        if rule not in EMAP_RULES:
            raise TangleDrakeError(f"EntanglementMapSystem ranks by {', '.join(EMAP_RULES)}, "
                                   f"not {rule!r}")
        self._rule, self._roi, self._params = rule, roi, params or EmapParams()
        depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(intrinsics.width, intrinsics.height)))
        candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        cnn = self.DeclareAbstractInputPort("cnn_scored", AbstractValue.Make([]))
        self._result = self.DeclareCacheEntry(
            "entanglement map and ranking",
            ValueProducer(allocate=lambda: AbstractValue.Make(_Result(None, [], None)),
                          calc=self._calc_result),
            {depth.ticket(), candidates.ticket(), cnn.ticket()})
        for name, field, empty in (("entanglement_map", "emap", None),
                                   ("scored_candidates", "scored", []),
                                   ("selected_grasp", "selected", None)):
            self.DeclareAbstractOutputPort(
                name, lambda empty=empty: AbstractValue.Make(empty),
                lambda context, value, field=field: value.set_value(
                    getattr(self._result.Eval(context), field)),
                {self._result.ticket()})

    def _calc_result(self, context: Context, value: AbstractValue) -> None:
        candidates = list(self.GetInputPort("candidates").Eval(context))
        if not candidates:  # nothing to rank (an empty bin): no map either
            value.set_value(_Result(None, [], None))
            return
        depth = np.asarray(self.GetInputPort("depth_image").Eval(context).data)[:, :, 0]
        emap = entanglement_map(depth, self._roi, self._params)
        entanglement = emap.at([c.u for c in candidates], [c.v for c in candidates])
        p, name = None, None
        if needs_model(self._rule):
            cnn = self.GetInputPort("cnn_scored")
            if not cnn.HasValue(context):
                raise TangleDrakeError(f"rule {self._rule!r} needs the tangle CNN: connect a "
                                       "TangleCnnSystem's scored_candidates to cnn_scored")
            scored_by_cnn = cnn.Eval(context)
            by_pose = {_pose(s.candidate): s.p_model for s in scored_by_cnn}
            p = np.array([by_pose[_pose(c)] for c in candidates], dtype=np.float64)
            name = next((s.p_model_name for s in scored_by_cnn), None)
        scored = rank_candidates(self._rule, candidates, p, entanglement=entanglement,
                                 p_model_name=name)
        value.set_value(_Result(emap, scored, scored[0].candidate if scored else None))


def add_emap_selection(builder: DiagramBuilder, name: str, depth: OutputPort,
                       candidates: OutputPort, intrinsics: CameraIntrinsics,
                       roi: np.ndarray | None, rule: str,
                       model: Any = None) -> tuple[OutputPort, OutputPort]:
    """Add an :class:`EntanglementMapSystem` named ``name`` for ``rule`` (and, for
    ``emap-harmonic``, a ``TangleCnnSystem`` with ``model``, a checkpoint path or a loaded
    model, to give it P(not tangled)); its ``scored_candidates`` and ``selected_grasp``."""
    emap = builder.AddNamedSystem(name, EntanglementMapSystem(intrinsics, roi, rule))
    builder.Connect(depth, emap.GetInputPort("depth_image"))
    builder.Connect(candidates, emap.GetInputPort("candidates"))
    if needs_model(rule):
        from tangle_drake.selection.cnn_system import TangleCnnSystem  # imports torch

        cnn = builder.AddNamedSystem(f"{name} tangle_cnn",
                                     TangleCnnSystem(model, intrinsics, "harmonic"))
        builder.Connect(depth, cnn.GetInputPort("depth_image"))
        builder.Connect(candidates, cnn.GetInputPort("candidates"))
        builder.Connect(cnn.GetOutputPort("scored_candidates"), emap.GetInputPort("cnn_scored"))
    return emap.GetOutputPort("scored_candidates"), emap.GetOutputPort("selected_grasp")
