"""Time-optimal parameterization of a joint path under velocity, acceleration and effort
limits with the full dynamics: TOPP-RA (Pham and Pham, "A new approach to time-optimal
path parameterization based on reachability analysis", IEEE T-RO 34(3), 2018) through the
``toppra`` package; ``trajectory.time_parameterize`` is the public entry point.

The path is its geometry, not its sampling, so that its timing does not depend on how many
waypoints describe it (``split_path``):

1. a waypoint within ``REPEATED`` (rad, or m) of the previous kept one repeats it and is
   dropped (MoveIt often repeats the end points), except that the last waypoint takes the
   place of the one it repeats; a path that never moves farther is one point at rest;
2. a waypoint within ``COLLINEAR`` of the chord from the previous vertex to the next
   waypoint is dropped: a straight stretch is its two ends, however many points describe it;
3. a vertex where the path turns by more than ``CORNER`` rad (the angle between the chords
   into and out of it, in joint space) is a corner, and the motion comes to rest there: the
   timed path follows the chords exactly (a planner checked them for collisions), run by
   run, each timed from rest to rest;
4. a run of two vertices is the straight line between them; a longer run (every turn at
   most ``CORNER``) is the cubic spline through its vertices (not-a-knot, parameterized by
   the chord length), so that a dense sampling of a smooth curve converges to
   the curve. At a turn of ``CORNER`` the spline leaves the chords by up to 1.2 % of their
   length. A coarse sampling of a curve (turns above ``CORNER``) is a polyline, timed with a
   rest at each vertex.

The solver's grid: ``grid`` intervals spread over the runs in proportion to their chord
length (at least ``MIN_INTERVALS`` on each), uniform on each, plus a spline's vertices (a
uniform point closer than a quarter interval to one moves onto it).

Along a run q(s), s its chord length, with x = sd^2 and u = sdd, qd = q' sd and
qdd = q' u + q'' x, so the actuator torques are (Pham and Pham 2018, Sec. II; Bobrow,
Dubowsky and Gibson 1985)

    tau = a(s) u + b(s) x + c(s) + f(s, sd),
    a = M q' = ID(q, 0, q') - g,  b = ID(q, q', q'') - g,  c = g = ID(q, 0, 0)

(three batched calls of the robot's inverse dynamics over the grid: gravity and any payload
included). Joint friction f (the robot's ``dissipation`` when ``dissipation=True`` and it is
enabled): the dry part (Coulomb plus the low-speed rise at rest) is fc sgn(q') and joins c
(the motion runs forward along the path, sd >= 0); the viscous part fv q' sd is not linear
in x, and is bounded by its tangent at the previous solution's x0 (sd <= (x + x0) / (2
sqrt(x0)), exact at x0), in a second pass: conservative, and tight where the profile does
not change. Every limit is checked again on a grid ``check`` times finer than the solver's,
on the returned waypoints (``trajectory.Waypoints``); where the interpolation between grid
points exceeds a limit, the whole timing is stretched uniformly until none does.

Infeasible paths are refused before TOPP-RA runs, naming the joint and the waypoints:
gravity (and dry friction) alone beyond an effort limit, or a joint that moves under a zero
velocity or acceleration limit. toppra's own log records go to this module's logger
(``serial_dynamics.trajectory.time_parameterization``) at DEBUG level.
"""
from __future__ import annotations

import logging

import numpy as np

VISCOUS_PASSES = 2       # the viscous bound's tangent point: one pass without it, one with
REPEATED = 1e-6          # rad (m): a waypoint this close to the previous one repeats it
COLLINEAR = 1e-9         # rad (m): a waypoint this close to its neighbours' chord is on it
CORNER = 0.1             # rad: a sharper turn between consecutive chords is a corner (rest)
MIN_INTERVALS = 10       # solver grid intervals on the shortest run

LOG = logging.getLogger(__name__)


class _ToDebug(logging.Handler):
    """Passes toppra's records on to this module's logger at DEBUG level."""

    def emit(self, record):
        LOG.debug("toppra: %s", record.getMessage())


