"""The benchmark's report: tables (Markdown, CSV, JSON), plots (PNG) and a terminal summary,
all computed from the finished trials on disk, so a resumed or an interrupted run reports
exactly what it has.

Success is *exactly one part came up*; its rate carries a Wilson 95 % interval, per part and
over all parts. Methods are compared on the same trials (paired): the difference of their
success rates with Newcombe's interval, and the trials only one of them got right.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import statistics
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from tangle_drake.bench.trials import FAILURES, RESULTS
from tangle_drake.common.provenance import describe
from tangle_drake.common.stats import paired_difference, wilson

ALL = "all"
"""The part name of the rows over every part."""
TIMINGS = ("perception_s", "cnn_s", "planning_s", "wall_s", "cpu_s", "sim_s")
"""Per-pick timings whose medians the report shows."""
PICK_COLUMNS = ("part", "trial", "pile_seed", "method", "result", "failure", "outcome",
                "lifted", "width", "rank", "p_model", "rejected", "u", "v", "angle_deg",
                "score", *TIMINGS, "execution_s", "depth_digest", "reason")


@dataclass(frozen=True)
class RateRow:
    """How one method did on one part (or all): counts, success rate and its interval."""

    part: str
    method: str
    n: int
    success: int
    tangled: int
    empty: int
    failure: int
    rate: float
    lower: float
    upper: float


def pick_rows(trials: Sequence[dict]) -> list[dict]:
    """Every pick of ``trials`` as a flat row (the columns of ``results.csv``)."""
    rows = []
    for trial in trials:
        for pick in trial["picks"]:
            row = {"part": trial["part"], "trial": trial["trial"],
                   "pile_seed": trial["pile"]["seed"], **pick, **(pick.get("candidate") or {})}
            rows.append({column: row.get(column) for column in PICK_COLUMNS})
    return rows


def rate_rows(rows: Sequence[dict], parts: Sequence[str], methods: Sequence[str]) -> list[RateRow]:
    """Per part and method, then per method over all parts (methods in the run's order)."""
    table = []
    for part in [*parts, ALL]:
        for method in methods:
            picks = [r for r in rows if r["method"] == method and part in (ALL, r["part"])]
            if not picks:
                continue
            counts = Counter(r["result"] for r in picks)
            lower, upper = wilson(counts["success"], len(picks))
            table.append(RateRow(part, method, len(picks), *(counts[r] for r in RESULTS),
                                 counts["success"] / len(picks), lower, upper))
    return table


def paired_rows(rows: Sequence[dict], parts: Sequence[str],
                methods: Sequence[str]) -> list[dict]:
    """Each later method against each earlier one, on the trials both ran, per part and
    over all parts."""
    success = {(r["part"], r["trial"], r["method"]): r["result"] == "success" for r in rows}
    table = []
    for part in [*parts, ALL]:
        for b, a in itertools.combinations(methods, 2):
            trials = sorted({(p, t) for p, t, m in success if m == a and part in (ALL, p)
                             and (p, t, b) in success})
            if not trials:
                continue
            result = paired_difference([success[(p, t, a)] for p, t in trials],
                                       [success[(p, t, b)] for p, t in trials])
            table.append({"part": part, "method_a": a, "method_b": b, **asdict(result)})
    return table


def failure_counts(rows: Sequence[dict], methods: Sequence[str]) -> dict[str, dict[str, int]]:
    """Per method, how many picks failed in each way."""
    return {method: {mode: sum(1 for r in rows if r["method"] == method
                               and r["failure"] == mode) for mode in FAILURES}
            for method in methods}


def timing_medians(rows: Sequence[dict], trials: Sequence[dict],
                   methods: Sequence[str]) -> dict[str, dict[str, float | None]]:
    """Median per-pick timings per method, and per trial (the pile drop, the whole trial)."""
    medians: dict[str, dict[str, float | None]] = {}
    for method in methods:
        picks = [r for r in rows if r["method"] == method]
        medians[method] = {name: _median([r[name] for r in picks]) for name in TIMINGS}
    medians["trial"] = {
        "pile_wall_s": _median([t["pile"]["wall_s"] for t in trials]),
        "pile_cpu_s": _median([t["pile"]["cpu_s"] for t in trials]),
        "wall_s": _median([t["wall_s"] for t in trials]),
        "cpu_s": _median([t["cpu_s"] for t in trials])}
    return medians


def _median(values: Sequence[float | None]) -> float | None:
    present = [v for v in values if v is not None]
    return statistics.median(present) if present else None


def summarize_run(trials: Sequence[dict], parts: Sequence[str], methods: Sequence[str],
                  context: dict) -> dict:
    """Everything the report shows, as plain data (``summary.json``)."""
    rows = pick_rows(trials)
    total_cpu = sum(t["cpu_s"] for t in trials)
    picks = len(rows)
    return {
        **context,
        "rates": [asdict(row) for row in rate_rows(rows, parts, methods)],
        "paired": paired_rows(rows, parts, methods),
        "failures": failure_counts(rows, methods),
        "timings": timing_medians(rows, trials, methods),
        "throughput": {"trials": len(trials), "picks": picks,
                       "cpu_s_per_pick": total_cpu / picks if picks else None,
                       "wall_s_per_trial_per_worker": _median([t["wall_s"] for t in trials])},
    }


def write_report(directory: Path, trials: Sequence[dict], summary: dict,
                 parts: Sequence[str], methods: Sequence[str]) -> list[Path]:
    """``report.md``, ``summary.json``, ``summary.csv``, ``results.csv`` and the plots."""
    directory = Path(directory)
    files = {
        "results.csv": _csv(pick_rows(trials), PICK_COLUMNS),
        "summary.csv": _csv(summary["rates"], tuple(RateRow.__dataclass_fields__)),
        "paired.csv": _csv(summary["paired"], ("part", "method_a", "method_b", "n", "rate_a",
                                               "rate_b", "difference", "lower", "upper",
                                               "a_only", "b_only", "p_value", "detectable")),
        "summary.json": json.dumps(summary, indent=2, sort_keys=True) + "\n",
        "report.md": markdown(summary),
    }
    written = []
    for name, text in files.items():
        (directory / name).write_text(text)
        written.append(directory / name)
    if summary["rates"]:
        written += write_plots(directory, summary, parts, methods)
    return written


def _csv(rows: Sequence[dict], columns: Sequence[str]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(columns), extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _ms(x: float | None) -> str:
    return "-" if x is None else f"{1e3 * x:.0f}"


def _s(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def rate_table(summary: dict) -> str:
    """Success rates: a row per method, a column per part and one over all (Markdown)."""
    parts = list(dict.fromkeys(row["part"] for row in summary["rates"]))
    methods = list(dict.fromkeys(row["method"] for row in summary["rates"]))
    cells = {(row["part"], row["method"]): row for row in summary["rates"]}
    lines = ["| method | " + " | ".join(parts) + " |", "|---" * (len(parts) + 1) + "|"]
    for method in methods:
        line = [method]
        for part in parts:
            row = cells.get((part, method))
            line.append("-" if row is None else
                        f"{_pct(row['rate'])} % [{_pct(row['lower'])}, {_pct(row['upper'])}]"
                        f" (n={row['n']})")
        lines.append("| " + " | ".join(line) + " |")
    return "\n".join(lines)


def _this_run(summary: dict) -> str:
    """What this invocation ran: a resumed run's minutes cover its new trials only."""
    ran = (f"{summary['new_trials']} trial(s) run in {summary['elapsed_s'] / 60:.1f} min with "
           f"{summary['workers']} worker(s)")
    earlier = summary["earlier_trials"]
    return ran + (f", {earlier} from earlier runs of the same command" if earlier else "")


def markdown(summary: dict) -> str:
    """``report.md``."""
    out = [f"# Bin-picking benchmark ({summary['mode']} mode)", "",
           f"Made by `{summary['command']}` ({describe(summary)}), {summary['date']}: "
           f"{_this_run(summary)}.", "",
           "Success = exactly one part lifted. Rates in %, with the Wilson 95 % confidence "
           "interval; every method picks from the same piles (paired).", ""]
    out += [f"> {note}" for note in summary["notes"]] + ([""] if summary["notes"] else [])
    if gallery := summary.get("gallery"):
        out += [f"Failure gallery: [{gallery['index']}]({gallery['index']}), a tile of each "
                f"failed pick by method and kind (drawing them took {gallery['seconds']:.1f} s "
                "of the run).", ""]
    out += ["## Success rate", "", rate_table(summary), "",
            "![success per method and part](success.png)", "",
            "## Paired differences (method A − method B, same trials)", "",
            "Detectable: the smallest difference these trials find with 80 % power at the 5 % "
            "level, from how often the two methods split (McNemar's normal approximation).", "",
            "| part | A − B | n | difference (pts) | 95 % CI | only A / only B | McNemar p "
            "| detectable (pts) |",
            "|---|---|---|---|---|---|---|---|"]
    for row in summary["paired"]:
        out.append(f"| {row['part']} | {row['method_a']} − {row['method_b']} | {row['n']} | "
                   f"{100 * row['difference']:+.1f} | [{100 * row['lower']:+.1f}, "
                   f"{100 * row['upper']:+.1f}] | {row['a_only']} / {row['b_only']} | "
                   f"{row['p_value']:.3g} | {100 * row['detectable']:.1f} |")
    out += ["", "## Outcomes", "", "| part | method | n | one | several | none | failed |",
            "|---|---|---|---|---|---|---|"]
    out += [f"| {r['part']} | {r['method']} | {r['n']} | {r['success']} | {r['tangled']} | "
            f"{r['empty']} | {r['failure']} |" for r in summary["rates"]]
    out += ["", "Failures by cause:", "", "| method | " + " | ".join(FAILURES) + " |",
            "|---" * (len(FAILURES) + 1) + "|"]
    out += [f"| {m} | " + " | ".join(str(counts[f]) for f in FAILURES) + " |"
            for m, counts in summary["failures"].items()]
    out += ["", "![outcomes per method and part](outcomes.png)", "", "## Timings", "",
            "Medians per pick: perception (render + graspability), CNN (+ selection), "
            "planning, and the whole pick's wall and CPU time and simulated time.", "",
            "| method | perception ms | CNN ms | planning ms | wall s | CPU s | simulated s |",
            "|---|---|---|---|---|---|---|"]
    timings = summary["timings"]
    out += [f"| {m} | {_ms(t['perception_s'])} | {_ms(t['cnn_s'])} | {_ms(t['planning_s'])} | "
            f"{_s(t['wall_s'])} | {_s(t['cpu_s'])} | {_s(t['sim_s'])} |"
            for m, t in timings.items() if m != "trial"]
    trial, throughput = timings["trial"], summary["throughput"]
    out += ["", f"Per trial (one pile, every method): pile drop {_s(trial['pile_wall_s'])} s "
            f"wall, whole trial {_s(trial['wall_s'])} s wall / {_s(trial['cpu_s'])} s CPU "
            f"(medians); {throughput['trials']} trials, {throughput['picks']} picks, "
            f"{_s(throughput['cpu_s_per_pick'])} CPU s per pick including the pile.", ""]
    return "\n".join(out)


def terminal_summary(summary: dict) -> str:
    """A few lines for the terminal: the success table and the key paired differences."""
    lines = [rate_table(summary)]
    overall = [row for row in summary["paired"] if row["part"] == ALL]
    for row in overall:
        lines.append(f"{row['method_a']} − {row['method_b']}: "
                     f"{100 * row['difference']:+.1f} pts [{100 * row['lower']:+.1f}, "
                     f"{100 * row['upper']:+.1f}] over {row['n']} paired trials (detects "
                     f"{100 * row['detectable']:.1f})")
    return "\n".join(lines)


def write_plots(directory: Path, summary: dict, parts: Sequence[str],
                methods: Sequence[str]) -> list[Path]:
    """``success.png`` (rate per method per part, with intervals) and ``outcomes.png``
    (what the picks ended as, failures by cause)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = [*parts, ALL]
    cells = {(r["part"], r["method"]): r for r in summary["rates"]}
    width = 0.8 / max(1, len(methods))
    figure, axes = plt.subplots(figsize=(max(6.0, 1.6 * len(groups)), 4.0))
    for i, method in enumerate(methods):
        xs, rates, errors = [], [], [[], []]
        for g, group in enumerate(groups):
            row = cells.get((group, method))
            if row is not None:
                xs.append(g + (i - (len(methods) - 1) / 2) * width)
                rates.append(100 * row["rate"])
                errors[0].append(100 * (row["rate"] - row["lower"]))
                errors[1].append(100 * (row["upper"] - row["rate"]))
        axes.bar(xs, rates, width, yerr=errors, capsize=3, label=method)
    axes.set_xticks(range(len(groups)), groups)
    axes.set_ylabel("exactly one part lifted, % (95 % CI)")
    axes.set_ylim(0, 100)
    axes.legend(loc="lower right", fontsize="small")
    figure.tight_layout()
    success = directory / "success.png"
    figure.savefig(success, dpi=120)
    plt.close(figure)

    rows = _outcome_counts(summary)
    kinds = ["success", "tangled", "empty", *(f"failure: {f}" for f in FAILURES)]
    figure, axes = plt.subplots(figsize=(max(6.0, 1.2 * len(methods) + 2), 4.0))
    bottom = [0.0] * len(methods)
    for kind in kinds:
        counts = [rows.get((method, kind), 0) for method in methods]
        if any(counts):
            axes.bar(methods, counts, 0.6, bottom=bottom, label=kind)
            bottom = [b + c for b, c in zip(bottom, counts, strict=True)]
    axes.set_ylabel("picks (all parts)")
    axes.legend(fontsize="small", bbox_to_anchor=(1.02, 1), loc="upper left")
    figure.tight_layout()
    outcomes = directory / "outcomes.png"
    figure.savefig(outcomes, dpi=120)
    plt.close(figure)
    return [success, outcomes]


def _outcome_counts(summary: dict) -> dict[tuple[str, str], int]:
    """(method, outcome kind) -> picks over all parts, failures by cause."""
    counts: dict[tuple[str, str], int] = {}
    for row in summary["rates"]:
        if row["part"] == ALL:
            for kind in ("success", "tangled", "empty"):
                counts[(row["method"], kind)] = row[kind]
    for method, failures in summary["failures"].items():
        for mode, n in failures.items():
            counts[(method, f"failure: {mode}")] = n
    return counts
