"""Wall-clock pacing of a stepped simulation (no rclpy here): when step k is due, how
late the loop is, when it gives up catching up, and the real-time factor achieved.

Step k is due at ``wall0 + (k - k0) dt / real_time_factor`` from an anchor (wall0, k0).
Late, the loop steps back to back to catch up; more than ``max_lag`` late, it re-anchors
at now (it then runs slower than asked rather than in a burst). A real-time factor of 0
means as fast as possible: every step is due at once.
"""
from __future__ import annotations

import time


class Pacer:
    def __init__(self, dt: float, real_time_factor: float, max_lag: float = 0.1,
                 clock=time.monotonic):
        self.period = dt / real_time_factor if real_time_factor > 0 else 0.0
        self.max_lag, self.clock = max_lag, clock
        self.late_steps = 0          # steps started more than one period behind schedule
        self.reanchors = 0           # times the schedule was given up (more than max_lag late)
        self.anchor(0)
        self.mark = (self.wall0, 0)

    def anchor(self, k: int):
        """Step k is due now (at start, after a pause)."""
        self.wall0, self.k0 = self.clock(), k

    def wait(self, k: int) -> float:
        """Seconds until step k is due (> 0: wait, then ask again); 0: take it now,
        counting it late or re-anchoring the schedule as the case may be."""
        if self.period == 0.0:
            return 0.0
        due, now = self.wall0 + (k - self.k0) * self.period, self.clock()
        if due > now:
            return due - now
        if now - due > self.period:
            self.late_steps += 1
        if now - due > self.max_lag:
            self.wall0, self.k0 = now, k
            self.reanchors += 1
        return 0.0

    def achieved(self, k: int, dt: float) -> float:
        """Simulated seconds per wall second from the previous call to this one (steps
        k of dt each); 0 if no wall time passed."""
        now = self.clock()
        wall0, k0 = self.mark
        self.mark = (now, k)
        return (k - k0) * dt / (now - wall0) if now > wall0 else 0.0
