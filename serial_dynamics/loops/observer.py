"""The external-torque observer node's loop, without ROS (``ros/external_torque_observer.py``
converts its parameters and messages and makes one call here per joint state).

``CollisionMonitor`` feeds ``observers.MomentumObserver`` one sample at a time from a
stream of stamped joint states and says, for each, the estimated external joint torques,
the tip wrench that explains them in least squares and whether the arm is in collision:
true from the first sample where some |tau_ext_i| exceeds its threshold, false again once
every |tau_ext_i| is below ``release`` times its threshold (hysteresis).

The stream's stamps: a zero stamp and a repeated one (a paused simulator) are refused
(``Rejected``); a stamp that goes back (a simulator restarted) or forward by more than
``max_gap`` (a pause) restarts the estimate from the current momentum, as tf2 clears its
buffer on a jump back. A new model (a payload) starts a new estimate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.errors import Rejected
from ..observers import MomentumObserver


@dataclass
class Sample:
    """What one joint state gives: ``tau_ext`` (dof,) and ``wrench`` (6,) [force; moment]
    on the tip, base frame; ``collision``; ``event``: the line that says a collision was
    flagged or cleared at this sample, else None; ``notes``: lines to log once per key, then
    as a count, ``(key, text, repeats)`` (a restart, per direction)."""
    tau_ext: np.ndarray
    wrench: np.ndarray
    collision: bool
    event: str | None
    notes: list


class CollisionMonitor:
    """The observer of ``robot`` with ``gain`` K (1/s; ``dissipation``: subtract the
    modelled friction), per-joint ``thresholds`` (N m; N), ``release`` in [0, 1] and
    ``max_gap`` (s). ValueError for parameters out of range."""

    def __init__(self, robot, gain, thresholds, release=0.5, max_gap=0.1, dissipation=False):
        thr = np.asarray(thresholds, float)
        for bad, text in (
                (not np.all((thr > 0) & np.isfinite(thr)),
                 f"'collision_thresholds' must be > 0 and finite, got {thr.tolist()}"),
                (not 0 < max_gap < np.inf, f"'max_sample_gap' must be > 0 (s), got {max_gap}"),
                (not 0 <= release <= 1, f"'collision_release' must be in [0, 1], got {release}"),
                (not 0 < gain < np.inf, f"'gain' must be > 0 (1/s), got {gain}")):
            if bad:
                raise ValueError(f"parameter {text}")
        self.threshold, self.release, self.max_gap = thr, release, max_gap
        self.gain, self.dissipation = gain, dissipation
        self.set_robot(robot)
        self.collision, self.restarts = False, 0
        self.r = np.zeros(robot.dof)

    def set_robot(self, robot):
        """A new model (a payload): its momentum p = M qd starts a new estimate."""
        self.robot = robot
        self.observer = MomentumObserver(robot, self.gain, self.dissipation)

    def warmup(self):
        """Compile (or load) the observer's kernels now, not at the first sample."""
        self.robot.warmup()
        zero = np.zeros(self.robot.dof)
        for t in (0.0, 1.0):
            self.observer.update(t, zero, zero, zero)
        self.observer.wrench(zero, zero)
        self.observer.reset()

    def update(self, t, q, qd, tau):
        """The sample at stamp ``t`` (s): joint positions, velocities and the actuator
        torques applied (model order). Rejected, or the library's ValueError, for a sample
        not taken (the estimate goes on from the last good one)."""
        obs, notes = self.observer, []
        if t == 0.0:
            raise Rejected("zero stamp", "joint_states has a zero stamp; the observer "
                           "integrates over the stamps: stamp every message")
        if obs.t is not None and t == obs.t:
            raise Rejected("stamp repeated", f"joint_states stamp {t:.9f} s is the "
                           "previous one's (a paused simulator): nothing new to take")
        if obs.t is not None and not 0 < t - obs.t <= self.max_gap:
            notes.append(self._restart(t - obs.t))
        r = obs.update(t, q, qd, tau)
        w, _ = obs.wrench(q, r)
        event = self._flag(r)
        self.r = r
        return Sample(r, w, self.collision, event, notes)

    def _restart(self, jump):
        self.restarts += 1
        way = "back" if jump < 0 else "forward"
        self.observer.reset()
        return (("restart", way), f"joint_states stamp jumped {way} by {abs(jump):.6g} s "
                f"(max_sample_gap {self.max_gap:g} s): the observer restarts from the "
                "current momentum", f"observer restarted {{}} more times since on a stamp "
                f"jump {way}")

    def _flag(self, r):
        ratio = np.abs(r) / self.threshold
        j = int(np.argmax(ratio))
        if not self.collision and ratio[j] > 1:
            self.collision = True
            return (f"collision: estimated external torque {r[j]:.4g} at "
                    f"{self.robot.joint_names[j]} (threshold {self.threshold[j]:.4g})")
        if self.collision and ratio[j] < self.release:
            self.collision = False
            return "collision cleared"
        return None

    def report(self):
        """The /diagnostics values: the largest estimate against its threshold, the
        collision flag, the restarts."""
        j = int(np.argmax(np.abs(self.r) / self.threshold))
        return [("largest estimated torque (N m)", f"{abs(self.r[j]):.4g}"),
                ("threshold at that joint (N m)", f"{self.threshold[j]:.4g}"),
                ("collision", self.collision, self.collision),
                ("restarts (stamp jumps)", self.restarts)]
