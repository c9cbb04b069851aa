"""The model card of a ``teach`` run (``card.md``): the mesh check, the same validation and
test tables as the shipped models' card (:mod:`tangle_drake.tangle_cnn.card`), and the paired
benchmark against graspability alone."""

from __future__ import annotations

import json
from pathlib import Path

from tangle_drake.tangle_cnn.card import TEST_HEADER, VALIDATION_HEADER, test_row, validation_row


def write_card(out: Path, part: str = "part.json") -> Path:
    """Write ``out/card.md`` from the run's files; its path. ``part``: how commands name the
    part (the part file in ``out``, or a built-in part's name)."""
    check = json.loads((out / "check.json").read_text())
    test = json.loads((out / "test.json").read_text())
    bench = json.loads((out / "bench" / "summary.json").read_text())
    name = check["name"]
    row, causes = test_row(name, test)
    rates = [r for r in bench["rates"] if r["part"] == "all"]
    paired = [p for p in bench["paired"] if p["part"] == "all"]
    lines = [f"# {name}: a tangle CNN taught by `tangle-drake teach`", "",
             "## The mesh check", "", *[f"- {line}" for line in
                                        (out / "check.txt").read_text().splitlines()], "",
             "![The part and its convex pieces](part.png) ![A settled pile](pile.png)", "",
             "## Validation (the model's own record)", "", VALIDATION_HEADER,
             validation_row(out / "model.pt"), "",
             "## Test on fresh piles (another seed)", "", TEST_HEADER, row, "",
             "| label came about as | right % (samples) |", "|---|---|",
             *[f"| {cause} | {value} |" for cause, value in causes.items()], "",
             "## Benchmark: exactly one part on the first pick, paired piles", "",
             "| method | success % [95 % CI] | picks |", "|---|---|---|",
             *[f"| {r['method']} | {100 * r['rate']:.1f} [{100 * r['lower']:.1f}, "
               f"{100 * r['upper']:.1f}] | {r['n']} |" for r in rates], ""]
    lines += [f"{p['method_a']} − {p['method_b']}: {100 * p['difference']:+.1f} points "
              f"[{100 * p['lower']:+.1f}, {100 * p['upper']:+.1f}], McNemar p = "
              f"{p['p_value']:.2g}, over {p['n']} piles" for p in paired]
    lines += ["", f"Use it: `tangle-drake demo --part {part} --model model.pt`, "
              f"`tangle-drake bench --parts {part} --methods graspability model:model.pt` "
              "(paths in this directory).", ""]
    path = out / "card.md"
    path.write_text("\n".join(lines))
    return path
