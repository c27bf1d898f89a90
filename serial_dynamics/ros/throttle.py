"""Throttled logging (no rclpy here): a warning the first time a cause comes up, then a
count of its repeats at most every ``period`` seconds. The nodes log refused messages,
service requests and parameter sets through it, so a storm of any costs a few lines, not
one each. ``Rejected`` (model/errors.py) is what a node refuses, with the cause its repeats
are grouped by.
"""
from __future__ import annotations

import time

from ..model.errors import Rejected  # noqa: F401  (re-exported: the nodes' refusals)


class Throttle:
    """``throttle(key, text, repeats)``: log ``text`` (with ``warn``) the first time
    ``key`` comes up; later, ``repeats`` (formatted with the number of repeats since the
    last line) at most every ``period`` s, or nothing if ``repeats`` is None."""

    def __init__(self, warn, period: float = 10.0, clock=time.monotonic):
        self.warn, self.period, self.clock = warn, period, clock
        self.counts, self._logged_at, self._logged_count = {}, {}, {}

    def __call__(self, key, text: str, repeats: str | None = None):
        n = self.counts[key] = self.counts.get(key, 0) + 1
        now = self.clock()
        if n == 1:
            self.warn(text)
        elif repeats and now - self._logged_at[key] >= self.period:
            self.warn(repeats.format(n - self._logged_count[key]))
        else:
            return
        self._logged_at[key], self._logged_count[key] = now, n
