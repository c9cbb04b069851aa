"""The bin-clearing benchmark's figures and report (``tangle-drake bench --clear``).

Per method and part, and per method over all parts: parts delivered to the tray; deliveries
(grasps after which parts landed in the tray, counted by the simulation) with exactly one
part and with several; several read as one (delivered on the estimator's "one part" while
several were held up through contacts at the weighing that decided it, or landed); weighings made
while a held part still rested on the pile (the wrist then reads light); grasps (not looks
that found nothing to pick) per delivered part; shakes, put-backs and stirs of the bin; parts
left in the bin and lost (in neither bin nor tray, by where they fell from and the planner's
mode then); parts delivered ÷ parts in the bins (``cleared`` in the summary: not the share of
bins emptied); delivered parts per hour of simulated time plus computation, and over each
third of the bins as they empty; how long the bin was busy per delivered part (a hand in it,
a look) and the two-arm ceiling that sets; each clearing that left parts in its bin, and why
it ended. Rates come with 95 % bootstrap intervals over bins.
"""

from __future__ import annotations

import csv
import json
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tangle_drake.common.provenance import describe

BOOTSTRAP_SAMPLES = 2000
BOOTSTRAP_SEED = 0
_FIELDS = ("part", "trial", "method", "index", "outcome", "failure", "lifted", "held",
           "resting", "held_decided", "weighed", "verdict", "recoveries", "disposition",
           "landed", "started_at", "in_bin_s", "look_s", "execution_s", "compute_s")


def _counts(runs: Sequence[dict]) -> dict:
    """Pooled counts over ``runs`` (one method's clearings of some bins)."""
    grasps = [g for run in runs for g in run["grasps"]]
    landed = [g["landed"] for g in grasps if g["landed"] > 0]
    delivered = sum(run["delivered"] for run in runs)
    parts = sum(run["delivered"] + run["left_in_bin"] + run["lost"] for run in runs)
    hours = sum(run["sim_s"] + run["compute_s"] for run in runs) / 3600
    return {
        "bins": len(runs), "parts": parts, "delivered": delivered,
        "deliveries": len(landed), "exactly_one": sum(n == 1 for n in landed),
        "several": sum(n >= 2 for n in landed),
        "several_read_as_one": sum(_several_read_as_one(g) for g in grasps),
        "weighed_resting": sum(_weighed_resting(g) for g in grasps),
        "grasps": sum(g["outcome"] != "FAILED" for g in grasps),
        "shakes": sum(r in ("SHAKE", "SHAKE_OFF") for g in grasps for r in g["recoveries"]),
        "stirs": sum(r == "STIR" for g in grasps for r in g["recoveries"]),
        "put_backs": sum(g["disposition"] == "PUT_BACK" for g in grasps),
        "empty": sum(g["disposition"] == "EMPTY" or g["outcome"] == "NONE" for g in grasps),
        "gave_up": sum(g["failure"] == "gave up" for g in grasps),
        "left_in_bin": sum(run["left_in_bin"] for run in runs),
        "lost": sum(run["lost"] for run in runs), "hours": hours,
        "lost_by_mode": _lost_by_mode(runs),
    }


def _weighed_resting(grasp: dict) -> bool:
    """The first weighing came while a held part still touched the pile. A grasp the
    fingers judged empty (closed past the empty width) was not weighed: what the simulation
    saw then, the closed fingers pressing on the pile early in the lift, is no weighing's."""
    judged_by_fingers = grasp.get("verdict") == "NONE" and grasp.get("weighed") is None
    return (grasp.get("resting") or 0) > 0 and not judged_by_fingers


def _several_read_as_one(grasp: dict) -> bool:
    """Delivered on the estimator's "one" while several were held up at the weighing that
    decided it, or several landed. A row made before ``held_decided`` was recorded knows the
    count at the first weighing only, which decided where no shake or re-weighing followed
    (after a shake that worked, several at the first weighing and one delivered is right)."""
    if grasp["disposition"] != "DELIVERED":
        return False
    if grasp["landed"] >= 2:
        return True
    decided = grasp.get("held_decided")
    if decided is None and not {"SHAKE", "REWEIGH"} & set(grasp["recoveries"]):
        decided = max(grasp["lifted"] or 0, grasp.get("held") or 0)
    return (decided or 0) >= 2


