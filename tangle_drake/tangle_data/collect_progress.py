"""The collection's progress: samples, samples per minute, and the class balance so far."""

from __future__ import annotations

from tangle_drake.common.progress import LINE_INTERVAL_S, Progress

LIFT_SHARES = (("tangled", "tangled"),)
"""The task counts an auto-lift collection's progress shows as shares of the samples."""


class CollectProgress:
    """:class:`~tangle_drake.common.progress.Progress` over the sample target, updated once per
    finished task (a bar on a terminal, a line a minute in a log). The command prints a
    summary either way."""

    def __init__(self, description: str, target: int, counts: dict,
                 enabled: bool | None = None, line_interval: float = LINE_INTERVAL_S,
                 shares: tuple[tuple[str, str], ...] = LIFT_SHARES) -> None:
        """``shares``: ``(count, words)`` of the task counts shown as shares of the samples
        (the auto-lift's tangled; a physical pick's one part, several, none:
        ``physical.PICK_SHARES``)."""
        self.samples = counts["samples"]
        self.shares = shares
        self.counted = {key: counts.get(key, 0) for key, _ in shares}
        self.skipped = _skipped(counts)
        self.workers = 1
        """The most tasks that have run at once: the workers that worked, whatever the pool's
        size (a pool of 1,000 for 3 samples runs one task)."""
        self.progress = Progress(target, self.samples, "sample", description, enabled,
                                 line_interval)
        self.progress.update(0, self._figures())

    def running(self, tasks: int) -> None:
        """``tasks`` run at once now."""
        self.workers = max(self.workers, tasks)

    def task_done(self, stats: dict) -> None:
        self.samples += stats["samples"]
        for key in self.counted:
            self.counted[key] += stats.get(key, 0)
        self.skipped += _skipped(stats)
        self.progress.update(stats["samples"], self._figures())

    def per_minute_per_worker(self) -> float:
        """New samples per minute per worker, wall clock, since the collection started."""
        return self.progress.per_minute() / self.workers

    def _figures(self) -> str:
        shares = "".join(
            f"{words} {100 * self.counted[key] / self.samples:.0f}%, " if self.samples else
            f"{words} -, " for key, words in self.shares)
        return (f"{shares}skipped {self.skipped}, "
                f"{self.per_minute_per_worker():.1f}/min/worker")

    def close(self) -> None:
        self.progress.close()


def _skipped(counts: dict) -> int:
    """Candidates that gave no sample: an empty closing region (the auto-lift), or a pick
    that could not be made (physical picks)."""
    return counts.get("empty_region", 0) + counts.get("failed", 0)
