"""What a model learns to predict (its objective), the one place for it: which dataset field its
labels come from, what its classes are, and which selection rules its probability serves.

The network is the same for every objective; class 0 is always the good outcome, so a model's
prediction is P(class 0):

- ``tangled``, the paper's tangle CNN: P(not tangled), from ``label`` (the auto-lift's or a
  pick's);
- ``success``, the seed's success/failure baseline (Matsumura et al. 2018): P(exactly one
  part), from ``outcome``, the physical pick's (failure: several parts or none);
- ``outcome``, the pick-outcome model: three classes from ``outcome``, one part / several /
  none, so it also tells a tangle from an empty grasp; its P(class 0) is P(exactly one part)
  too, so it serves the same rules as the success CNN.

A checkpoint names its objective; one made before objectives existed is a tangle CNN.
Torch-free.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from tangle_drake.common.errors import TangleDrakeError


@dataclass(frozen=True)
class Objective:
    name: str
    classes: tuple[str, ...]
    """Class 0 (the good outcome, whose probability the model gives), then the others."""
    field: str
    """The dataset field the labels come from."""
    codes: dict[int, int]
    """Field value -> class; other values (-1: no label) are left out."""
    data: str
    """How to make data with this field, for error messages."""
    balance: str = "undersample"
    """How ``train`` evens out its classes unless told (``split.BALANCES``)."""
    prior_corrected: bool = False
    """Whether the model's probabilities are moved back from the equal class shares it trained
    on (undersampled, or weighted in the loss: ``split.BALANCES``) to its data's own shares
    (:func:`prior_weights`). A pick model's P(one part) is then the chance that the pick
    brings up one part, which a rate or a recovery plan can use (on the S-hook's test piles the
    outcome model's calibration error fell from 31 to 10 points); the tangle CNN keeps the
    paper's balanced output, which its harmonic-mean rule was made with."""

    @property
    def failure(self) -> str:
        """The words for the samples not of class 0 (its class 1 where there are two), e.g.
        ``tangled``, ``not one part``."""
        return self.classes[1] if len(self.classes) == 2 else f"not {self.classes[0]}"

    @property
    def probability(self) -> str:
        """The words for what the model predicts, e.g. ``P(not tangled)``."""
        return f"P({self.classes[0]})"

    def labels(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The class of each labelled row of ``values`` (the field), and which rows those are."""
        values = np.asarray(values).astype(np.int64)
        labelled = np.isin(values, list(self.codes))
        lookup = np.vectorize(self.codes.__getitem__, otypes=[np.int64])
        return (lookup(values[labelled]) if labelled.any() else
                np.zeros(0, dtype=np.int64)), labelled


TANGLED = Objective("tangled", ("not tangled", "tangled"), "label", {0: 0, 1: 1},
                    "`tangle-drake collect` (either --label)")
_PICKS = "`tangle-drake collect --label pick` (or a pick log)"
SUCCESS = Objective("success", ("success", "failure"), "outcome", {1: 0, 2: 1, 0: 1}, _PICKS,
                    balance="weight", prior_corrected=True)
OUTCOME = Objective("outcome", ("one part", "several parts", "no part"), "outcome",
                    {1: 0, 2: 1, 0: 2}, _PICKS, balance="weight", prior_corrected=True)
OBJECTIVES = {o.name: o for o in (TANGLED, SUCCESS, OUTCOME)}
DEFAULT_OBJECTIVE = TANGLED.name

RULE_OBJECTIVES = {"cnn": (TANGLED,), "harmonic": (TANGLED,), "emap-harmonic": (TANGLED,),
                   "success-cnn": (SUCCESS, OUTCOME), "success-harmonic": (SUCCESS, OUTCOME)}
"""The models each rule that needs one can read, the first the one shipped for it."""
DEFAULT_RULES = {TANGLED.name: "harmonic", SUCCESS.name: "success-cnn",
                 OUTCOME.name: "success-harmonic"}
"""The rule a model of each objective picks with unless told otherwise."""


def rule_objective(rule: str) -> Objective:
    """The objective of the model shipped for ``rule`` (a tangle CNN for rules that read
    none)."""
    return RULE_OBJECTIVES.get(rule, (TANGLED,))[0]


def objective_named(name: str) -> Objective:
    if name not in OBJECTIVES:
        raise TangleDrakeError(f"unknown objective {name!r}; choose one of "
                               f"{', '.join(OBJECTIVES)}")
    return OBJECTIVES[name]


def checkpoint_objective(info: dict[str, Any]) -> Objective:
    """The objective of a checkpoint's metadata (a tangle CNN if it names none)."""
    return objective_named(str(info.get("objective") or DEFAULT_OBJECTIVE))


def prior_weights(objective: Objective, data: dict[str, Any]) -> np.ndarray | None:
    """Each class's share of the training data (a checkpoint's ``data`` summary), by which a
    prior-corrected objective's probabilities are multiplied and then renormalised: a network
    trained on balanced classes gives p(class | crop) under equal priors, and Bayes' rule moves
    it to the data's. ``None`` where nothing is corrected (the objective keeps balanced output,
    or the checkpoint lacks its class counts)."""
    counts = data.get("class_counts") if objective.prior_corrected else None
    if not isinstance(counts, dict):
        return None
    shares = np.array([float(counts.get(name, 0)) for name in objective.classes])
    if not (np.isfinite(shares).all() and (shares > 0).all()):
        return None
    return shares / shares.sum()


def check_serves(rule: str, objective: Objective, model: object) -> None:
    """Refuse a ``model`` (named in the message) of ``objective`` for a ``rule`` it cannot
    serve."""
    served = RULE_OBJECTIVES.get(rule)
    if served is None or objective in served:
        return
    fitting = [r for r, objectives in RULE_OBJECTIVES.items() if objective in objectives]
    needed = served[0]
    raise TangleDrakeError(
        f"the {rule} rule needs a model of {needed.probability} (trained with --objective "
        f"{' or '.join(o.name for o in served)}); {model} predicts {objective.probability} "
        f"(--objective {objective.name}): use it with the {' or '.join(fitting)} rule")
