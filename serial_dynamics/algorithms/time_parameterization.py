"""Time-optimal parameterization of a joint path under velocity, acceleration and effort
limits with the full dynamics: TOPP-RA (Pham and Pham, "A new approach to time-optimal
path parameterization based on reachability analysis", IEEE T-RO 34(3), 2018) through the
``toppra`` package; ``trajectory.time_parameterize`` is the public entry point.

The path q(s), s in [0, 1], is a cubic spline through the waypoints (toppra's
``SplineInterpolator``, parameterized by the normalized chord length; two waypoints: the
straight line). Along it, with x = sd^2 and u = sdd, qd = q' sd and qdd = q' u + q'' x, so
the actuator torques are (Pham and Pham 2018, Sec. II; Bobrow, Dubowsky and Gibson 1985)

    tau = a(s) u + b(s) x + c(s) + f(s, sd),
    a = M q' = ID(q, 0, q') - g,  b = ID(q, q', q'') - g,  c = g = ID(q, 0, 0)

(three batched calls of the robot's inverse dynamics over the grid: gravity and any payload
included). Joint friction f (the robot's ``dissipation`` when ``dissipation=True`` and it is
enabled): the dry part (Coulomb plus the low-speed rise at rest) is fc sgn(q') and joins c
(the motion runs forward along the path, sd >= 0); the viscous part fv q' sd is not linear
in x, and is bounded by its tangent at the previous solution's x0 (sd <= (x + x0) / (2
sqrt(x0)), exact at x0), in a second pass: conservative, and tight where the profile does
not change. Every limit is checked again on a grid ``check`` times finer than the solver's,
on the returned waypoints (quintic Hermite between them, ``trajectory.Waypoints``); where
the interpolation between grid points exceeds a limit, the whole timing is stretched
uniformly until none does.
"""
from __future__ import annotations

import numpy as np

VISCOUS_PASSES = 2       # the viscous bound's tangent point: one pass without it, one with


def _toppra():
    import toppra
    toppra.setup_logging("WARNING")
    return toppra


def check_path(robot, path):
    """(N, n) float array of a path; ValueError naming the culprit."""
    path = np.asarray(path, dtype=float)
    n = robot.dof
    if path.ndim != 2 or path.shape[1] != n or path.shape[0] < 2:
        raise ValueError(f"path has shape {path.shape}; give (N, {n}) joint positions, N >= 2, "
                         f"for the joints {robot.joint_names}")
    if not np.all(np.isfinite(path)):
        k, j = np.argwhere(~np.isfinite(path))[0]
        raise ValueError(f"path waypoint {k} has a NaN or Inf position of joint "
                         f"{robot.joint_names[j]!r}; give finite numbers")
    step = np.linalg.norm(np.diff(path, axis=0), axis=1)
    if np.any(step == 0):
        k = int(np.flatnonzero(step == 0)[0])
        raise ValueError(f"path waypoints {k} and {k + 1} are the same; drop the repeated one "
                         "(a dwell is a pause between two timed paths)")
    lo, hi = robot.lower, robot.upper
    bad = (path < lo - 1e-9) | (path > hi + 1e-9)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise ValueError(f"path waypoint {k}: joint {robot.joint_names[j]!r} at {path[k, j]:.6g} "
                         f"is outside its range [{lo[j]:.6g}, {hi[j]:.6g}]")
    return path, np.concatenate([[0.0], np.cumsum(step)]) / step.sum()


def _limits(value, default, name, n, names):
    v = np.array(default if value is None else value, dtype=float).reshape(-1)
    v = np.broadcast_to(v, (n,)) if v.size == 1 else v
    if v.shape != (n,) or np.any(np.isnan(v)) or np.any(v <= 0):
        raise ValueError(f"{name} must be one positive number or one per joint {names} "
                         "(inf: none)")
    return v


