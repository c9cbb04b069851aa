"""Which tangle CNN and selection rule a pick uses: the one place that decides it.

Trained models ship as ``tangle_drake/trained/<part>.pt``. With one (or a ``--model`` file)
the paper's ``harmonic`` rule is the default; without, picking falls back to the graspability
index alone and says so, since a rule that needs the CNN cannot run without it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from tangle_drake.errors import TangleDrakeError
from tangle_drake.tangle_cnn.selection import check_rule

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


def trained_model_path(part: str) -> Path:
    """Where the shipped model for ``part`` (a built-in name or a mesh's stem) would be."""
    return TRAINED_DIR / f"{Path(part).stem}.pt"


def resolve_tangle_choice(part: str, rule: str | None = None,
                          model: str | Path | None = None) -> TangleChoice:
    """The model and rule for picking ``part``.

    ``model`` (a checkpoint path) wins; else the shipped ``trained/<part>.pt``; else no model,
    which allows only the graspability rule. ``rule`` defaults to ``harmonic`` with a model.
    Raises ``TangleDrakeError`` for an unknown rule, a missing ``model`` file, or a rule that
    needs a model when there is none.
    """
    if rule is not None:
        check_rule(rule)
    if model is not None:
        path = Path(model)
        if not path.is_file():
            raise TangleDrakeError(f"model file not found: {path}")
        return TangleChoice(path, rule or "harmonic")
    shipped = trained_model_path(part)
    if shipped.is_file():
        return TangleChoice(shipped, rule or "harmonic")
    if rule not in (None, FALLBACK_RULE):
        raise TangleDrakeError(
            f"rule {rule!r} needs a tangle model, and there is none for part {part!r} "
            f"({shipped} does not exist): pass --model PATH, or --rule {FALLBACK_RULE}")
    notice = None if rule == FALLBACK_RULE else (
        f"notice: no trained tangle model for part {part!r} ({shipped} does not exist); "
        f"selecting by the {FALLBACK_RULE} index alone. Train one with `tangle-drake train` "
        f"and pass --model, or install it there, for the paper's harmonic rule.")
    return TangleChoice(None, FALLBACK_RULE, notice)
