"""Write every generated result table of the README and the docs pages from the results'
machine-readable files, so that each figure lives once: in the result's ``summary.json`` or
``clear_summary.json``, never typed by hand into a page.

    python tools/results_tables.py           # rewrite the generated tables in place
    python tools/results_tables.py --check   # exit 1 naming each table its files disagree with

A generated table is a block between marker comments, each alone on its line::

    <!-- table: NAME -->
    ...
    <!-- /table -->

(the README's headline keeps its own ``<!-- headline -->`` ... ``<!-- /headline -->``, named
``headline``). ``BLOCKS`` says what each name holds; the tool writes only what lies between the
markers and leaves every other line alone. After remaking a result run it, and commit the
result and the pages together; ``tests/test_docs.py`` fails when a committed table disagrees
with its files.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from tangle_drake.scenario import Scenario, load_scenario
from tangle_drake.selection.registry import markdown_table

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
GENERATED_REPORTS = ("report.md", "clear_report.md")
"""Pages the commands write whole; the tool reads no markers there."""

SCENARIO_FILE = "scenario.yaml"
"""The scenario a result ran on, kept beside it (its digest is the run's ``scenario_sha256``)."""

HEADLINE_METHODS = ("random", "graspability", "cnn", "harmonic", "success-cnn", "outcome")
"""The pick methods the headline compares, in its columns' order."""
HEADLINE_PICKS = {"docs/results/benchmark": "one layer",
                  "docs/results/dense_comparison": "dense bin"}
"""The pick benchmarks of the headline (folders holding ``summary.json`` and ``report.md``),
with what the headline calls each."""
HEADLINE_CLEARING_METHOD = "harmonic"
HEADLINE_CLEARINGS = ("docs/results/clearing/closed", "docs/results/clearing/arm_brisk_6cm")
"""The clearings of the headline (folders holding ``clear_summary.json`` and
``clear_report.md``)."""

START = re.compile(r"^<!-- table: ([\w-]+) -->$")
END = "<!-- /table -->"
HEADLINE_START = "<!-- headline -->"
HEADLINE_END = "<!-- /headline -->"


class TableError(Exception):
    """A result file or a page the tables cannot be made from or written into."""


# --- figures -------------------------------------------------------------------------------------

def percent(rate: float) -> str:
    return f"{100 * rate:.1f} %"


def interval(low: float, high: float, scale: float = 100.0, digits: int = 1) -> str:
    return f"[{scale * low:.{digits}f}, {scale * high:.{digits}f}]"


def result_scenario(folder: Path, summary: dict) -> Scenario:
    """The scenario the result in ``folder`` ran on, checked against the digest it recorded."""
    path = folder / SCENARIO_FILE
    recorded = summary["config"]["scenario_sha256"]
    if not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() != recorded:
        raise TableError(f"{folder.relative_to(ROOT)}: no {SCENARIO_FILE} with the sha256 its "
                         f"summary recorded ({recorded})")
    return load_scenario(path)


def pile_size(summary: dict, scenario: Scenario) -> int:
    return int(summary["config"].get("pile_size") or scenario.pile.total_count)


def row(cells: list[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def pick_row(link: str, kind: str, summary: dict, scenario: Scenario,
             methods: list[str] | tuple[str, ...]) -> str:
    """The headline row of a pick benchmark (``summary.json``): first picks with exactly one
    part over every part, per method; ``–`` where the benchmark did not run the method."""
    overall = {rate["method"]: rate for rate in summary["rates"] if rate["part"] == "all"}
    piles = {rate["n"] for rate in overall.values()}
    if len(piles) != 1:
        raise TableError(f"{link}: methods ran on different piles")
    label = (f"[{kind}]({link}): {piles.pop()} piles of {pile_size(summary, scenario)} parts, "
             f"{summary['trials_per_part']} per part")
    cells = [f"{percent(overall[m]['rate'])} {interval(overall[m]['lower'], overall[m]['upper'])}"
             if m in overall else "–" for m in methods]
    return row([label, *cells])


def clearing_row(link: str, summary: dict, scenario: Scenario, method: str) -> str:
    """The headline row of a clearing (``clear_summary.json``): deliveries with exactly one
    part, parts delivered over the parts in the bins, parts lost, parts per hour."""
    if summary["open_loop"]:
        raise TableError(f"{link}: the headline shows the closed loop")
    if method not in summary["overall"]:
        raise TableError(f"{link}: no method {method!r} in its summary")
    figures = summary["overall"][method]
    if summary["mode"] == "arm":
        nextage = scenario.model_drivers["nextage"]
        carrier = (f"Nextage arm, planned at {nextage.planning_velocity_limit:.1f} rad/s and "
                   f"{nextage.planning_acceleration_limit:.1f} rad/s² per joint, "
                   f"{100 * nextage.planning_slow_speed:g} cm/s next to the pile")
    else:
        carrier = "gantry (floating gripper)"
    parts_per_bin = figures["parts"] / figures["bins"]
    if parts_per_bin != int(parts_per_bin):
        raise TableError(f"{link}: bins of different sizes")
    label = f"[{carrier}]({link}): {figures['bins']} bins of {int(parts_per_bin)} parts"
    low, high = figures["parts_per_hour_ci"]
    share = percent(figures["delivered"] / figures["parts"])
    cells = [f"{figures['exactly_one']} of {figures['deliveries']}",
             f"{figures['delivered']} ÷ {figures['parts']} ({share})",
             f"{figures['lost']}",
             f"{figures['parts_per_hour']:.0f} {interval(low, high, scale=1.0, digits=0)}"]
    return row([label, *cells])


# --- the tables ----------------------------------------------------------------------------------

def read_json(path: Path) -> dict:
    if not path.is_file():
        raise TableError(f"{path.relative_to(ROOT)}: no such result file")
    return json.loads(path.read_text())


def link_from(page: Path, target: Path) -> str:
    """``target`` as a link written on ``page``."""
    return Path(os.path.relpath(target, page.parent)).as_posix()


def headline(page: Path) -> list[str]:
    """The README's headline: the pick benchmarks per method, then the clearings."""
    lines = [row(["first pick with exactly one part", *[f"`{m}`" for m in HEADLINE_METHODS]]),
             row(["---"] * (1 + len(HEADLINE_METHODS))).replace(" ", "")]
    for folder, kind in HEADLINE_PICKS.items():
        summary = read_json(ROOT / folder / "summary.json")
        link = link_from(page, ROOT / folder / "report.md")
        scenario = result_scenario(ROOT / folder, summary)
        lines.append(pick_row(link, kind, summary, scenario, HEADLINE_METHODS))
    lines += ["",
              row([f"clearing whole bins, closed loop, `{HEADLINE_CLEARING_METHOD}` rule",
                   "deliveries with exactly one part", "parts delivered ÷ parts in the bins",
                   "parts lost", "parts per hour"]),
              row(["---"] * 5).replace(" ", "")]
    for folder in HEADLINE_CLEARINGS:
        summary = read_json(ROOT / folder / "clear_summary.json")
        link = link_from(page, ROOT / folder / "clear_report.md")
        scenario = result_scenario(ROOT / folder, summary)
        lines.append(clearing_row(link, summary, scenario, HEADLINE_CLEARING_METHOD))
    return lines


def methods(page: Path) -> list[str]:
    """The registered ways of choosing a grasp (``tangle_drake.selection.registry``)."""
    return markdown_table()


BLOCKS: dict[str, Callable[[Path], list[str]]] = {"headline": headline, "methods": methods}
"""What each generated block holds: its lines, made for the page it is on (links relative
to that page)."""


# --- the pages -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Block:
    """A generated block of a page: its name and the lines between its markers
    (``lines[start:end]``, markers excluded)."""

    name: str
    start: int
    end: int


def pages() -> list[Path]:
    """Every page that may hold a generated block: the README and docs/ but its reports."""
    docs = sorted((ROOT / "docs").rglob("*.md"))
    return [README, *[page for page in docs if page.name not in GENERATED_REPORTS]]


def find_blocks(lines: list[str], where: str) -> list[Block]:
    """The generated blocks among ``lines``; ``where`` names the page in errors."""
    found, number = [], 0
    while number < len(lines):
        line = lines[number].strip()
        match = START.match(line)
        if match or line == HEADLINE_START:
            name, end_marker = (match.group(1), END) if match else ("headline", HEADLINE_END)
            end = next((i for i in range(number + 1, len(lines))
                        if lines[i].strip() == end_marker), None)
            if end is None:
                raise TableError(f"{where}:{number + 1}: {line} without its {end_marker}")
            if name not in BLOCKS:
                raise TableError(f"{where}:{number + 1}: no table named {name!r} "
                                 f"(known: {', '.join(BLOCKS)})")
            found.append(Block(name, number + 1, end))
            number = end
        number += 1
    return found


def render(page: Path, text: str) -> tuple[str, list[str]]:
    """``text`` of ``page`` with every generated block made anew, and the names of the blocks
    that changed (``page: name``)."""
    lines = text.splitlines()
    where = page.relative_to(ROOT).as_posix()
    changed = []
    for block in reversed(find_blocks(lines, where)):
        made = BLOCKS[block.name](page)
        if lines[block.start:block.end] != made:
            changed.append(f"{where}: {block.name}")
            lines[block.start:block.end] = made
    trailing = "\n" if text.endswith("\n") else ""
    return "\n".join(lines) + trailing, changed[::-1]


def generated_blocks() -> list[tuple[Path, str]]:
    """Every generated block of the pages: its page and name."""
    return [(page, block.name) for page in pages()
            for block in find_blocks(page.read_text().splitlines(),
                                     page.relative_to(ROOT).as_posix())]


def stale(page: Path, text: str | None = None) -> list[str]:
    """The blocks of ``page`` (or of ``text`` as that page) that disagree with their files."""
    return render(page, page.read_text() if text is None else text)[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 naming each table that disagrees with its "
                             "result files")
    args = parser.parse_args(argv)
    try:
        differing = []
        for page in pages():
            text = page.read_text()
            made, changed = render(page, text)
            differing += changed
            if changed and not args.check:
                page.write_text(made)
    except TableError as error:
        print(f"results_tables: {error}", file=sys.stderr)
        return 2
    for name in differing:
        print(f"{'differs from its result files' if args.check else 'rewritten'}: {name}")
    return 1 if args.check and differing else 0


if __name__ == "__main__":
    sys.exit(main())