def _toppra():
    import toppra
    log = logging.getLogger("toppra")
    if not any(isinstance(h, _ToDebug) for h in log.handlers):
        for h in list(log.handlers):          # setup_logging's console handler, if any
            if not isinstance(h, logging.NullHandler):
                log.removeHandler(h)
        log.addHandler(_ToDebug())
        log.propagate = False
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
    lo, hi = robot.lower, robot.upper
    bad = (path < lo - 1e-9) | (path > hi + 1e-9)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise ValueError(f"path waypoint {k}: joint {robot.joint_names[j]!r} at {path[k, j]:.6g} "
                         f"is outside its range [{lo[j]:.6g}, {hi[j]:.6g}]")
    return path


def split_path(path):
    """The runs of ``path`` (N, n) between corners (module docstring, 1-3): a list of
    arrays of the indices of each run's vertices in ``path``, consecutive runs sharing their
    corner; one run of one index when the path never moves."""
    keep = [0]
    for k in range(1, len(path)):            # 1. repeated waypoints dropped
        if np.linalg.norm(path[k] - path[keep[-1]]) > REPEATED:
            keep.append(k)
    if len(keep) > 1:
        keep[-1] = len(path) - 1             # the path ends where it is told to
    vertex = keep[:1]
    for k, nxt in zip(keep[1:-1], keep[2:]):  # 2. waypoints on the chord of their neighbours
        if _off_segment(path[k], path[vertex[-1]], path[nxt]) > COLLINEAR:
            vertex.append(k)
    vertex = np.array(vertex + keep[-1:] if len(keep) > 1 else vertex)
    if len(vertex) < 3:
        return [vertex]
    d = np.diff(path[vertex], axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    turn = np.arccos(np.clip(np.sum(d[:-1] * d[1:], axis=1), -1.0, 1.0))
    cut = np.concatenate([[0], 1 + np.flatnonzero(turn > CORNER), [len(vertex) - 1]])
    return [vertex[a:b + 1] for a, b in zip(cut[:-1], cut[1:])]


def _off_segment(p, a, b):
    """Distance of the point p from the segment [a, b]."""
    ab = b - a
    h = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0) if np.any(ab) else 0.0
    return float(np.linalg.norm(p - a - h * ab))


def run_geometry(ta, points):
    """(toppra path of s, s at each vertex) of one run (module docstring, 4): s is the
    chord length from the first vertex (rad, or m), so |q'| is about 1 on a run of any
    length and the solver's sd and sdd are the speed and acceleration along it."""
    ss = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return ta.SplineInterpolator(ss, points), ss      # two points: the straight line


def run_grid(ss, intervals):
    """The solver's grid on a run: ``intervals`` uniform intervals, plus the vertices ``ss``
    (a uniform point within a quarter interval of one moved onto it)."""
    u = np.linspace(0.0, ss[-1], intervals + 1)
    near = np.min(np.abs(u[:, None] - ss[None, :]), axis=1) < 0.25 * ss[-1] / intervals
    return np.union1d(u[~near], ss)


def _limits(value, default, name, names, zero):
    n = len(names)
    v = np.array(default if value is None else value, dtype=float).reshape(-1)
    v = np.broadcast_to(v, (n,)) if v.size == 1 else v
    if v.shape != (n,) or np.any(np.isnan(v)) or np.any(v < 0 if zero else v <= 0):
        raise ValueError(f"{name} must be one {'non-negative' if zero else 'positive'} number "
                         f"or one per joint {names} (inf: none"
                         f"{'; 0: the joint holds still' if zero else ''})")
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
          grid=200, dissipation=True):
    """(t, q, qd, qdd, limits) at the grid points of the time-optimal timing of ``path``,
    run by run from rest to rest (module docstring); one point at t = 0 when the path never
    moves. ValueError when no timing is feasible, naming the joint and the waypoints."""
    ta = _toppra()
    path = check_path(robot, path)
    names = robot.joint_names
    vmax = _limits(velocity_limit, robot.velocity_limit, "velocity_limit", names, True)
    amax = _limits(acceleration_limit, np.inf, "acceleration_limit", names, True)
    emax = _limits(effort_limit, robot.effort_limit, "effort_limit", names, False)
    grid = int(grid)
    if grid < 2:
        raise ValueError(f"grid = {grid}; give at least 2 intervals (a few hundred is typical)")
    d = robot.dissipation
    on = dissipation and d.enabled
    dry = d.coulomb + d.stribeck if on else None
    viscous = d.viscous if on and np.any(d.viscous > 0) else None
    _check_still(robot, path, (("velocity limit", vmax), ("acceleration limit", amax)))
    # a zero limit binds only a joint that holds still: none
    vmax, amax = (np.where(x == 0, np.inf, x) for x in (vmax, amax))
    limits = (vmax, amax, emax, on)
    runs = split_path(path)
    if len(runs[0]) == 1:                   # the path never moves: one point at rest
        q = path[runs[0]]
        _static_check(robot, path, q, np.zeros_like(q), dry, emax)
        return np.zeros(1), q, np.zeros_like(q), np.zeros_like(q), limits
    kinematic = []                          # the same for every run
    if np.any(np.isfinite(vmax)):
        kinematic.append(ta.constraint.JointVelocityConstraint(np.column_stack([-vmax, vmax])))
    if np.any(np.isfinite(amax)):
        c = ta.constraint.JointAccelerationConstraint(np.column_stack([-amax, amax]))
        c.discretization_type = ta.constraint.DiscretizationType.Interpolation
        kinematic.append(c)
    length = [np.sum(np.linalg.norm(np.diff(path[idx], axis=0), axis=1)) for idx in runs]
    parts = [_solve_run(ta, robot, path, idx, max(MIN_INTERVALS, round(grid * L / sum(length))),
                        kinematic, emax, dry, viscous) for idx, L in zip(runs, length)]
    return _join(parts) + (limits,)


