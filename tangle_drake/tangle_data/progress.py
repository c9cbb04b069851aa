"""The collection's progress bar: samples, samples per second, and the class balance so far."""

from __future__ import annotations

import time

from tqdm import tqdm


class CollectProgress:
    """A tqdm bar over the sample target, updated once per finished task.

    Shown on a terminal only (tqdm's default); the command prints a summary either way.
    """

    def __init__(self, description: str, target: int, counts: dict, workers: int,
                 enabled: bool | None = None) -> None:
        self.samples = counts["samples"]
        self.tangled = counts["tangled"]
        self.skipped = _skipped(counts)
        self.workers = workers
        self.new = 0
        self.start = time.perf_counter()
        self.bar = tqdm(total=target, initial=min(self.samples, target), unit="sample",
                        desc=description, dynamic_ncols=True,
                        disable=None if enabled is None else not enabled)
        self._postfix()

    def task_done(self, stats: dict) -> None:
        self.samples += stats["samples"]
        self.tangled += stats["tangled"]
        self.skipped += _skipped(stats)
        self.new += stats["samples"]
        self.bar.update(stats["samples"])
        self._postfix()

    def per_minute_per_worker(self) -> float:
        """New samples per minute per worker, wall clock, since the bar started."""
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        return 60 * self.new / elapsed / self.workers

    def _postfix(self) -> None:
        share = f"{100 * self.tangled / self.samples:.0f}%" if self.samples else "-"
        self.bar.set_postfix_str(f"tangled {share}, skipped {self.skipped}, "
                                 f"{self.per_minute_per_worker():.1f}/min/worker")

    def close(self) -> None:
        self.bar.close()


def _skipped(counts: dict) -> int:
    """Candidates that gave no sample: an empty closing region (the auto-lift), or a pick
    that could not be made (physical picks)."""
    return counts.get("empty_region", 0) + counts.get("failed", 0)