def _lost_by_mode(runs: Sequence[dict]) -> dict[str, int]:
    """Lost parts by where they came from and the planner's mode when they left (``bin in
    put back``); ``unseen``: lost, but never seen falling (or from a run made before escapes
    were recorded)."""
    modes = Counter(f"{e.get('source', 'bin')} in {e['mode']}"
                    for run in runs for e in run.get("escapes", []))
    unseen = sum(run["lost"] - len(run.get("escapes", [])) for run in runs)
    if unseen:
        modes["unseen"] = unseen
    return dict(modes.most_common())


def _rates(c: dict) -> dict:
    return {"exactly_one_rate": c["exactly_one"] / c["deliveries"] if c["deliveries"] else None,
            "several_rate": c["several"] / c["deliveries"] if c["deliveries"] else None,
            "cleared": c["delivered"] / c["parts"] if c["parts"] else None,
            "grasps_per_part": c["grasps"] / c["delivered"] if c["delivered"] else None,
            "parts_per_hour": c["delivered"] / c["hours"] if c["hours"] else None}


def _interval(runs: Sequence[dict], key: str) -> list[float] | None:
    """95 % bootstrap interval of a pooled rate, resampling whole bins."""
    if not runs:
        return None
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    values = []
    for _ in range(BOOTSTRAP_SAMPLES):
        sample = [runs[i] for i in rng.integers(len(runs), size=len(runs))]
        value = _rates(_counts(sample))[key]
        if value is not None:
            values.append(value)
    return [float(np.percentile(values, 2.5)), float(np.percentile(values, 97.5))] \
        if values else None