def _solve_run(ta, robot, path, idx, intervals, constraints, emax, dry, viscous):
    """(t, q, qd, qdd) at the grid points of one run's time-optimal timing, rest to rest,
    under the kinematic ``constraints`` and the effort limits ``emax``."""
    spline, ss = run_geometry(ta, path[idx])
    s = run_grid(ss, intervals)
    _static_check(robot, path, spline.eval(s), spline.evald(s), dry, emax)
    x0 = None
    for _ in range(VISCOUS_PASSES if viscous is not None else 1):
        effort = [_Effort(robot, emax, dry, viscous, x0)] if np.any(np.isfinite(emax)) else []
        inst = ta.algorithm.TOPPRA(constraints + effort, spline, gridpoints=s)
        sdd, sd, _ = inst.compute_parameterization(0.0, 0.0)[:3]
        if sd is None:
            raise ValueError(f"no timing of the path between waypoints {idx[0]} and {idx[-1]} "
                             "is within the limits, though gravity and friction alone are "
                             "within the effort limits all along it (TOPP-RA found it not "
                             "controllable from rest to rest); give a finer grid")
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
    return t, q, qd, qdd


def _join(parts):
    """(t, q, qd, qdd) of runs timed one after the other: each corner once, at rest, its
    acceleration the mean of its two sides (as at a switching point)."""
    t, q, qd, qdd = ([x] for x in parts[0])
    for tr, qr, qdr, qddr in parts[1:]:
        qdd[-1][-1] = 0.5 * (qdd[-1][-1] + qddr[0])
        t.append(t[-1][-1] + tr[1:])
        q.append(qr[1:]), qd.append(qdr[1:]), qdd.append(qddr[1:])
    return tuple(np.concatenate(x) for x in (t, q, qd, qdd))


def _check_still(robot, path, zero_limits):
    """A joint under a zero velocity or acceleration limit must hold still: else a
    ValueError naming it and the first two waypoints between which it moves."""
    moves = np.abs(np.diff(path, axis=0)) > REPEATED
    for name, limit in zero_limits:
        bad = moves & (limit == 0)
        if np.any(bad):
            k, j = np.argwhere(bad)[0]
            raise ValueError(f"infeasible path: the {name} of joint {robot.joint_names[j]!r} is "
                             f"0 but the path moves it between waypoints {k} and {k + 1}; "
                             "raise the limit or keep the joint still")


def _static_check(robot, path, q, q1, dry, emax):
    """Gravity (with the payload) and dry friction alone must be within the effort limits
    at every grid point of a run (q, q' there): else a ValueError naming the joint and the
    waypoint of ``path`` nearest to the first point where they are not."""
    c = robot.gravity_torques(q) + (0.0 if dry is None else dry * np.sign(q1))
    over = np.abs(c) > emax
    if np.any(over):
        k, j = np.argwhere(over)[0]
        gap = np.linalg.norm(path - q[k], axis=1)
        w = int(np.argmin(gap))
        at = f"{'at' if gap[w] <= REPEATED else 'near'} waypoint {w}"
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
