"""Joint trajectories, the torques along them, their feasibility, the minimum-time
maneuver under torque (and speed) limits, and the time-optimal timing of a path
(``time_parameterize``; TOPP-RA, ``trajectory/time_parameterization.py``).

Shape functions s(x) on x in [0, 1] with s(0) = 0, s(1) = 1 and zero end rates:

    cubic       s = 3x^2 - 2x^3                       (jumps in acceleration at the ends)
    quintic     s = 10x^3 - 15x^4 + 6x^5               (zero end accelerations)
    cycloidal   s = x - sin(2 pi x) / (2 pi)           (zero end accelerations)

A point-to-point motion is q(t) = q0 + s(t/T) (q1 - q0); a via-point motion is a clamped
cubic spline (zero end velocities, continuous acceleration) through the points.

Minimum-time maneuver (the reference chapter; shared/reference section E). Along
q = q0 + s(x) dq, x = t/T, the actuator torques are

    tau(x; T) = f(x) / T^2 + g(q(x)) - delta(s'(x) dq / T),
    f(x) = M(q) s''(x) dq + C(q, s'(x) dq) s'(x) dq

(f by inverse dynamics at T = 1 minus the gravity torques, so that the split is exact to
round-off; delta the joint dissipation, which opposes the motion). Without gravity and
dissipation tau scales as 1/T^2 and T_min = max_i sqrt(F_i / tau_max_i), F_i = max_x |f_i|.
With them, T_min is the root of max_{i,x} |tau_i(x; T)| / tau_max_i = 1, found by
scipy.optimize.brentq after a scan that brackets the smallest feasible T. Joint speed limits
add T >= max |s'| |dq_i| / v_max_i. The maxima over x are taken on a grid of ``num`` points.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq


# ------------------------------------------------------------------ shape functions
def _cubic(x, d):
    return (3 * x**2 - 2 * x**3, 6 * x - 6 * x**2, 6 - 12 * x)[d]


def _quintic(x, d):
    return (10 * x**3 - 15 * x**4 + 6 * x**5, 30 * x**2 - 60 * x**3 + 30 * x**4,
            60 * x - 180 * x**2 + 120 * x**3)[d]


def _cycloidal(x, d):
    w = 2 * np.pi
    return (x - np.sin(w * x) / w, 1 - np.cos(w * x), w * np.sin(w * x))[d]


SHAPES = {"cubic": _cubic, "quintic": _quintic, "cycloidal": _cycloidal}


def shape(name, x, derivative=0):
    """s(x), s'(x) or s''(x) of the named shape function, x in [0, 1] (array or scalar)."""
    try:
        f = SHAPES[name]
    except KeyError:
        raise ValueError(f"shape {name!r} unknown; use one of {list(SHAPES)}") from None
    if derivative not in (0, 1, 2):
        raise ValueError(f"derivative {derivative}: use 0, 1 or 2")
    return f(np.asarray(x, dtype=float), derivative)


# ------------------------------------------------------------------ trajectories
class Trajectory:
    """q(t), qd(t), qdd(t) on [0, duration]; call it with times (scalar or (N,)) to get the
    three arrays ((n,) or (N, n)). Times outside [0, duration] are clamped (the robot
    rests at the end points)."""

    def __init__(self, duration, evaluate, dof):
        if not duration > 0:
            raise ValueError(f"duration = {duration}; it must be > 0 s")
        self.duration, self._evaluate, self.dof = float(duration), evaluate, dof

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        q, qd, qdd = self._evaluate(np.clip(np.atleast_1d(t), 0.0, self.duration))
        return (q[0], qd[0], qdd[0]) if t.ndim == 0 else (q, qd, qdd)

    def times(self, num=None, dt=None):
        """``num`` evenly spaced times including both ends, or a step ``dt``."""
        if dt is not None:
            return np.arange(0.0, self.duration + 0.5 * dt, dt).clip(max=self.duration)
        return np.linspace(0.0, self.duration, 1001 if num is None else int(num))

    def sample(self, num=None, dt=None):
        """(t, q, qd, qdd) on ``times(num, dt)``."""
        t = self.times(num, dt)
        return (t, *self(t))