class _Effort:
    """toppra's canonical linear constraint for |tau_i| <= limit_i: rows v = [tau's upper
    bound; its lower bound] (they differ by the viscous term's bound), F v <= g."""

    def __new__(cls, robot, limit, dry, viscous, x0):
        ta = _toppra()

        class Effort(ta.constraint.LinearConstraint):
            def __init__(self):
                super().__init__()
                self.identical = True
                self.discretization_type = ta.constraint.DiscretizationType.Interpolation

            def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
                a, b, cu, cl = path_torques(robot, path, gridpoints, dry)
                n = robot.dof
                up, lo = [np.zeros_like(a) for _ in range(2)], [np.zeros_like(a) for _ in range(2)]
                if viscous is not None and x0 is not None:
                    k = viscous * path.evald(gridpoints)              # fv q': tau_v = k sd
                    r = np.sqrt(np.maximum(x0, 1e-12))[:, None]
                    tx, tc = k / (2 * r), k * r / 2                   # k sd <= tx x + tc (k >= 0)
                    up = [np.where(k > 0, tx, 0.0), np.where(k > 0, tc, 0.0)]
                    lo = [np.where(k < 0, tx, 0.0), np.where(k < 0, tc, 0.0)]
                A = np.hstack([a, a])
                B = np.hstack([b + up[0], b + lo[0]])
                C = np.hstack([cu + up[1], cl + lo[1]])
                F = np.zeros((2 * n, 2 * n))
                F[:n, :n], F[n:, n:] = np.eye(n), -np.eye(n)
                fin = np.isfinite(limit)
                keep = np.concatenate([fin, fin])
                F, g = F[keep], np.concatenate([limit, limit])[keep]
                return ta.constraint.linear_constraint.canlinear_colloc_to_interpolate(
                    A, B, C, F, g, None, None, gridpoints, identical=True)

        return Effort()


def path_torques(robot, path, s, dry):
    """(a, b, c_upper, c_lower) (len(s), n): tau = a u + b x + c along the path (module
    docstring), c's bounds with the dry friction."""
    q, q1, q2 = path.eval(s), path.evald(s), path.evaldd(s)
    c = robot.inverse_dynamics(q, np.zeros_like(q), np.zeros_like(q))
    a = robot.inverse_dynamics(q, np.zeros_like(q), q1) - c
    b = robot.inverse_dynamics(q, q1, q2) - c
    if dry is None:
        return a, b, c, c
    # a joint whose rate changes sign next to a grid point may move either way there: both
    # signs of its dry friction bound the torque (upper, lower)
    sg = np.sign(q1)
    near = np.stack([np.r_[sg[:1], sg[:-1]], sg, np.r_[sg[1:], sg[-1:]]])
    return a, b, c + dry * near.max(axis=0), c + dry * near.min(axis=0)


