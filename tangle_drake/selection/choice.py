"""Which tangle CNN and selection rule a pick uses: the one place that decides it.

Trained models ship as ``tangle_drake/trained/<part>.pt``. With one (or a ``--model`` file)
the paper's ``harmonic`` rule is the default; without, picking falls back to the graspability
index alone and says so, since a rule that needs the CNN cannot run without it. The
pick diagram selects by the choice with :class:`~tangle_drake.selection.methods.GraspSelector`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import shown_path
from tangle_drake.parts import load_part
from tangle_drake.parts.library import PART_FILE_SUFFIX
from tangle_drake.selection.rules import check_rule, needs_model
from tangle_drake.tangle_cnn.objectives import (
    DEFAULT_OBJECTIVE,
    DEFAULT_RULES,
    Objective,
    checkpoint_objective,
    rule_objective,
)

TRAINED_DIR = Path(__file__).resolve().parent.parent / "trained"
"""Where the package's trained models live, one ``<part>.pt`` per part."""

FALLBACK_RULE = "graspability"


@dataclass(frozen=True)
class TangleChoice:
    """The model (``None``: no CNN in the diagram) and the rule to select with."""

    model: Path | None
    rule: str
    notice: str | None = None
    """Something the user should read (a fallback), or ``None``."""


def trained_model_path(part: str | Path, objective: str = DEFAULT_OBJECTIVE) -> Path:
    """Where the model of ``objective`` for ``part`` would be: for a built-in name or a mesh,
    the shipped ``<part>.pt`` (``<part>.<objective>.pt`` for another objective); for a part
    file, ``model.pt`` beside it, where ``tangle-drake teach`` writes the one it makes."""
    suffix = "" if objective == DEFAULT_OBJECTIVE else f".{objective}"
    if Path(part).suffix.lower() == PART_FILE_SUFFIX:
        return Path(part).parent / f"model{suffix}.pt"
    return TRAINED_DIR / f"{Path(part).stem}{suffix}.pt"


def resolve_tangle_choice(part: str, rule: str | None = None,
                          model: str | Path | None = None) -> TangleChoice:
    """The model and rule for picking ``part``.

    ``model`` (a checkpoint path) wins; else the shipped ``trained/<part>.pt`` (for
    ``success-cnn``, ``trained/<part>.success.pt``); else no model, which allows the rules that
    need no CNN (``graspability``, the default then, and ``random``). ``rule`` defaults to
    ``harmonic`` with a model (``success-cnn`` with a success/failure ``model``).
    Raises ``TangleDrakeError`` for an unknown rule, a missing ``model`` file, or a rule that
    needs a model when there is none.
    """
    if rule is not None:
        check_rule(rule)
    if model is not None:
        path = Path(model)
        if not path.is_file():
            raise TangleDrakeError(f"model file not found: {path}")
        return TangleChoice(path, rule or default_rule(path))
    shipped = trained_model_path(part, rule_objective(rule).name if rule else DEFAULT_OBJECTIVE)
    if shipped.is_file():
        return TangleChoice(shipped, rule or "harmonic")
    if rule is not None and needs_model(rule):
        raise TangleDrakeError(
            f"rule {rule!r} needs a tangle model, and there is none for part {part!r} "
            f"({shipped} does not exist): pass --model PATH, or --rule {FALLBACK_RULE}")
    if rule is not None:
        return TangleChoice(None, rule)
    notice = (
        f"notice: no trained tangle model for part {part!r} ({shipped} does not exist); "
        f"selecting by the {FALLBACK_RULE} index alone. Train one with `tangle-drake train` "
        f"and pass --model, or install it there, for the paper's harmonic rule.")
    return TangleChoice(None, FALLBACK_RULE, notice)


def model_objective(model: Path) -> Objective:
    """What the checkpoint at ``model`` predicts (its objective)."""
    from tangle_drake.tangle_cnn.checkpoint import read_checkpoint  # imports torch

    return checkpoint_objective(read_checkpoint(Path(model)))


def default_rule(model: Path) -> str:
    """The rule the checkpoint at ``model`` picks with unless told: ``harmonic`` for a tangle
    CNN, ``success-cnn`` for a success/failure CNN."""
    return DEFAULT_RULES[model_objective(model).name]


def model_part_notice(model: Path, part: str) -> str | None:
    """A warning when the checkpoint at ``model`` was trained on another part than ``part``
    (a built-in name, a mesh file or a part file): it still runs, but its probability means
    little."""
    from tangle_drake.tangle_cnn.checkpoint import read_checkpoint  # imports torch

    trained_on = read_checkpoint(Path(model)).get("part")
    name = load_part(part).name if Path(part).suffix.lower() == PART_FILE_SUFFIX else \
        Path(part).stem  # a part file names its mesh's part
    if trained_on is None or str(trained_on) == name:
        return None
    return (f"warning: the tangle model {shown_path(model)} was trained on part "
            f"{trained_on!r}, and the pile is of {name!r}: its P(not tangled) is not this "
            "part's")
