"""Excitation trajectories for identification: a finite Fourier series per joint, its
coefficients chosen to minimize the condition number of the base regressor within the
joint limits (Swevers, Ganseman, Tukel, De Schutter, Van Brussel, "Optimal robot
excitation and identification", IEEE T-RA 13(5), 1997).

Joint i, base pulsation w = 2 pi / period, harmonics l = 1 .. H (Swevers et al., eq. 8):

    q_i(t)   = q0_i + sum_l  a_il / (w l) sin(w l t) - b_il / (w l) cos(w l t)
    qd_i(t)  =        sum_l  a_il cos(w l t) + b_il sin(w l t)
    qdd_i(t) =        sum_l -a_il w l sin(w l t) + b_il w l cos(w l t)

The series is periodic; it is at rest (qd = qdd = 0) at t = 0 and after every period when
sum_l a_il = 0 and sum_l l b_il = 0, which the parametrization keeps exactly: a_i1 and b_i1
are those sums' remainders, the other coefficients and q0 are free. The objective is
log cond(W), W the base regressor (friction columns included) stacked over samples of
one period. The limits hold by construction: each joint's coefficients are scaled to the
largest amplitude within its position range, speed and acceleration limits (each used up
to ``margin`` of itself), then all together within the effort limits (inverse dynamics
plus the robot's friction; bisection), on the samples during the search and on a grid
20 times finer for the result. The search over the
coefficients' directions is scipy.optimize.minimize's Powell method (derivative free:
the peaks over time make the objective only piecewise smooth).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from .base_parameters import base_parameters


@dataclass(frozen=True, eq=False)
class Excitation:
    """A periodic Fourier excitation, at rest at t = 0 and at the end of each period.
    Call it with times to get (q, qd, qdd); ``condition_number``: cond of the base
    regressor over one period (friction columns included when optimized with them)."""

    joint_names: tuple
    q0: np.ndarray               # (n,) offsets, rad or m
    a: np.ndarray                # (n, H) sine coefficients, rad/s
    b: np.ndarray                # (n, H) cosine coefficients, rad/s
    period: float                # s
    duration: float              # s, a whole number of periods
    condition_number: float
    initial_condition_number: float
    peak: dict                   # name -> (n,) peak use of each limit (fraction; position:
                                 # of the distance from the center to the range's nearer end)
    iterations: int = 0

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    def __call__(self, t):
        """(q, qd, qdd) at times ``t`` ((N,) -> (N, n) each; a scalar -> (n,) each)."""
        t = np.asarray(t, dtype=float)
        q, qd, qdd = fourier(self.q0, self.a, self.b, 2 * np.pi / self.period,
                             np.atleast_1d(t))
        return (q[0], qd[0], qdd[0]) if t.ndim == 0 else (q, qd, qdd)

    def sample(self, dt=0.01):
        """(t, q, qd, qdd) every ``dt`` seconds over the whole duration, both ends included."""
        t = np.linspace(0.0, self.duration, int(round(self.duration / dt)) + 1)
        return (t, *self(t))

    def trajectory(self):
        """The excitation as a ``serial_dynamics.trajectory.Trajectory``."""
        from ..trajectory import Trajectory
        return Trajectory(self.duration, lambda t: self(t), len(self.joint_names))

    def to_csv(self, path, dt=0.01):
        """Write t, q_<joint>, qd_<joint>, qdd_<joint> every ``dt`` s (the reference a
        controller follows)."""
        t, q, qd, qdd = self.sample(dt)
        head = (["t"] + [f"q_{j}" for j in self.joint_names]
                + [f"qd_{j}" for j in self.joint_names] + [f"qdd_{j}" for j in self.joint_names])
        np.savetxt(path, np.column_stack([t, q, qd, qdd]), delimiter=",",
                   header=",".join(head), comments="", fmt="%.12g")


def fourier(q0, a, b, w, t):
    """(q, qd, qdd), each (N, n), of the Fourier series (module docstring) at times t (N,)."""
    l = np.arange(1, a.shape[1] + 1)
    wl = w * l                                           # (H,)
    s, c = np.sin(t[:, None] * wl), np.cos(t[:, None] * wl)   # (N, H)
    q = q0 + s @ (a / wl).T - c @ (b / wl).T           # Fourier series (Swevers et al. 1997)
    qd = c @ a.T + s @ b.T
    qdd = -s @ (a * wl).T + c @ (b * wl).T
    return q, qd, qdd


def _coefficients(x, n, H):
    """(q0, a, b) from the free variables x: q0 (n), a_il and b_il for l >= 2; a_i1, b_i1
    make the series start at rest (sum_l a_il = 0, sum_l l b_il = 0)."""
    q0 = x[:n]
    a_free = x[n:n + n * (H - 1)].reshape(n, H - 1)
    b_free = x[n + n * (H - 1):].reshape(n, H - 1)
    l = np.arange(2, H + 1)
    a = np.column_stack([-a_free.sum(axis=1), a_free])
    b = np.column_stack([-(b_free * l).sum(axis=1), b_free])
    return q0, a, b


def _limits(robot, margin, acceleration_limit):
    n = robot.dof
    lo, hi = np.asarray(robot.lower, float), np.asarray(robot.upper, float)
    vmax = np.asarray(robot.velocity_limit, float)
    amax = (np.full(n, np.inf) if acceleration_limit is None
            else np.broadcast_to(np.asarray(acceleration_limit, float), (n,)))
    emax = np.asarray(robot.effort_limit, float)
    if not np.all(np.isfinite(vmax)) and acceleration_limit is None:
        free = [robot.joint_names[i] for i in np.flatnonzero(~np.isfinite(vmax))]
        raise ValueError(f"joints {free} "
                         "have no speed limit in the URDF; give acceleration_limit (and "
                         "velocity_limit in the URDF) to bound the excitation")
    return lo, hi, margin * vmax, margin * amax, margin * emax


def excitation(robot, duration=10.0, harmonics=5, periods=1, friction=True, margin=0.8,
               acceleration_limit=None, center=None, samples=None, seed=0, maxiter=10,
               progress=None) -> Excitation:
    """Optimize a Fourier excitation of ``duration`` seconds (``periods`` repetitions of
    one period, ``harmonics`` per joint, >= 2) for ``robot``: minimum condition number of
    the base regressor (with the friction columns when ``friction``), within the joint
    ranges and ``margin`` (0 .. 1] of the speed, ``acceleration_limit`` (rad/s^2 per joint
    or one for all; default: the speed limit per second) and effort limits. ``center``:
    the starting offsets q0 (default: the middle of each range, 0 where unlimited).
    ``samples``: time samples per period for the objective and the limits (default
    max(100, 20 H)). ``maxiter``: Powell iterations (each a line search along every
    coefficient). ``progress``: callable(iteration, condition_number). Deterministic for
    a given ``seed``."""
    n, H = robot.dof, int(harmonics)
    if H < 2:
        raise ValueError(f"harmonics = {H}; give at least 2 (one is used to start at rest)")
    if not (duration > 0 and periods >= 1 and 0 < margin <= 1):
        raise ValueError(f"duration = {duration}, periods = {periods}, margin = {margin}: give "
                         "duration > 0 s, periods >= 1, 0 < margin <= 1")
    period = float(duration) / int(periods)
    w = 2 * np.pi / period
    if acceleration_limit is None:
        acceleration_limit = np.asarray(robot.velocity_limit, float) * 1.0
    lo, hi, vmax, amax, emax = _limits(robot, margin, acceleration_limit)
    if center is None:
        finite = np.isfinite(lo) & np.isfinite(hi)
        center = np.where(finite, 0.5 * (np.where(finite, lo, 0) + np.where(finite, hi, 0)), 0.0)
    center = np.asarray(center, float).reshape(n)
    m = int(samples or max(100, 20 * H))
    t = np.arange(m) * (period / m)
    bp = base_parameters(robot, friction=friction)
    diss = robot.dissipation
    span = np.where(np.isfinite(hi - lo), hi - lo, 2 * np.pi)
    # positions stay margin-inside the range: |q - center| <= reach
    reach = np.minimum(center - (lo + 0.5 * (1 - margin) * span),
                       (hi - 0.5 * (1 - margin) * span) - center)
    if np.any(reach <= 0):
        j = int(np.flatnonzero(reach <= 0)[0])
        raise ValueError(f"center of joint {robot.joint_names[j]!r} ({center[j]:g}) leaves no "
                         "room within its range; choose a center inside it")

    fine = np.arange(20 * m) * (period / (20 * m))    # the final check, between the samples

    def motion(c, scale=1.0, times=t):
        q0, a, b = _coefficients(np.concatenate([center, scale * c]), n, H)
        return fourier(q0, a, b, w, times)

    def use(c, scale=1.0, times=t):
        """Peak use of each limit (fraction of the allowed value), per joint: (4, n)."""
        q, qd, qdd = motion(c, scale, times)
        tau = robot.inverse_dynamics(q, qd, qdd) - diss.torque(qd)
        return np.array([np.max(np.abs(v), axis=0) / lim for v, lim in
                         ((q - center, reach), (qd, vmax), (qdd, amax), (tau, emax))])

    def feasible_scale(c, times=t):
        """Per joint, the largest scale of its coefficients within its position, speed and
        acceleration limits (these grow linearly with it); then one common factor within
        the effort limits (bisection). (n,) per joint, repeated over its coefficients."""
        k = 1.0 / np.maximum(use(c, 1.0, times)[:3].max(axis=0), 1e-300)    # (n,)
        k = np.tile(k, 2 * (H - 1)).reshape(2, H - 1, n).transpose(0, 2, 1).ravel()
        if use(c, k, times)[3].max() <= 1:
            return k
        lo_, hi_ = 0.0, 1.0
        for _ in range(20):
            mid = 0.5 * (lo_ + hi_)
            lo_, hi_ = (mid, hi_) if use(c, mid * k, times)[3].max() <= 1 else (lo_, mid)
        return lo_ * k

    def objective(c):
        """log cond of the base regressor along c scaled to the limits."""
        q, qd, qdd = motion(c, feasible_scale(c))
        W = bp.project(robot.regressor(q, qd, qdd, friction=friction)).reshape(-1, bp.count)
        ev = np.linalg.eigvalsh(W.T @ W)     # cond(W)^2 = ev_max / ev_min (cheaper than an SVD)
        return float(0.5 * np.log(ev[-1] / max(ev[0], 1e-300 * ev[-1], 1e-300)))

    def condition(c):
        """cond of the base regressor along the coefficients c as they are."""
        q, qd, qdd = motion(c)
        W = bp.project(robot.regressor(q, qd, qdd, friction=friction)).reshape(-1, bp.count)
        return float(np.linalg.cond(W))

    rng = np.random.default_rng(seed)
    c0 = rng.standard_normal(2 * n * (H - 1))
    c0 /= np.linalg.norm(c0)
    cond0 = float(np.exp(objective(c0)))
    best = [np.log(cond0), c0]
    it = [0]

    def tracked(c):
        f = objective(c)
        if f < best[0]:
            best[:] = [f, c.copy()]
        return f

    def callback(c):
        it[0] += 1
        if progress is not None:
            progress(it[0], float(np.exp(best[0])))

    # Powell's derivative-free search: the peaks over time and the scaling to the limits
    # make the objective only piecewise smooth, where gradient methods stall
    if maxiter > 0:
        minimize(tracked, c0, method="Powell", callback=callback,
                 options=dict(maxiter=int(maxiter), xtol=1e-3, ftol=1e-4))
    c = best[1]
    # a peak between the fine samples (>= 400 per period of the highest harmonic) exceeds
    # the sampled one by at most 1 - cos(pi / 400) = 3e-5 of it: keep 1e-4 below
    x = np.concatenate([center, (1 - 1e-4) * feasible_scale(c, fine) * c])
    q0, a, b = _coefficients(x, n, H)
    peak = dict(zip(("position", "velocity", "acceleration", "effort"),
                    margin * use(x[n:], 1.0, fine)))
    return Excitation(tuple(robot.joint_names), q0, a, b, period, period * int(periods),
                      condition(x[n:]), condition(c0 * feasible_scale(c0, fine)), peak, it[0])

