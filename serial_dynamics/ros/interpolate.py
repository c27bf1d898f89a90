"""Time-parameterized joint trajectories: sampling between waypoints (pure numpy).

Like ros2_control's joint trajectory controller: positions only -> linear segments;
positions and velocities -> cubic Hermite; positions, velocities and accelerations ->
quintic Hermite (position, velocity and acceleration continuous at the waypoints).
Before the first waypoint the first point holds; after the last, its position holds
with zero velocity and acceleration.
"""
from __future__ import annotations

import numpy as np


class Trajectory:
    """Waypoints at times ``t`` (N,) (s, strictly increasing) with ``q`` (N, n) and
    optional ``qd``, ``qdd`` (N, n)."""

    def __init__(self, t, q, qd=None, qdd=None):
        self.t = np.asarray(t, dtype=float)
        self.q = np.atleast_2d(np.asarray(q, dtype=float))
        if self.t.shape != (self.q.shape[0],) or np.any(np.diff(self.t) <= 0):
            raise ValueError("waypoint times must be strictly increasing, one per point")
        self.order = 1 if qd is None else (3 if qdd is None else 5)
        zero = np.zeros_like(self.q)
        self.qd = zero if qd is None else np.asarray(qd, dtype=float)
        self.qdd = zero if qdd is None else np.asarray(qdd, dtype=float)

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def sample(self, t):
        """(q, qd, qdd) at time(s) t: scalar -> (n,) each, array (M,) -> (M, n) each."""
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        N = len(self.t)
        q, qd, qdd = (np.empty((ts.size, self.q.shape[1])) for _ in range(3))
        before, after = ts <= self.t[0], ts >= self.t[-1]
        q[before], qd[before], qdd[before] = self.q[0], self.qd[0], self.qdd[0]
        q[after], qd[after], qdd[after] = self.q[-1], 0.0, 0.0
        inside = ~(before | after)
        if N > 1 and np.any(inside):
            i = np.clip(np.searchsorted(self.t, ts[inside], side="right") - 1, 0, N - 2)
            T = (self.t[i + 1] - self.t[i])[:, None]
            s = (ts[inside] - self.t[i])[:, None] / T
            q[inside], qd[inside], qdd[inside] = self._segment(i, s, T)
        if np.ndim(t) == 0:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def _segment(self, i, s, T):
        p0, p1 = self.q[i], self.q[i + 1]
        if self.order == 1:
            v = (p1 - p0) / T
            return p0 + s * (p1 - p0), v, np.zeros_like(v)
        v0, v1 = self.qd[i] * T, self.qd[i + 1] * T           # derivatives in s
        if self.order == 3:
            h = [2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2]
            dh = [6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s]
            ddh = [12 * s - 6, 6 * s - 4, -12 * s + 6, 6 * s - 2]
            coef = (p0, v0, p1, v1)
        else:
            a0, a1 = self.qdd[i] * T**2, self.qdd[i + 1] * T**2
            s2, s3, s4, s5 = s**2, s**3, s**4, s**5
            h = [1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5,
                 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5, 10 * s3 - 15 * s4 + 6 * s5,
                 -4 * s3 + 7 * s4 - 3 * s5, 0.5 * s3 - s4 + 0.5 * s5]
            dh = [-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4,
                  s - 4.5 * s2 + 6 * s3 - 2.5 * s4, 30 * s2 - 60 * s3 + 30 * s4,
                  -12 * s2 + 28 * s3 - 15 * s4, 1.5 * s2 - 4 * s3 + 2.5 * s4]
            ddh = [-60 * s + 180 * s2 - 120 * s3, -36 * s + 96 * s2 - 60 * s3,
                   1 - 9 * s + 18 * s2 - 10 * s3, 60 * s - 180 * s2 + 120 * s3,
                   -24 * s + 84 * s2 - 60 * s3, 3 * s - 12 * s2 + 10 * s3]
            coef = (p0, v0, a0, p1, v1, a1)
        q = sum(h_ * c for h_, c in zip(h, coef))
        qd = sum(h_ * c for h_, c in zip(dh, coef)) / T
        qdd = sum(h_ * c for h_, c in zip(ddh, coef)) / T**2
        return q, qd, qdd


# ------------------------------------------------------------------ the demo's task
UR5E_PICK_AND_PLACE = [   # (time s, joint positions rad) for the UR5e joints, base to tip
    (0.0, [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]),      # home
    (1.0, [0.6, -1.25, 1.65, -1.97, -1.571, 0.6]),         # above the pick
    (1.5, [0.6, -1.05, 1.80, -2.32, -1.571, 0.6]),         # pick (down)
    (1.8, [0.6, -1.05, 1.80, -2.32, -1.571, 0.6]),         # grasp (dwell)
    (2.3, [0.6, -1.25, 1.65, -1.97, -1.571, 0.6]),         # lift
    (3.5, [-0.7, -1.25, 1.65, -1.97, -1.571, -0.7]),       # above the place
    (4.0, [-0.7, -1.05, 1.80, -2.32, -1.571, -0.7]),       # place (down)
    (4.3, [-0.7, -1.05, 1.80, -2.32, -1.571, -0.7]),       # release (dwell)
    (4.8, [-0.7, -1.25, 1.65, -1.97, -1.571, -0.7]),       # retreat
]


def pick_and_place(robot) -> Trajectory:
    """The built-in pick-and-place task: rest-to-rest quintic segments through the
    waypoints (zero velocity and acceleration at each). For the UR5e, the waypoints above;
    for any other chain, the same rhythm with offsets of up to 0.4 rad (0.05 m for
    prismatic joints) about the middle of each joint's range (0 where unlimited)."""
    t = np.array([w[0] for w in UR5E_PICK_AND_PLACE])
    ur = [f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1",
                                 "wrist_2", "wrist_3")]
    if robot.joint_names == ur:
        q = np.array([w[1] for w in UR5E_PICK_AND_PLACE])
    else:
        limited = np.isfinite(robot.lower) & np.isfinite(robot.upper)
        mid = np.where(limited, 0.5 * (np.where(limited, robot.lower, 0) + np.where(limited, robot.upper, 0)), 0.0)
        scale = np.array([0.05 if k == "prismatic" else 0.4 for k in robot.joint_types])
        pattern = np.array([0.0, 0.6, 1.0, 1.0, 0.6, -0.6, -1.0, -1.0, -0.6])
        sign = np.where(np.arange(robot.dof) % 2 == 0, 1.0, -1.0)
        q = mid + pattern[:, None] * scale * sign
    zero = np.zeros_like(q)
    return Trajectory(t, q, zero, zero)
