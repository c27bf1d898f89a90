"""Bilateral constrained forward dynamics: the accelerations a and the contact forces f that
keep every contact's acceleration zero (Gauss's principle: a is the one closest to the
unconstrained a0 in the metric M among those the contacts allow; Udwadia & Kalaba 1992).

The KKT system [M, -J^T; J, 0] [a; f] = [tau - b; -J-dot v] is solved through its Schur
complement, the Delassus matrix G = J M^-1 J^T (Featherstone 2008, Sec. 8.5), with M^-1
applied by M's Cholesky factor M = C C^T, inverted (``dense.py``: LAPACK's, dense; in NumPy
it is far faster on these sizes than the tree's sparse L^T D L of ``mass_matrix_factor``,
whose loops run in Python; docs/contacts.md has the figures). G f = r is solved by proximal
iterations (Carpentier et al. 2021, 'Proximal and sparse resolution of constrained dynamic
equations', RSS): f_k+1 = (G + mu 1)^-1 (r + mu f_k), from f_0 = 0, which converge to the
minimum-norm forces where G is singular (a redundant set: four feet in frame contact, two
hands on one bar) and whose fixed point is the exact solution, taken directly where G is far
from singular (``DIRECT``). ``mu`` is relative to G's largest diagonal entry.
A set whose rows no motion satisfies (more constraints than the robot can meet, at a
velocity that breaks them) does not converge and is refused with the reason.

Baumgarte's stabilization (Featherstone 2008, Sec. 8.3), for a caller that integrates:
J a + J-dot v = -kd J v - kp e, e the position error of each anchored contact.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

from . import compiled
from .dense import firm_factor, inverse_factor
from .jacobians import contact_rows
from .states import positive, rows


DIRECT = 1e-6   # a Delassus pivot^2 above this share of its largest diagonal: solved directly


def settings(mu, tolerance, max_iterations, baumgarte):
    """The solver's settings checked: (mu, tolerance, max_iterations, kp, kd)."""
    mu, tolerance = positive("mu", mu), positive("tolerance", tolerance)
    if not isinstance(max_iterations, (int, np.integer)) or max_iterations < 1:
        raise ValueError(f"max_iterations must be an integer >= 1; got {max_iterations!r}")
    kp = kd = 0.0
    if baumgarte is not None:
        if np.shape(baumgarte) != (2,):
            raise ValueError(f"baumgarte must be (kp, kd): the position (1/s^2) and velocity "
                             f"(1/s) gains, e.g. (100.0, 20.0); got {baumgarte!r}")
        kp = positive("baumgarte's kp", baumgarte[0], allow_zero=True)
        kd = positive("baumgarte's kd", baumgarte[1], allow_zero=True)
    return mu, tolerance, int(max_iterations), kp, kd


def proximal_solve(G, r, mu, tolerance, max_iterations):
    """(f, converged, residual): f_k+1 = (G + mu 1)^-1 (r + mu f_k) (max norms below) until
    a step |f_k+1 - f_k| is within tolerance times max(1, |f|) (Pinocchio's relative
    accuracy), or the residual |G f - r| is within tolerance times max(1, |r|) and no longer
    halves (its rounding floor: a redundant set's forces drift along G's null space by the
    rounding of r over mu at each step, so their steps never vanish). (G + mu 1) is factored
    once by LAPACK's Cholesky (dpotrf) and each iterate is two triangular solves (dpotrs).
    Where G is far from singular (its pivots, ``DIRECT``) the fixed point G^-1 r is taken
    directly when its residual meets the tolerance: the same answer, without iterating."""
    m = len(r)
    f = np.zeros(m)
    if m == 0:
        return f, True, 0.0
    scale = max(1.0, float(np.abs(r).max()))
    g_max = max(float(G.diagonal().max()), np.finfo(float).tiny)
    # G well away from singular (every pivot of its Cholesky factor above DIRECT of its
    # largest diagonal entry): the iterations' fixed point G^-1 r directly, kept where its
    # residual meets the tolerance (a redundant set has a vanishing pivot and iterates)
    L = firm_factor(G, DIRECT)
    if L is not None:
        f = dpotrs(L, r, lower=1)[0]
        residual = float(np.abs(G @ f - r).max())
        if residual <= tolerance * scale:
            return f, True, residual
        f = np.zeros(m)
    mu_abs = mu * g_max
    C, info = dpotrf(G + mu_abs * np.eye(m), lower=1)       # positive definite: mu > 0
    if info != 0:
        raise ValueError(f"the Delassus matrix plus mu is not positive definite (LAPACK "
                         f"dpotrf info {info}): a NaN in the contact rows?")
    residual = float(np.abs(r).max())
    for _ in range(max_iterations):
        f_next = dpotrs(C, r + mu_abs * f, lower=1)[0]
        step = float(np.abs(f_next - f).max())
        f = f_next
        previous, residual = residual, float(np.abs(G @ f - r).max())
        if (step <= tolerance * max(1.0, float(np.abs(f).max()))
                or tolerance * scale >= residual > 0.5 * previous):
            return f, True, residual
    return f, False, residual


