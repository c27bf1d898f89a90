"""Contact forces inside Coulomb's friction cones: the minimum-norm forces f that exert a
given wrench on a floating base, B f = h (B = J_base^T), with every contact with the
environment's force in its cone |f_t| <= mu f_n about the surface normal n. A second-order
cone program, solved by Clarabel (Goulart & Chen 2024, 'Clarabel: an interior-point solver
for conic programs with quadratic objectives'), on the exact cones (no linearized pyramid).
A frame contact's cone bounds its force; its moment is free (no sole polygon). Loop closures
(``other_link``) have no cone. Where no such forces exist, ``ValueError`` names the contacts
that would slip (their force on the cone's edge) or lift off (no normal force) in the
forces that come closest."""
from __future__ import annotations

import numpy as np


def normals(normal, contacts):
    """One unit surface normal per contact, (k, 3), from (3,) or (k, 3) (world axes)."""
    n = np.asarray(normal, dtype=float) if not isinstance(normal, str) else np.zeros(0)
    if n.shape not in ((3,), (len(contacts), 3)) or not np.all(np.isfinite(n)):
        raise ValueError(f"normal must be a direction (3,) or one per contact ({len(contacts)}, "
                         f"3), world axes; got {normal!r}")
    n = np.broadcast_to(n, (len(contacts), 3))
    length = np.linalg.norm(n, axis=1)
    if np.any(length == 0):
        raise ValueError("normal has a zero vector; give the surface's outward normal")
    return n / length[:, None]


def _cone_rows(n, mu):
    """(3, 3) K with K f = (mu n.f, t1.f, t2.f): f is in the cone iff that is in SOC(3)."""
    e = np.eye(3)[np.argmin(np.abs(n))]             # the axis furthest from n
    t1 = np.cross(n, e)
    t1 /= np.linalg.norm(t1)
    return np.vstack([mu * n, t1, np.cross(n, t1)])


def _socp(P, q, B, h, cones_at, K):
    """min 1/2 x^T P x + q^T x, B x = h (B may have no rows), K_i x_i in SOC(3) (Clarabel:
    A x + s = b, s in the cones). Returns (status, x)."""
    import clarabel
    from scipy import sparse

    m = P.shape[0]
    rows, cones = [], []
    if B.shape[0]:
        rows.append(B)
        cones.append(clarabel.ZeroConeT(B.shape[0]))
    for j, Kj in zip(cones_at, K):
        block = np.zeros((3, m))
        block[:, j:j + 3] = -Kj                      # s = K f_j in the cone, b = 0
        rows.append(block)
        cones.append(clarabel.SecondOrderConeT(3))
    A = sparse.csc_matrix(np.vstack(rows))
    b = np.concatenate([h if B.shape[0] else np.zeros(0), np.zeros(3 * len(K))])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_feas = settings.tol_gap_abs = settings.tol_gap_rel = 1e-12
    solution = clarabel.DefaultSolver(sparse.triu(sparse.csc_matrix(P)).tocsc(), q, A, b,
                                      cones, settings).solve()
    return solution.status, np.array(solution.x)


def friction_forces(B, h, contacts, mu, normal, tolerance):
    """f (m,) with B f = h and each environment contact's force in its cone (module
    docstring); ``contacts`` give the layout of f (3 or 6 rows each)."""
    import clarabel

    n = normals(normal, contacts)
    starts = np.cumsum([0] + [c.size for c in contacts])
    env = [k for k, c in enumerate(contacts) if c.other_link is None]
    K = [_cone_rows(n[k], mu) for k in env]
    at = [starts[k] for k in env]
    m = B.shape[1]
    status, f = _socp(np.eye(m), np.zeros(m), B, h, at, K)
    if status in (clarabel.SolverStatus.Solved, clarabel.SolverStatus.AlmostSolved):
        f = f + np.linalg.lstsq(B, h - B @ f, rcond=None)[0]    # B f = h to rounding
        return f
    # the forces closest to h inside the cones: min |B f - h|^2 (+ a touch of |f|^2)
    eps = 1e-9 * max(1.0, float(np.max(np.abs(B))) ** 2)
    _, f = _socp(B.T @ B + eps * np.eye(m), -B.T @ h, np.zeros((0, m)), h, at, K)
    size = max(1.0, float(np.max(np.abs(h))))        # the forces' scale: the wrench asked
    slip, lift = [], []
    for k, j in zip(env, at):
        fn, ft = n[k] @ f[j:j + 3], np.linalg.norm(f[j:j + 3] - (n[k] @ f[j:j + 3]) * n[k])
        if fn <= 1e-6 * size:
            lift.append(str(contacts[k]))
        elif ft >= mu * fn * (1 - 1e-6):
            slip.append(str(contacts[k]))
    left = (np.round(B @ f - h, 6) + 0.0).tolist()
    raise ValueError(
        f"no contact forces inside the friction cones (friction {mu}) realise these "
        f"accelerations: the closest leave a base wrench of {left} (N, N m; base frame) "
        f"unbalanced. Would slip (force on the cone's edge): {slip or 'none'}; would lift "
        f"off, the robot tipping over the others (no normal force): {lift or 'none'}")
