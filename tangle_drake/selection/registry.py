"""Every way of choosing a grasp, in one list: ``demo --rule``, ``bench --methods``, their help
texts and the README's table are read from here.

A *rule* (:data:`RULES`) orders one image's candidates (:mod:`.rules` has the arithmetic); a
*method* is what a benchmark compares: a rule by its own name, a rule with a shipped model other
than its own (``outcome``), or a rule with a checkpoint given by path (``model:PATH``,
``RULE:PATH``).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Entry:
    """One registered way of choosing a grasp."""

    name: str
    what: str
    """What it picks, in one line (help texts and the README)."""
    model: bool = False
    """Whether it reads a trained model's probability."""
    emap: bool = False
    """Whether it reads the entanglement map."""
    shipped: str | None = None
    """A method that is not a rule: the objective of the part's shipped model it reads (it
    picks with the rule that objective's models pick with)."""
    pattern: bool = False
    """A method named with a path (``model:PATH``, ``RULE:PATH``)."""


MODEL_PREFIX = "model:"

REGISTRY: tuple[Entry, ...] = (
    Entry("random", "one drawn among graspability's top 5 (seeded): knows nothing but where a "
                    "grasp is possible"),
    Entry("graspability", "the best graspability index (Domae et al. 2014), no CNN"),
    Entry("cnn", "the highest P(not tangled) from the part's tangle CNN", model=True),
    Entry("harmonic", "the paper's rule: the harmonic mean of graspability and P(not tangled)",
          model=True),
    Entry("emap", "graspability re-ranked by low entanglement (Zhang et al. 2021), no training",
          emap=True),
    Entry("emap-harmonic", "the harmonic mean of graspability, P(not tangled) and 1 - "
                           "entanglement", model=True, emap=True),
    Entry("success-cnn", "the seed's second baseline (Matsumura et al. 2018): the highest "
                         "P(success) from the part's success/failure CNN", model=True),
    Entry("success-harmonic", "the harmonic mean of graspability and P(success) (a "
                              "pick-outcome model's P(one part) serves too)", model=True),
    Entry("outcome", "the part's pick-outcome model: its P(one part) with graspability, as "
                     "success-harmonic", model=True, shipped="outcome"),
    Entry(f"{MODEL_PREFIX}PATH", "the checkpoint at PATH with the rule its objective picks with "
                                 "(harmonic for a tangle CNN, success-cnn for a success/failure "
                                 "CNN)", model=True, pattern=True),
    Entry("RULE:PATH", "a rule that reads a model, with the checkpoint at PATH (one it serves)",
          model=True, pattern=True),
)

RULES = tuple(e.name for e in REGISTRY if e.shipped is None and not e.pattern)
"""The rules, each a method under its own name."""
MODEL_RULES = tuple(e.name for e in REGISTRY if e.shipped is None and not e.pattern and e.model)
"""The rules that need a trained model's probability (which model:
:mod:`tangle_drake.tangle_cnn.objectives`)."""
EMAP_RULES = tuple(e.name for e in REGISTRY if e.shipped is None and not e.pattern and e.emap)
"""The rules that need each candidate's entanglement (the entanglement map)."""
SHIPPED_MODEL_METHODS = {e.name: e.shipped for e in REGISTRY if e.shipped is not None}
"""Methods named for a shipped model other than their rule's own, and that model's objective."""
METHOD_NAMES = tuple(e.name for e in REGISTRY if not e.pattern)
"""Every method a name alone gives (the rules, then ``outcome``)."""
DEFAULT_METHODS = ("random", "graspability", "cnn", "harmonic", "success-cnn", "outcome")
"""The methods a benchmark compares unless told otherwise: the paper's comparison
(graspability, the seed's success/failure CNN, its tangle CNN with the harmonic mean) with the
pick-outcome model and two controls; the others on request."""


def help_list(names: tuple[str, ...] | None = None) -> str:
    """``name: what it picks; ...`` for a command's help text."""
    entries = [e for e in REGISTRY if names is None or e.name in names]
    return "; ".join(f"{e.name}: {e.what}" for e in entries)


def markdown_table() -> list[str]:
    """The README's table of methods."""
    return ["| method | picks |", "|---|---|",
            *(f"| `{e.name}` | {e.what} |" for e in REGISTRY)]
