"""What ``tangle-drake train`` is asked to do: its settings and their defaults, torch-free so
the command line can show them without importing torch."""

from __future__ import annotations

from dataclasses import dataclass

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.tangle_cnn.objectives import DEFAULT_OBJECTIVE, objective_named
from tangle_drake.tangle_cnn.split import BALANCES

TRAIN_THREADS = 1
"""Torch threads of the runs that make models to keep (the shipped ones, ``teach``'s): another
count sums in another order and gives slightly different weights, so one count makes the same
model on every machine."""

AUGMENTATIONS: dict[str, int] = {"d4": 8, "none": 1}
"""Augmentation name -> number of transforms (transform ids 0..n-1)."""


@dataclass(frozen=True)
class TrainSettings:
    """What ``tangle-drake train`` was asked to do; stored in the checkpoint."""

    epochs: int = 40
    batch_size: int = 64
    lr: float = 3e-4
    """Adam's step size. At 1e-3 the network memorised the ~1,000-sample datasets within a
    few epochs of starting to learn; at 3e-4 it generalises best around epochs 5-10."""
    seed: int = 0
    patience: int = 8
    """Stop after this many epochs without a lower validation loss (the loss on small
    validation parts is noisy, and learning starts slowly from He initialisation)."""
    augment: str = "d4"
    validation_fraction: float = 0.1
    target_mask: bool = True
    """Give the network a second channel marking the target part's pixels
    (:mod:`.target_mask`); ``False`` trains on the paper's plain depth crop."""
    objective: str = DEFAULT_OBJECTIVE
    """What the model learns to predict (:mod:`.objectives`): ``tangled``, the paper's tangle
    CNN, or ``success``, the seed's success/failure baseline (from physical picks)."""
    balance: str | None = None
    """How the classes are evened out (``split.BALANCES``); ``None``: the objective's way
    (``Objective.balance``), set when the settings are made."""

    def __post_init__(self) -> None:
        if self.augment not in AUGMENTATIONS:
            raise TangleDrakeError(f"unknown augmentation {self.augment!r}; choose one of "
                                   f"{', '.join(AUGMENTATIONS)}")
        if self.epochs < 1 or self.batch_size < 1 or self.patience < 1:
            raise TangleDrakeError("epochs, batch size and patience must be at least 1")
        if not self.lr > 0:
            raise TangleDrakeError(f"the learning rate must be positive, got {self.lr}")
        if not 0 < self.validation_fraction < 1:
            raise TangleDrakeError("the validation fraction must be between 0 and 1")
        objective = objective_named(self.objective)
        if self.balance is None:
            object.__setattr__(self, "balance", objective.balance)
        if self.balance not in BALANCES:
            raise TangleDrakeError(f"unknown balance {self.balance!r}; choose one of "
                                   f"{', '.join(BALANCES)}")
