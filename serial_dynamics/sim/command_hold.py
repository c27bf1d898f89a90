"""The simulator's commands between two messages (no rclpy here): a zero-order hold of
the effort and of the joint servo's targets, and of the push on the tip, each with its
timeout in steps of simulated time.

Not thread-safe by itself: the simulator node changes and reads it under its step lock.
"""
from __future__ import annotations

import numpy as np

from serial_dynamics.sim.servo import servo


class CommandHold:
    """``tau`` (the effort held), ``q_target``/``qd_target`` (NaN: no target), ``servo``
    (the joint servo of the targets, or None), ``tau_servo`` (its torque over the last
    step, set by the stepper) and ``wrench`` ((6,) or None). ``timeout_steps``: steps
    without a command after which the effort returns to zero and the targets are cleared
    (0: never); ``wrench_timeout_steps``: steps after which a wrench is dropped (0: never)."""

    def __init__(self, n: int, kp, kd, timeout_steps: int = 0, wrench_timeout_steps: int = 0):
        self.n, self.kp, self.kd = n, kp, kd
        self.timeout_steps, self.wrench_timeout_steps = timeout_steps, wrench_timeout_steps
        self.wrench, self.wrench_step = None, 0
        self.clear(0)

    def clear(self, k: int):
        """No command (at start, ~/reset): zero effort, no targets; nothing to time out."""
        n = self.n
        self.tau, self.cmd_step, self.timed_out = np.zeros(n), k, True
        self.q_target, self.qd_target = np.full(n, np.nan), np.full(n, np.nan)
        self.servo, self.tau_servo = None, np.zeros(n)

    def command(self, k: int, idx, effort, position=None, velocity=None):
        """The command of the joints ``idx`` at step k: effort, and servo targets (None:
        the joints named have none; NaN entries: none at that joint). Others keep theirs."""
        tau, qt, vt = self.tau.copy(), self.q_target.copy(), self.qd_target.copy()
        tau[idx] = effort
        qt[idx] = np.nan if position is None else position
        vt[idx] = np.nan if velocity is None else velocity
        self.tau, self.cmd_step, self.timed_out = tau, k, False
        self.q_target, self.qd_target = qt, vt
        self.servo = (servo(self.kp, self.kd, qt, vt) if np.any(~np.isnan(qt) | ~np.isnan(vt))
                      else None)
        if self.servo is None:
            self.tau_servo = np.zeros(self.n)

    def push(self, k: int, wrench):
        """The wrench on the tip from step k ((6,), or None: no push)."""
        self.wrench, self.wrench_step = wrench, k

    def expire(self, k: int) -> list:
        """Apply the timeouts at step k; the events, to log: "command", "wrench"."""
        events = []
        if self.timeout_steps and not self.timed_out and k - self.cmd_step > self.timeout_steps:
            self.clear(k)
            events.append("command")
        if (self.wrench is not None and self.wrench_timeout_steps
                and k - self.wrench_step >= self.wrench_timeout_steps):
            self.wrench = None
            events.append("wrench")
        return events