def point_to_point(q0, q1, duration, shape_name="quintic"):
    """Rest-to-rest motion q0 -> q1 in ``duration`` seconds with the given shape function."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    if q0.shape != q1.shape or q0.ndim != 1:
        raise ValueError(f"q0 {q0.shape} and q1 {q1.shape} must be vectors of the same length")
    shape(shape_name, 0.0)                                         # validates the name
    dq, T = q1 - q0, float(duration)

    def evaluate(t):
        x = t / T
        s, s1, s2 = (shape(shape_name, x, d)[:, None] for d in range(3))
        return q0 + s * dq, s1 * dq / T, s2 * dq / T**2

    return Trajectory(T, evaluate, q0.size)


def via_points(points, times):
    """Motion through ``points`` (K, n) at ``times`` (K,), increasing from 0: a clamped cubic
    spline (zero velocity at both ends; position, velocity and acceleration continuous)."""
    points, times = np.asarray(points, dtype=float), np.asarray(times, dtype=float)
    if points.ndim != 2 or points.shape[0] != times.shape[0] or points.shape[0] < 2:
        raise ValueError(f"points {points.shape} and times {times.shape}: give (K, n) and (K,), K >= 2")
    if times[0] != 0 or np.any(np.diff(times) <= 0):
        raise ValueError("times must start at 0 and increase strictly")
    spline = CubicSpline(times, points, bc_type="clamped", axis=0)
    d1, d2 = spline.derivative(1), spline.derivative(2)
    return Trajectory(times[-1], lambda t: (spline(t), d1(t), d2(t)), points.shape[1])


# ------------------------------------------------------------------ torques and limits
def torques(robot, trajectory, t=None, num=1001, wrench=None, dissipation=False):
    """(t, tau): actuator torques (N, n) along the trajectory in one batch call of inverse
    dynamics; with ``dissipation`` the torques also overcome the robot's joint friction
    (tau - delta(qd))."""
    t = trajectory.times(num) if t is None else np.atleast_1d(np.asarray(t, dtype=float))
    q, qd, qdd = trajectory(t)
    tau = robot.inverse_dynamics(q, qd, qdd, wrench)
    if dissipation:
        tau = tau - robot.dissipation.torque(qd)
    return t, tau


@dataclass(frozen=True)
class Feasibility:
    """Peak use of each limit along a trajectory, as a fraction of the limit (<= 1 is fine)."""

    feasible: bool
    effort_ratio: np.ndarray        # (n,) max_t |tau_i| / effort_limit_i (0 where unlimited)
    velocity_ratio: np.ndarray      # (n,) max_t |qd_i| / velocity_limit_i
    position_ok: np.ndarray         # (n,) bool: within [lower, upper] throughout
    worst: str                      # e.g. "effort of joint 'elbow' at t = 0.31 s"


def check_limits(robot, trajectory, num=1001, wrench=None, dissipation=False):
    """Torques, speeds and positions along the trajectory against the robot's limits."""
    t, tau = torques(robot, trajectory, None, num, wrench, dissipation)
    q, qd, _ = trajectory(t)
    er = _ratio(np.abs(tau), robot.effort_limit)
    vr = _ratio(np.abs(qd), robot.velocity_limit)
    pos_ok = np.all((q >= robot.lower) & (q <= robot.upper), axis=0)
    names = robot.joint_names
    cand = [(er.max(), "effort", er), (vr.max(), "speed", vr)]
    peak, kind, r = max(cand, key=lambda c: c[0].max())
    j, k = np.unravel_index(np.argmax(r), r.shape)
    worst = f"{kind} of joint {names[k]!r} at t = {t[j]:.4g} s ({peak:.3g} of its limit)"
    if not np.all(pos_ok):
        worst = f"position of joint {names[int(np.flatnonzero(~pos_ok)[0])]!r} leaves its range; " + worst
    return Feasibility(bool(er.max() <= 1 and vr.max() <= 1 and np.all(pos_ok)), er.max(axis=0),
                       vr.max(axis=0), pos_ok, worst)


def _ratio(value, limit):
    limit = np.asarray(limit, dtype=float)
    return np.where(np.isfinite(limit), value / np.where(np.isfinite(limit), limit, 1.0), 0.0)


# ------------------------------------------------------------------ minimum-time maneuver
@dataclass(frozen=True)
class MinimumTime:
    """Result of ``minimum_time``: the shortest duration and what limits it."""

    T: float                        # s
    joint: str                      # the joint that reaches its limit
    limit: str                      # "effort" or "velocity"
    x: float                        # where along the path (x = t / T) it does
    T_effort: float                 # the effort-limited time alone
    T_velocity: float               # the speed-limited time alone
    trajectory: Trajectory


