"""``TangleCnnSystem``: the tangle CNN and the selection rule as a Drake system.

========================= ====== ==========================================================
port                      dir    value
========================= ====== ==========================================================
``depth_image``           in     ``ImageDepth32F``, metres (``camera.depth_image``)
``candidates``            in     list of grasp candidates (``u, v, angle_deg, width_m,
                                 depth_m, score, X_WT``; graspability's top-k)
``scored_candidates``     out    list of ``ScoredCandidate(candidate, p_model, score,
                                 p_model_name)``
                                 in the rule's order, best first (``selection.rank``)
``selected_grasp``        out    the chosen candidate (the first), or ``None`` when there is
                                 none
========================= ====== ==========================================================

Both outputs come from one cache entry that depends on the two inputs only, so the CNN runs
once per new image or candidate list however many ports are read. The ``random`` rule draws
from ``seed`` and the candidates' poses, which keeps the outputs a function of the inputs (as
Drake requires) while differing between candidate lists.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem, ValueProducer
from pydrake.systems.sensors import ImageDepth32F

from tangle_drake.perception.camera import CameraIntrinsics
from tangle_drake.selection.rules import ScoredCandidate, check_rule, rank_candidates
from tangle_drake.tangle_cnn.model import TangleModel, load_tangle_model
from tangle_drake.tangle_cnn.objectives import check_serves

WARM_UP_CANDIDATES = 16
"""Candidates the network is warmed up for: at least the pick diagram's graspability top-k
(10); a smaller batch then needs no new buffers."""


class _Result(NamedTuple):
    scored: list[ScoredCandidate]
    selected: Any


class TangleCnnSystem(LeafSystem):
    """Scores grasp candidates with the tangle CNN and selects one by ``rule``."""

    def __init__(self, model: TangleModel | Path | str, intrinsics: CameraIntrinsics,
                 rule: str = "harmonic", seed: int = 0, warm_up: int = WARM_UP_CANDIDATES) -> None:
        """``warm_up``: predict once for that many candidates now, so the first pick does
        not pay torch's first-call costs (0: do not)."""
        super().__init__()
        self._model = model if isinstance(model, TangleModel) else load_tangle_model(model)
        self._rule = check_rule(rule)
        check_serves(self._rule, self._model.objective, self._model.source)
        if warm_up > 0:
            self._model.warm_up(warm_up)
        self._intrinsics = intrinsics
        self._seed = seed
        depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F(intrinsics.width, intrinsics.height)))
        candidates = self.DeclareAbstractInputPort("candidates", AbstractValue.Make([]))
        self._result = self.DeclareCacheEntry(
            "tangle CNN scores and selection",
            ValueProducer(allocate=lambda: AbstractValue.Make(_Result([], None)),
                          calc=self._calc_result),
            {depth.ticket(), candidates.ticket()})
        self.DeclareAbstractOutputPort(
            "scored_candidates", lambda: AbstractValue.Make([]),
            lambda context, value: value.set_value(self._result.Eval(context).scored),
            {self._result.ticket()})
        self.DeclareAbstractOutputPort(
            "selected_grasp", lambda: AbstractValue.Make(None),
            lambda context, value: value.set_value(self._result.Eval(context).selected),
            {self._result.ticket()})

    def _calc_result(self, context: Context, value: AbstractValue) -> None:
        candidates: Sequence[Any] = list(self.get_input_port(1).Eval(context))
        depth = np.asarray(self.get_input_port(0).Eval(context).data)[:, :, 0]
        p = self._model.predict_candidates(depth, self._intrinsics, candidates)
        scored = rank_candidates(self._rule, candidates, p, self._seed,
                                 p_model_name=self._model.objective.probability)
        value.set_value(_Result(scored, scored[0].candidate if scored else None))