def forces_table(contacts, f):
    """The stacked forces as (k, 3) (every contact a point) or (k, 6) (a point's moment 0)."""
    width = 6 if any(c.frame for c in contacts) else 3
    out, i = np.zeros((len(contacts), width)), 0
    for k, c in enumerate(contacts):
        out[k, :c.size] = f[i:i + c.size]
        i += c.size
    return out


def _one(robot, q, v, tau, contacts, mu, tolerance, max_iterations, kp, kd):
    Ci = inverse_factor(robot.mass_matrix(q))                   # C^-1, M = C C^T
    rows_ = contact_rows(robot, q, v, contacts, positions=kp != 0.0)
    a0 = Ci.T @ (Ci @ (tau - robot.bias_torques(q, v)))        # M a0 = tau - b
    Y = Ci @ rows_.J.T                                         # C^-1 J^T
    G = Y.T @ Y                                                # Delassus: J M^-1 J^T
    # J a = -J-dot v - kd J v - kp e, with a = a0 + M^-1 J^T f: G f = r
    r = -rows_.drift - kd * rows_.velocity - kp * rows_.error - rows_.J @ a0
    f, converged, residual = proximal_solve(G, r, mu, tolerance, max_iterations)
    if not converged:
        rank = np.linalg.matrix_rank(rows_.J)
        raise ValueError(
            f"the contacts {[str(c) for c in contacts]} ask for accelerations no motion meets: "
            f"{len(r)} constraint rows of rank {rank} on {len(v)} velocities, residual "
            f"{residual:.3g} after {max_iterations} iterations. The set over-constrains the "
            "robot at this velocity: drop contacts or make frame contacts point contacts (if "
            "it is only ill-conditioned, raise max_iterations or lower mu)")
    a = a0 + Ci.T @ (Y @ f)                                    # + M^-1 J^T f
    return a, forces_table(contacts, f)


def constrained_forward_dynamics(robot, q, v, tau, contacts, baumgarte=None, mu=1e-6,
                                 tolerance=1e-12, max_iterations=100):
    """(a, f): accelerations (nv,) and contact forces (k, 3) or (k, 6) (world axes, exerted
    by the environment or by ``other_link`` on the robot) with M a + b = tau + J^T f and every
    contact's acceleration zero (or Baumgarte's, ``baumgarte=(kp, kd)``). ``tau`` as
    ``forward_dynamics`` takes it; a batch (N, .) gives (N, nv) and (N, k, .). One state of
    float64 vectors is one compiled call (``compiled.py``) where the robot has its kernel,
    and a batch runs row by row through it; the rest, and a call the kernel does not answer
    (not converged, a factor that fails), here in NumPy (``_one``: the reference)."""
    contacts, cset = compiled.checked(robot, contacts)
    mu, tolerance, max_iterations, kp, kd, num = _settings(mu, tolerance, max_iterations,
                                                           baumgarte)
    out = compiled.solve(robot, q, v, tau, cset, num, kp)      # one state: one compiled call
    if out is not None:
        return out
    # the rest (other types, batches, no kernel, a status: rows() names a bad state)
    nv = robot.nv
    taus = (nv, robot.dof) if robot.is_floating else (nv,)
    single, N, (Q, V, T) = rows((("q", q, (robot.nq,)), ("v", v, (nv,)), ("tau", tau, taus)))
    if T.shape[1] != nv:
        T = np.concatenate([np.zeros((N, nv - T.shape[1])), T], axis=1)
    A, F = [], []
    for i in range(N):                  # rows of broadcast views, copied for the kernels
        qi, vi, ti = np.array(Q[i]), np.array(V[i]), np.array(T[i])     # (C, writable)
        out = compiled.solve(robot, qi, vi, ti, cset, num, kp)
        a, f = out if out is not None else _one(robot, qi, vi, ti, contacts, mu, tolerance,
                                                max_iterations, kp, kd)
        A.append(a)
        F.append(f)
    return (A[0], F[0]) if single else (np.array(A), np.array(F))


_SETTINGS = {}      # (mu, tolerance, max_iterations, DIRECT) -> _settings' answer


def _settings(mu, tolerance, max_iterations, baumgarte):
    """``settings`` and the kernel's numbers (``compiled.numbers``); those of two floats and
    an int without Baumgarte's terms (the usual call) remembered (up to 64)."""
    key = ((mu, tolerance, max_iterations, DIRECT) if baumgarte is None and type(mu) is float
           and type(tolerance) is float and type(max_iterations) is int else None)
    known = _SETTINGS.get(key)
    if known is None:
        s = settings(mu, tolerance, max_iterations, baumgarte)
        known = (*s, compiled.numbers(*s, DIRECT))
        if key is not None and len(_SETTINGS) < 64:
            _SETTINGS[key] = known
    return known

