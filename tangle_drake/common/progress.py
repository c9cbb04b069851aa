"""Progress of a long job: a bar on a terminal, a plain line now and then in a log.

tqdm draws its bar on a terminal only; a job run under ``nohup`` or by CI would say nothing
for an hour. Off a terminal (unless progress is switched off) :class:`Progress` prints a line
at most every ``interval`` seconds instead: done of total, the caller's figures, time left.
"""

from __future__ import annotations

import time

from tqdm import tqdm

LINE_INTERVAL_S = 60.0
"""Off a terminal, a progress line at most this often, s."""


class Progress:
    """``total`` units of work, ``initial`` of them done before; ``enabled`` ``None``: a bar
    on a terminal and lines off one, ``False``: silent, ``True``: the bar."""

    def __init__(self, total: int, initial: int, unit: str, description: str,
                 enabled: bool | None = None, interval: float = LINE_INTERVAL_S) -> None:
        self.total = total
        self.done = initial
        self.unit = unit
        self.description = description
        self.bar = tqdm(total=total, initial=min(initial, total), unit=unit, desc=description,
                        dynamic_ncols=True, disable=None if enabled is None else not enabled)
        self._lines = enabled is None and self.bar.disable
        self._interval = interval
        self._start = self._last = time.perf_counter()
        self._new = 0
        self._postfix = ""

    def update(self, count: int, postfix: str) -> None:
        """``count`` more units done; ``postfix``: the caller's figures so far."""
        self.done += count
        self._new += count
        self._postfix = postfix
        self.bar.update(count)
        self.bar.set_postfix_str(postfix)
        now = time.perf_counter()
        if self._lines and now - self._last >= self._interval:
            self._last = now
            print(self.line(), flush=True)

    def per_minute(self) -> float:
        """Units done per minute since the start (wall clock)."""
        return 60 * self._new / max(time.perf_counter() - self._start, 1e-9)

    def line(self) -> str:
        """Where the job stands, in one line."""
        rate = self.per_minute()
        left = max(self.total - self.done, 0)
        eta = f", about {left / rate:.0f} min left" if rate > 0 else ""
        figures = f", {self._postfix}" if self._postfix else ""
        return (f"  {self.description}: {min(self.done, self.total)}/{self.total} {self.unit}s"
                f"{figures}{eta}")

    def close(self) -> None:
        self.bar.close()
