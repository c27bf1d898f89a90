"""Bilateral constrained forward dynamics: the accelerations a and the contact forces f that
keep every contact's acceleration zero (Gauss's principle: a is the one closest to the
unconstrained a0 in the metric M among those the contacts allow; Udwadia & Kalaba 1992).

The KKT system [M, -J^T; J, 0] [a; f] = [tau - b; -J-dot v] is solved through its Schur
complement, the Delassus matrix G = J M^-1 J^T (Featherstone 2008, Sec. 8.5), with M^-1
applied by M's Cholesky factor M = C C^T (LAPACK's, dense: in NumPy it is far faster on
these sizes than the tree's sparse L^T D L of ``mass_matrix_factor``, whose loops run in
Python; docs/contacts.md has the figures). G f = r is solved by proximal iterations
(Carpentier et al. 2021, 'Proximal and sparse resolution of constrained dynamic equations',
RSS):
f_k+1 = (G + mu 1)^-1 (r + mu f_k), from f_0 = 0, which converge to the minimum-norm forces
where G is singular (a redundant set: four feet in frame contact, two hands on one bar) and
whose fixed point is the exact solution. ``mu`` is relative to G's largest diagonal entry.
A set whose rows no motion satisfies (more constraints than the robot can meet, at a
velocity that breaks them) does not converge and is refused with the reason.

Baumgarte's stabilization (Featherstone 2008, Sec. 8.3), for a caller that integrates:
J a + J-dot v = -kd J v - kp e, e the position error of each anchored contact.
"""
from __future__ import annotations

import numpy as np

from .contact import check_contacts
from .jacobians import contact_rows
from .states import positive, rows


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
    rounding of r over mu at each step, so their steps never vanish)."""
    m = len(r)
    f = np.zeros(m)
    if m == 0:
        return f, True, 0.0
    mu_abs = mu * max(float(np.max(np.diag(G))), np.finfo(float).tiny)
    C = np.linalg.cholesky(G + mu_abs * np.eye(m))           # positive definite: mu > 0
    scale = max(1.0, float(np.max(np.abs(r))))
    residual = float(np.max(np.abs(r)))
    for _ in range(max_iterations):
        f_next = np.linalg.solve(C.T, np.linalg.solve(C, r + mu_abs * f))
        step = float(np.max(np.abs(f_next - f)))
        f = f_next
        previous, residual = residual, float(np.max(np.abs(G @ f - r)))
        if (step <= tolerance * max(1.0, float(np.max(np.abs(f))))
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
    C = np.linalg.cholesky(robot.mass_matrix(q))               # M = C C^T
    rows_ = contact_rows(robot, q, v, contacts)
    a0 = np.linalg.solve(C.T, np.linalg.solve(C, tau - robot.bias_torques(q, v)))   # M a0 = tau - b
    Y = np.linalg.solve(C, rows_.J.T)                          # C^-1 J^T
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
    a = a0 + np.linalg.solve(C.T, Y @ f)
    return a, forces_table(contacts, f)


def constrained_forward_dynamics(robot, q, v, tau, contacts, baumgarte=None, mu=1e-6,
                                 tolerance=1e-12, max_iterations=100):
    """(a, f): accelerations (nv,) and contact forces (k, 3) or (k, 6) (world axes, exerted
    by the environment or by ``other_link`` on the robot) with M a + b = tau + J^T f and every
    contact's acceleration zero (or Baumgarte's, ``baumgarte=(kp, kd)``). ``tau`` as
    ``forward_dynamics`` takes it; a batch (N, .) gives (N, nv) and (N, k, .)."""
    contacts = check_contacts(robot, contacts)
    mu, tolerance, max_iterations, kp, kd = settings(mu, tolerance, max_iterations, baumgarte)
    nv, n = robot.nv, robot.dof
    taus = (nv, n) if robot.is_floating else (nv,)
    single, N, (Q, V, T) = rows((("q", q, (robot.nq,)), ("v", v, (nv,)), ("tau", tau, taus)))
    if T.shape[1] != nv:                                       # joint torques, the base free
        T = np.concatenate([np.zeros((N, nv - T.shape[1])), T], axis=1)
    A, F = [], []
    for i in range(N):
        a, f = _one(robot, Q[i], V[i], T[i], contacts, mu, tolerance, max_iterations, kp, kd)
        A.append(a)
        F.append(f)
    return (A[0], F[0]) if single else (np.array(A), np.array(F))
