"""The progress bar of long runs: text on stderr, or a callable(fraction)."""
from __future__ import annotations

import sys
import time


class Progress:
    """A text progress bar on stderr that appears only once a run has lasted 1 s."""

    def __init__(self, duration, enabled, stream=None, delay=1.0):
        self.duration, self.enabled = duration, enabled
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.delay, self.shown, self.last = delay, False, -1

    def __call__(self, t):
        if not self.enabled:
            return
        if callable(self.enabled):
            self.enabled(t / self.duration)
            return
        now = time.perf_counter() - self.start
        pct = int(100 * t / self.duration)
        if now < self.delay or pct == self.last:
            return
        self.shown, self.last = True, pct
        bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
        self.stream.write(f"\rsimulating [{bar}] {pct:3d}%  t = {t:.3f} s  ({now:.1f} s)")
        self.stream.flush()

    def close(self):
        if self.shown and not callable(self.enabled):
            self.stream.write("\n")
            self.stream.flush()