def minimum_time(robot, q0, q1, shape_name="cycloidal", gravity=True, dissipation=True,
                 velocity=True, num=2001, xtol=1e-12):
    """Shortest duration T of q(t) = q0 + s(t/T)(q1 - q0) within the effort limits (and the
    speed limits with ``velocity``). ``gravity`` / ``dissipation``: include the gravity
    torques / the robot's joint dissipation; with neither, the closed form of the 1/T^2
    scaling is used, otherwise a root-finder on T. Raises ValueError when no duration is
    feasible (gravity alone exceeds a limit along the path, or no limit is finite)."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    dq = q1 - q0
    x = np.linspace(0.0, 1.0, int(num))
    s, s1, s2 = (shape(shape_name, x, d) for d in range(3))
    q = q0 + s[:, None] * dq
    G = robot.gravity_torques(q) if gravity else np.zeros_like(q)
    F = robot.inverse_dynamics(q, s1[:, None] * dq, s2[:, None] * dq) - robot.gravity_torques(q)
    limit = np.asarray(robot.effort_limit, dtype=float)
    lim = np.where(np.isfinite(limit), limit, np.inf)
    names = robot.joint_names
    diss = robot.dissipation if dissipation and robot.dissipation.enabled else None

    def load(T):                    # (num, n) torque / limit at duration T
        tau = F / T**2 + G
        if diss is not None:
            tau = tau - diss.torque(s1[:, None] * dq / T)
        return np.abs(tau) / lim

    # speed limit: |qd| = |s'| |dq| / T <= v_max
    vlim = np.asarray(robot.velocity_limit, dtype=float)
    T_vel = float(np.max(np.abs(s1).max() * np.abs(dq) / vlim)) if velocity else 0.0
    # effort limit
    if not gravity and diss is None:                       # closed form: tau = f / T^2
        Fmax = np.abs(F).max(axis=0)
        T_eff = float(np.sqrt(np.max(Fmax / lim)))
    else:
        slow = load(1e12)                                  # as T -> infinity: gravity, friction
        if np.max(slow) > 1:
            j = int(np.argmax(np.max(slow, axis=0)))
            raise ValueError(f"no duration is feasible: holding joint {names[j]!r} against "
                             "gravity (and static friction) along the path exceeds its effort limit")
        h = lambda T: np.max(load(T)) - 1.0               # noqa: E731
        T_eff = _smallest_root(h, np.sqrt(np.max(np.abs(F).max(axis=0) / lim)), xtol)
    T = max(T_eff, T_vel)
    if not np.isfinite(T) or T <= 0:
        raise ValueError("no finite limit constrains the motion (or the motion is null); "
                         "give effort or velocity limits and distinct end points")
    if T_vel > T_eff:
        r = np.abs(s1)[:, None] * np.abs(dq) / T / vlim
        kind = "velocity"
    else:
        r = load(T)
        kind = "effort"
    k, j = np.unravel_index(np.argmax(r), r.shape)
    return MinimumTime(T, names[j], kind, float(x[k]), T_eff, T_vel,
                       point_to_point(q0, q1, T, shape_name))


def _smallest_root(h, T_guess, xtol):
    """The duration above which every T scanned is feasible (h(T) <= 0): scan a geometric
    grid around the inertial estimate for the last infeasible T, then brentq on the
    bracket above it. Just below the result the limit is violated."""
    if not np.isfinite(T_guess) or T_guess <= 0:
        T_guess = 1.0
    grid = T_guess * np.geomspace(1e-3, 1e3, 601)
    feasible = np.array([h(T) <= 0 for T in grid])
    if not feasible[-1]:
        raise ValueError("no duration up to 1000 x the inertial estimate is feasible")
    bad = np.flatnonzero(~feasible)
    if bad.size:
        lo, hi = grid[bad[-1]], grid[bad[-1] + 1]
    else:                                   # feasible over the whole grid: look further down
        hi = grid[0]
        for _ in range(60):
            lo = hi / 10
            if h(lo) > 0:
                break
            hi = lo
        else:
            raise ValueError("the motion needs no time: no limit is ever reached")
    return brentq(h, lo, hi, xtol=xtol * hi, rtol=4 * np.finfo(float).eps, maxiter=200)


# ------------------------------------------------------------------ waypoints (as in ROS)
# Time-parameterized waypoints, sampled like ros2_control's joint trajectory controller:
# positions only -> linear segments; positions and velocities -> cubic Hermite; positions,
# velocities and accelerations -> quintic Hermite (position, velocity and acceleration
# continuous at the waypoints). Before the first waypoint the first point holds; after the
# last, its position holds with zero velocity and acceleration. The computed-torque
# controller node samples trajectory_msgs/JointTrajectory with it.
class Waypoints:
    """Waypoints at times ``t`` (N,) (s, strictly increasing) with ``q`` (N, n) and
    optional ``qd``, ``qdd`` (N, n). ``interpolation``: None (by what is given, as above),
    or "cubic" (cubic Hermite from q and qd even when qdd is given: a time-optimal timing's
    accelerations jump at its switching points, which a quintic overshoots)."""

    def __init__(self, t, q, qd=None, qdd=None, interpolation=None):
        self.t = np.asarray(t, dtype=float)
        self.q = np.atleast_2d(np.asarray(q, dtype=float))
        if self.t.shape != (self.q.shape[0],) or np.any(np.diff(self.t) <= 0):
            raise ValueError("waypoint times must be strictly increasing, one per point")
        self.order = 1 if qd is None else (3 if qdd is None else 5)
        if interpolation not in (None, "cubic") or (interpolation and qd is None):
            raise ValueError(f"interpolation {interpolation!r}: None, or 'cubic' with qd")
        if interpolation == "cubic":
            self.order = 3
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


# ------------------------------------------------------------------ time-parameterization
def time_parameterize(robot, path, velocity_limit=None, acceleration_limit=None,
                      effort_limit=None, grid=200, dissipation=True, check=8) -> Waypoints:
    """The fastest timing of ``path`` (N, n) joint positions (``robot.joint_names`` order)
    from rest to rest within the velocity, acceleration and effort limits (the robot's
    ``velocity_limit`` and ``effort_limit`` by default, none on acceleration; a number or
    one per joint; inf: none; a zero velocity or acceleration limit: the joint holds
    still), with the full dynamics: gravity, the payload, and the robot's joint friction
    with ``dissipation`` when it is enabled. TOPP-RA (the ``toppra`` package) on ``grid``
    intervals (``trajectory/time_parameterization.py``).

    The path is timed by its geometry, not by how many waypoints describe it: repeated
    consecutive waypoints are dropped, points on a straight stretch count as its ends, the
    motion rests at every corner (a turn of more than ``time_parameterization.CORNER``,
    0.1 rad, in joint space: the timed path follows the chords there exactly), and a run
    of gentler turns is a cubic spline through its vertices. Returns ``Waypoints`` at the
    grid points with positions, velocities and accelerations (first, last and each corner at
    rest; sampled as cubic Hermite, which holds the solver's constant path acceleration on
    each interval), checked on a grid ``check`` times finer (stretched uniformly in time,
    ``.stretch``, where the interpolation exceeds a limit); a path that never moves: one
    point at t = 0.
    ValueError naming the joint and the waypoint when no timing is feasible (gravity and
    friction alone exceed an effort limit; a joint moves under a zero limit)."""
    from . import time_parameterization as tp
    if robot.is_floating:
        raise NotImplementedError("time_parameterize needs a fixed base")
    t, q, qd, qdd, limits = tp.solve(robot, path, velocity_limit, acceleration_limit,
                                     effort_limit, grid, dissipation)
    check = max(int(check), 1)
    k = 1.0
    for _ in range(60):
        w = Waypoints(k * t, q, qd / k, qdd / k**2, interpolation="cubic")
        fine = np.linspace(0.0, 1.0, check + 1)[:-1]
        # and each segment's end from its own side (a cubic's acceleration peaks at its ends)
        ts = np.concatenate([(w.t[:-1, None] + fine * np.diff(w.t)[:, None]).ravel(), w.t[-1:],
                             w.t[1:] - 1e-9 * np.diff(w.t)])
        rv, ra, re = tp.limit_ratios(robot, *w.sample(ts), limits)
        worst = max(rv, np.sqrt(ra), np.sqrt(re))
        if worst <= 1.0:
            w.stretch = k
            return w
        k *= worst * (1 + 1e-9) if re <= 1.0 else max(worst, 1.0 + 1e-4)
    raise ValueError("the timed path still exceeds a limit between grid points after "
                     f"stretching it {k:.3g} times; give a finer grid (now {grid})")


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


def pick_and_place(robot) -> Waypoints:
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
    return Waypoints(t, q, zero, zero)