def solve(robot, path, velocity_limit=None, acceleration_limit=None, effort_limit=None,
          grid=200, dissipation=True, check=4):
    """(t, q, qd, qdd, s) at the grid points of the time-optimal timing of ``path`` (module
    docstring); ValueError when no timing is feasible, naming the joint and the waypoint."""
    ta = _toppra()
    path, ss = check_path(robot, path)
    n, names = robot.dof, robot.joint_names
    vmax = _limits(velocity_limit, robot.velocity_limit, "velocity_limit", n, names)
    amax = _limits(acceleration_limit, np.inf, "acceleration_limit", n, names)
    emax = _limits(effort_limit, robot.effort_limit, "effort_limit", n, names)
    grid = int(grid)
    if grid < 2:
        raise ValueError(f"grid = {grid}; give at least 2 intervals (a few hundred is typical)")
    spline = ta.SplineInterpolator(ss, path)
    s = np.union1d(np.linspace(0.0, 1.0, grid + 1), ss)         # the waypoints on the grid
    d = robot.dissipation
    on = dissipation and d.enabled
    dry = d.coulomb + d.stribeck if on else None
    viscous = d.viscous if on and np.any(d.viscous > 0) else None
    _static_check(robot, spline, s, ss, dry, emax)
    constraints = []
    if np.any(np.isfinite(vmax)):
        constraints.append(ta.constraint.JointVelocityConstraint(np.column_stack([-vmax, vmax])))
    if np.any(np.isfinite(amax)):
        c = ta.constraint.JointAccelerationConstraint(np.column_stack([-amax, amax]))
        c.discretization_type = ta.constraint.DiscretizationType.Interpolation
        constraints.append(c)
    x0 = None
    for _ in range(VISCOUS_PASSES if viscous is not None else 1):
        effort = [_Effort(robot, emax, dry, viscous, x0)] if np.any(np.isfinite(emax)) else []
        inst = ta.algorithm.TOPPRA(constraints + effort, spline, gridpoints=s)
        sdd, sd, _ = inst.compute_parameterization(0.0, 0.0)[:3]
        if sd is None:
            raise ValueError("no timing of the path is within the limits (TOPP-RA found the "
                             "path not controllable from rest to rest); slow limits that are "
                             "too tight for the dynamics, or split the path")
        x0 = sd ** 2
    if not np.all(np.isfinite(sd)) or np.all(sd[1:-1] == 0):
        raise ValueError("no finite limit constrains the motion: give velocity, acceleration "
                         "or effort limits")
    sd = np.maximum(sd, 0.0)
    dt = 2 * np.diff(s) / np.maximum(sd[:-1] + sd[1:], 1e-300)  # constant sdd on each interval
    t = np.concatenate([[0.0], np.cumsum(dt)])
    # sdd is constant on each interval and jumps at switching points: each grid point gets
    # the mean of its two sides (the quintic Hermite between waypoints then overshoots by
    # less; the first and last points their one side)
    u = np.concatenate([sdd[:1], 0.5 * (sdd[:-1] + sdd[1:]), sdd[-1:]])
    q, q1, q2 = spline.eval(s), spline.evald(s), spline.evaldd(s)
    qd, qdd = q1 * sd[:, None], q1 * u[:, None] + q2 * (sd ** 2)[:, None]
    qd[[0, -1]] = 0.0
    return t, q, qd, qdd, (vmax, amax, emax, on)


def _static_check(robot, spline, s, ss, dry, emax):
    """Gravity (with the payload) and dry friction alone must be within the effort limits
    at every grid point: else a ValueError naming the joint and the nearest waypoint."""
    q = spline.eval(s)
    c = robot.gravity_torques(q) + (0.0 if dry is None else dry * np.sign(spline.evald(s)))
    over = np.abs(c) > emax
    if np.any(over):
        k, j = np.argwhere(over)[0]
        w = int(np.argmin(np.abs(ss - s[k])))
        at = (f"at waypoint {w}" if np.isclose(ss[w], s[k]) else
              f"near waypoint {w} (path parameter {s[k]:.3g}, between waypoints "
              f"{int(np.searchsorted(ss, s[k]) - 1)} and {int(np.searchsorted(ss, s[k]))})")
        raise ValueError(f"infeasible path: holding joint {robot.joint_names[j]!r} against "
                         f"gravity{'' if dry is None else ' and friction'} takes "
                         f"{abs(c[k, j]):.4g}, above its effort limit {emax[j]:.4g}, {at}; "
                         "lighten the payload, raise the limit or change the path")


def limit_ratios(robot, q, qd, qdd, limits):
    """Peak |qd|/vmax, |qdd|/amax, |tau|/emax over samples (tau with the robot's friction
    when it is on)."""
    vmax, amax, emax, on = limits
    tau = robot.inverse_dynamics(q, qd, qdd)
    if on:
        tau = tau - robot.dissipation.torque(qd)
    r = lambda x, lim: float(np.max(np.abs(x) / lim))      # noqa: E731 (inf limit: 0)
    return r(qd, vmax), r(qdd, amax), r(tau, emax)
