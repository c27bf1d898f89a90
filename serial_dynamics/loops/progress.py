"""A progress line while a node's start-up step is slow (compiling the numba kernels on a
cold cache: minutes on a first start, about a second from the cache afterwards), said from a
thread of its own so that the step itself needs no hook.

    with Heartbeat(say, "compiling the dynamics kernels"):
        robot.warmup()

says nothing if the step ends within ``after`` seconds; else "<what>: 12 s so far (...)"
then every ``every`` seconds, and "<what>: done in 47 s" at the end.
"""
from __future__ import annotations

import threading
import time

FIRST_START = ("the first start on this machine fills the numba cache; later starts load "
               "it in about a second")


class Heartbeat:
    """Calls ``say(text)`` while the ``with`` block runs longer than ``after`` s, every
    ``every`` s, and once when it ends (only if it said anything before)."""

    def __init__(self, say, what: str, after: float = 3.0, every: float = 10.0,
                 clock=time.monotonic):
        if not (0 <= after and 0 < every):
            raise ValueError(f"Heartbeat needs after >= 0 and every > 0 s, got {after}, {every}")
        self.say, self.what, self.after, self.every, self.clock = say, what, after, every, clock
        self.said = 0
        self._stop = threading.Event()
        self._thread = None

    def __enter__(self):
        self.start = self.clock()
        self._thread = threading.Thread(target=self._beat, name="heartbeat", daemon=True)
        self._thread.start()
        return self

    def _beat(self):
        wait = self.after
        while not self._stop.wait(wait):
            self.said += 1
            self.say(f"{self.what}: {self.clock() - self.start:.0f} s so far ({FIRST_START})")
            wait = self.every

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        if self.said:
            self.say(f"{self.what}: done in {self.clock() - self.start:.0f} s")
        return False