def _thirds(run: dict) -> list[tuple[int, float, int]] | None:
    """(parts delivered, hours, grasps) in each third of a bin: a grasp belongs to the third
    of the next part to be delivered (the bin's parts numbered in the order they leave), a
    third ends with its last grasp (the last third with the clearing), and its time is
    simulated time plus its grasps' computation. ``None`` for a run made before grasps
    recorded their start."""
    grasps = run["grasps"]
    if any(g.get("started_at") is None and g["outcome"] != "FAILED" for g in grasps):
        return None
    parts = max(run["delivered"] + run["left_in_bin"] + run["lost"], 1)
    delivered, compute, count, ends = 0, [0.0] * 3, [0] * 3, [0.0] * 3
    landed = [0] * 3
    for g in grasps:
        third = min(2, 3 * delivered // parts)
        landed[third] += g["landed"]
        compute[third] += g["compute_s"]
        count[third] += 1
        delivered += g["landed"]
        if g.get("started_at") is not None:
            ends[third] = g["started_at"] + g["execution_s"]
    ends[2] = run["sim_s"]
    starts = [0.0, ends[0], max(ends[:2])]
    return [(landed[k], (max(ends[k], starts[k]) - starts[k] + compute[k]) / 3600, count[k])
            for k in range(3)]


def _rate_by_third(runs: Sequence[dict]) -> list[float | None] | None:
    """Delivered parts per hour over the first, middle and last third of each bin, pooled
    over ``runs``: how the rate changes as the bin empties."""
    split = [t for run in runs if (t := _thirds(run)) is not None]
    if not split:
        return None
    rates = []
    for k in range(3):
        parts, hours = sum(t[k][0] for t in split), sum(t[k][1] for t in split)
        grasped = any(t[k][2] for t in split)
        rates.append(parts / hours if grasped and hours > 0 else None)
    return rates


def _bin_busy(runs: Sequence[dict]) -> dict | None:
    """Per delivered part, how long the bin was busy: a hand in it (fingertips below the rim),
    and the looks (settling and perceiving, simulated, plus the computation's wall time); and
    the rate two arms sharing the bin could reach at most, one busy while the other carries:
    3600 ÷ (busy seconds per part). ``None`` for runs made before the times were recorded."""
    grasps = [g for run in runs for g in run["grasps"]]
    delivered = sum(run["delivered"] for run in runs)
    if not delivered or not grasps or any("in_bin_s" not in g for g in grasps):
        return None
    in_bin = sum(g["in_bin_s"] for g in grasps) / delivered
    look = sum(g["look_s"] + g["compute_s"] for g in grasps) / delivered
    if in_bin + look <= 0:
        return None
    return {"in_bin_s": in_bin, "look_s": look,
            "compute_s": sum(g["compute_s"] for g in grasps) / delivered,
            "two_arm_ceiling_per_hour": 3600 / (in_bin + look)}


def figures(runs: Sequence[dict]) -> dict:
    """Counts, rates and intervals of one method's clearings."""
    counts = _counts(runs)
    intervals = {f"{key}_ci": _interval(runs, key)
                 for key in ("exactly_one_rate", "several_rate", "cleared", "parts_per_hour")}
    return {**counts, **_rates(counts), **intervals,
            "parts_per_hour_by_third": _rate_by_third(runs), "bin_busy": _bin_busy(runs)}


def summarize_clearing(trials: Sequence[dict], parts: Sequence[str], methods: Sequence[str],
                       meta: dict) -> dict:
    """The run's figures per method (over all parts) and per method and part."""
    def runs_of(method: str, part: str | None = None) -> list[dict]:
        return [run for trial in trials if part in (None, trial["part"])
                for run in trial["runs"] if run["method"] == method]

    return {**meta, "overall": {m: figures(runs_of(m)) for m in methods},
            "by_part": {p: {m: figures(runs_of(m, p)) for m in methods} for p in parts}}


def _pct(value: float | None, interval: list[float] | None = None) -> str:
    if value is None:
        return "–"
    text = f"{100 * value:.1f} %"
    return text + (f" [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]" if interval else "")


def _row(name: str, f: dict) -> str:
    pph = "–" if f["parts_per_hour"] is None else (
        f"{f['parts_per_hour']:.0f}" + (f" [{f['parts_per_hour_ci'][0]:.0f}, "
                                        f"{f['parts_per_hour_ci'][1]:.0f}]"
                                        if f["parts_per_hour_ci"] else ""))
    gpp = "–" if f["grasps_per_part"] is None else f"{f['grasps_per_part']:.2f}"
    return (f"| {name} | {f['bins']} | {f['delivered']}/{f['parts']} "
            f"({_pct(f['cleared'])}) | {f['deliveries']} | "
            f"{_pct(f['exactly_one_rate'], f['exactly_one_rate_ci'])} | {f['several']} | "
            f"{f['several_read_as_one']} | {f['weighed_resting']} | {gpp} | {f['shakes']} | "
            f"{f['put_backs']} | {f['stirs']} | {f['left_in_bin']} | {f['lost']} | {pph} |")


_HEADER = ["| method | bins | delivered ÷ parts in the bins | deliveries | exactly one part "
           "[95 % CI] | several | several read as one | weighed while resting | grasps per "
           "part | shakes | put-backs | stirs | left in bin | lost | parts per hour [95 % CI] |",
           "|---" * 15 + "|"]


def _lost_lines(by_method: dict, methods: Sequence[str]) -> list[str]:
    """Where each method's lost parts left the bin (the planner's mode), if any were lost."""
    lines = [f"- {m}: " + ", ".join(f"{mode} {n}" for mode, n in
                                    by_method[m]["lost_by_mode"].items())
             for m in methods if by_method[m]["lost_by_mode"]]
    return ["", "Lost parts, by where they were (bin, tray, gripper) and the planner's mode "
            "when they fell:", "", *lines] \
        if lines else []


def _third_lines(by_method: dict, methods: Sequence[str]) -> list[str]:
    """Each method's rate over the first, middle and last third of its bins."""
    def rate(value: float | None) -> str:
        return "–" if value is None else f"{value:.0f}"

    lines = [f"- {m}: " + ", ".join(map(rate, by_method[m]["parts_per_hour_by_third"]))
             for m in methods if by_method[m].get("parts_per_hour_by_third")]
    return ["", "Parts per hour as the bin empties (its first, middle and last third of parts "
            "delivered):", "", *lines] if lines else []


def _busy_lines(by_method: dict, methods: Sequence[str]) -> list[str]:
    """Each method's bin-busy time per delivered part and the two-arm ceiling it sets."""
    lines = [f"- {m}: {b['in_bin_s'] + b['look_s']:.1f} s: a hand in the bin "
             f"{b['in_bin_s']:.1f} s, looks {b['look_s']:.1f} s ({b['compute_s']:.1f} s of it "
             f"computing); two arms could deliver at most {b['two_arm_ceiling_per_hour']:.0f} "
             "parts per hour"
             for m in methods if (b := by_method[m].get("bin_busy"))]
    return ["", "The bin busy per delivered part (while one arm carries a part away, another "
            "could work the bin only outside these):", "", *lines] if lines else []


def _unfinished_lines(trials: Sequence[dict]) -> list[str]:
    """Each clearing that left parts in the bin, and why it ended (a run made before the
    reason was recorded gives the run's end)."""
    lines = [f"- {trial['part']} bin {trial['trial']}, {run['method']}: {run['left_in_bin']} "
             f"left; {run.get('end_reason', run['end'])}"
             for trial in trials for run in trial["runs"] if run["left_in_bin"]]
    return ["", "Clearings that ended with parts in the bin, and why:", "", *lines] \
        if lines else []


def write_clear_report(directory: Path, trials: Sequence[dict], summary: dict,
                       parts: Sequence[str], methods: Sequence[str]) -> list[Path]:
    """``clear_report.md``, ``clear_summary.json`` and ``clear_grasps.csv`` in ``directory``."""
    loop = "open loop (the paper's)" if summary.get("open_loop") else "closed loop"
    lines = [f"# Bin clearing ({summary['mode']} mode, {loop})", "",
             f"Made by `{summary['command']}` ({describe(summary)}, {summary['date']}).", "",
             "Deliveries and their part counts are the simulation's (what landed in the tray);"
             " parts per hour count simulated time plus the computation's wall time. Several "
             "read as one: delivered on the estimator's \"one\" while several were held up "
             "(through contacts) at the weighing that decided it, or landed. Weighed while "
             "resting: the first weighing came while a held part still touched the pile.", "",
             "## All parts", "", *_HEADER,
             *[_row(m, summary["overall"][m]) for m in methods]]
    lines += _lost_lines(summary["overall"], methods)
    lines += _third_lines(summary["overall"], methods)
    lines += _busy_lines(summary["overall"], methods)
    lines += _unfinished_lines(trials)
    for part in parts:
        lines += ["", f"## {part}", "", *_HEADER,
                  *[_row(m, summary["by_part"][part][m]) for m in methods]]
        lines += _lost_lines(summary["by_part"][part], methods)
        lines += _third_lines(summary["by_part"][part], methods)
        lines += _busy_lines(summary["by_part"][part], methods)
    for note in summary.get("notes", []):
        lines += ["", f"Note: {note}"]
    report = directory / "clear_report.md"
    report.write_text("\n".join(lines) + "\n")
    summary_path = directory / "clear_summary.json"
    summary_path.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")
    grasps = directory / "clear_grasps.csv"
    with grasps.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=_FIELDS, extrasaction="ignore")
        writer.writeheader()
        for trial in trials:
            for run in trial["runs"]:
                for g in run["grasps"]:
                    writer.writerow({**g, "part": trial["part"], "trial": trial["trial"],
                                     "method": run["method"],
                                     "recoveries": " ".join(g["recoveries"])})
    return [report, summary_path, grasps]


def terminal_clear_summary(summary: dict) -> str:
    """A few lines for the terminal: each method's figures over all parts."""
    out = []
    for method, f in summary["overall"].items():
        out.append(f"{method}: delivered {f['delivered']}/{f['parts']} parts, exactly one in "
                   f"{_pct(f['exactly_one_rate'], f['exactly_one_rate_ci'])} of "
                   f"{f['deliveries']} deliveries, {f['several_read_as_one']} several read as "
                   f"one, {f['lost']} lost, "
                   + ("–" if f["parts_per_hour"] is None else f"{f['parts_per_hour']:.0f}")
                   + " parts per hour")
    return "\n".join(out)
