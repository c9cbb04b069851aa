"""The collection's progress: samples, samples per minute, and the class balance so far."""

from __future__ import annotations

from tangle_drake.progress import LINE_INTERVAL_S, Progress


class CollectProgress:
    """:class:`~tangle_drake.progress.Progress` over the sample target, updated once per
    finished task (a bar on a terminal, a line a minute in a log). The command prints a
    summary either way."""

    def __init__(self, description: str, target: int, counts: dict, workers: int,
                 enabled: bool | None = None, line_interval: float = LINE_INTERVAL_S) -> None:
        self.samples = counts["samples"]
        self.tangled = counts["tangled"]
        self.skipped = _skipped(counts)
        self.workers = workers
        self.progress = Progress(target, self.samples, "sample", description, enabled,
                                 line_interval)
        self.progress.update(0, self._figures())

    def task_done(self, stats: dict) -> None:
        self.samples += stats["samples"]
        self.tangled += stats["tangled"]
        self.skipped += _skipped(stats)
        self.progress.update(stats["samples"], self._figures())

    def per_minute_per_worker(self) -> float:
        """New samples per minute per worker, wall clock, since the collection started."""
        return self.progress.per_minute() / self.workers

    def _figures(self) -> str:
        share = f"{100 * self.tangled / self.samples:.0f}%" if self.samples else "-"
        return (f"tangled {share}, skipped {self.skipped}, "
                f"{self.per_minute_per_worker():.1f}/min/worker")

    def close(self) -> None:
        self.progress.close()


def _skipped(counts: dict) -> int:
    """Candidates that gave no sample: an empty closing region (the auto-lift), or a pick
    that could not be made (physical picks)."""
    return counts.get("empty_region", 0) + counts.get("failed", 0)
