"""A run's progress on the terminal: one line on stderr, rewritten in place."""

from __future__ import annotations

import sys
import time


class ProgressLine:
    """Shows scenarios.runner.Progress as "  42.5 / 200 s simulated, 6.3x real time, discs 2/8"
    on `stream`, at most every `every_s` seconds of wall time; `close` clears the line."""

    def __init__(self, stream=None, every_s: float = 0.25):
        self.stream = stream or sys.stderr
        self.every_s = every_s
        self.start = time.monotonic()
        self._last = -float("inf")
        self._shown = False

    def __call__(self, p) -> None:
        now = time.monotonic()
        if now - self._last < self.every_s and p.time_s < p.duration_s - 1e-6:  # the last one is always shown
            return
        self._last = now
        factor = p.time_s / max(now - self.start, 1e-9)
        discs = f", discs {p.discs_done}/{p.discs}" if p.discs else ""
        line = f"{p.time_s:7.1f} / {p.duration_s:g} s simulated, {factor:.1f}x real time{discs}"
        self.stream.write(f"\r{line}\x1b[K")  # \x1b[K: erase what a longer line left
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        if self._shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
