"""Analytical derivatives of inverse dynamics, by forward-mode differentiation of the
3-vector Newton-Euler recursion (``rnea.py``), and of forward dynamics from them.

Inverse dynamics tau(q, qd, qdd) = M qdd + b - J^T w is ``rnea._rnea``: an outward recursion
for the angular velocity omega, angular acceleration alpha and classical acceleration acc
of each body origin, the body wrench (fB; nB), and an inward recursion for the joint wrench
(f; n), tau_i = S_i^T (n_i; f_i). Each recursion is differentiated along one direction at a
time (a tangent, written d.): a change of q_j or qd_j touches nothing inboard of body j, so
its tangents start at body j (the seeds below), travel outward through the bodies below it
(j+1 .. n-1 in a chain; on a tree j's descendants, each from its parent) with the
linearized outward equations, and inward through every body with the linearized inward
equations, where joint j's own transform also turns the wrench it carries. One
direction costs O(n); all 2n directions O(n^2), like Carpentier & Mansard, "Analytical
derivatives of rigid body dynamics algorithms" (RSS 2018), which obtain them in spatial
algebra. Every equation is the derivative of the ``rnea.py`` line it names.

The seeds at body j (e_z its axis, omega', alpha' the parent's rates in frame j before
joint j adds its own; revolute R_j = Xtree_R Rz(q_j), so d R_j / d q_j = R_j [e_z]x;
prismatic p_j = Xtree_p + q_j R_j e_z):

    d/dq_j,  revolute:  d omega = omega_j x e_z,  d alpha = alpha' x e_z + qd_j (omega' x e_z) x e_z,
                        d acc = acc_j x e_z,      d e = e_j x e_z (the tip wrench in frame j)
    d/dq_j,  prismatic: d acc = alpha' x e_z + omega' x (omega' x e_z)
    d/dqd_j, revolute:  d omega = e_z,  d alpha = omega' x e_z
    d/dqd_j, prismatic: d acc = 2 omega' x e_z

and inward, into joint j's parent body, the turn of joint j itself (d/dq_j only):
    revolute:  d f += R_j (e_z x f_j),  d n += R_j (e_z x n_j) + p_j x R_j (e_z x f_j)
    prismatic: d n += R_j (e_z x f_j)           (d p_j = R_j e_z: (R_j e_z) x (R_j f_j))

The armature term I_a qdd depends on neither q nor qd; a base motion enters through the
starting values of the recursion, which depend on neither. Forward dynamics qdd(q, qd, tau)
solves tau = ID(q, qd, qdd), so (implicit function theorem) d qdd/d q = -M^-1 d tau/d q,
d qdd/d qd = -M^-1 d tau/d qd at qdd = FD(q, qd, tau), and d qdd/d tau = M^-1.
"""
import numpy as np

from ._batch import as_batch, mtv, mv, unbatch
from .crba import mass_matrix
from .joint import joint_rate, own_turn, project, rate_tangent, seed_q, seed_qd
from .forward import forward_dynamics
from .kinematics import joint_transforms
from .rnea import _wrench_batch, body_wrench, into_body

E_Z = np.array([0.0, 0.0, 1.0])


def inverse_dynamics_derivatives(model, q, qd, qdd, wrench=None, base_motion=None):
    """(d tau/d q, d tau/d qd), each (n, n) or (N, n, n): [.., i, j] = d tau_i / d x_j."""
    single, (q, qd, qdd) = as_batch(model, ("q", q), ("qd", qd), ("qdd", qdd))
    w = _wrench_batch(wrench, q.shape[0])
    dq, dqd = _derivatives(model, q, qd, qdd, w, base_motion)
    return unbatch(single, dq), unbatch(single, dqd)


def forward_dynamics_derivatives(model, q, qd, tau, wrench=None, base_motion=None):
    """(d qdd/d q, d qdd/d qd, d qdd/d tau) = (-M^-1 d tau/d q, -M^-1 d tau/d qd, M^-1)."""
    single, (q, qd, tau) = as_batch(model, ("q", q), ("qd", qd), ("tau", tau))
    qdd = forward_dynamics(model, q, qd, tau, wrench, "cholesky", base_motion=base_motion)
    dq, dqd = _derivatives(model, q, qd, qdd, _wrench_batch(wrench, q.shape[0]), base_motion)
    Minv = np.linalg.inv(mass_matrix(model, q))
    Minv = 0.5 * (Minv + np.swapaxes(Minv, -1, -2))
    return (unbatch(single, -Minv @ dq), unbatch(single, -Minv @ dqd), unbatch(single, Minv))


def _forward(model, q, qd, qdd, w, base):
    """The Newton-Euler recursion of ``rnea._rnea``, keeping what the tangents need:
    per body (N, n, 3) omega', alpha' (the parent's, in frame i), omega, alpha, acc, the tip
    wrench e = (f, m) in frame i, and the joint wrench (f; n) of the inward pass."""
    N, n = q.shape
    R, p = joint_transforms(model, q)
    g = model.gravity
    omega = np.zeros((N, 3))
    alpha = np.zeros((N, 3))
    acc = np.broadcast_to(-g, (N, 3))
    if base is not None:
        omega = np.broadcast_to(base.angular_velocity, (N, 3))
        alpha = np.broadcast_to(base.angular_acceleration, (N, 3))
        acc = np.broadcast_to(base.linear_acceleration - g, (N, 3))
    s = {k: np.zeros((N, n, 3)) for k in ("omp", "alp", "omega", "alpha", "acc", "ef", "em",
                                          "f", "n")}
    start = (omega, alpha, acc, np.zeros((N, 3)) if w is None else w[:, :3],
             np.zeros((N, 3)) if w is None else w[:, 3:])   # the tip wrench, carried outward
    fB, nB = np.empty((N, n, 3)), np.empty((N, n, 3))
    for i in range(n):                                           # rnea.py: outward
        l = model.parent[i]
        omega, alpha, acc, ef, em = start if l < 0 else (
            s["omega"][:, l], s["alpha"][:, l], s["acc"][:, l], s["ef"][:, l], s["em"][:, l])
        omega, alpha, acc = into_body(R, p, i, omega, alpha, acc)
        ef, em = mtv(R[:, i], ef), mtv(R[:, i], em)
        s["omp"][:, i], s["alp"][:, i] = omega, alpha
        omega, alpha, acc = joint_rate(model.kind[i], omega, alpha, acc, qd[:, i], qdd[:, i])
        s["omega"][:, i], s["alpha"][:, i], s["acc"][:, i] = omega, alpha, acc
        s["ef"][:, i], s["em"][:, i] = ef, em
        fB[:, i], nB[:, i] = body_wrench(model, i, omega, alpha, acc)
    if w is not None:                                            # rnea.py: the tip load -w
        f = -s["ef"][:, n - 1]
        fB[:, n - 1] += f
        nB[:, n - 1] += -s["em"][:, n - 1] + np.cross(model.Xtip_p, f)
    for i in range(n - 1, -1, -1):                               # rnea.py: inward
        f, nm = fB[:, i], nB[:, i]                               # with the children's, below
        s["f"][:, i], s["n"][:, i] = f, nm
        l = model.parent[i]
        if l >= 0:
            f = mv(R[:, i], f)
            fB[:, l] += f
            nB[:, l] += mv(R[:, i], nm) + np.cross(p[:, i], f)
    return R, p, s


def _body_wrench_tangent(model, i, omega, dw, da, dl):
    """The tangent of ``rnea.body_wrench`` at omega along (d omega, d alpha, d acc):
    d f = m d acc + d alpha x h + dw x (w x h) + w x (dw x h),
    d n = I_O d alpha + dw x I_O w + w x I_O dw + h x d acc."""
    m, h, I_O = model.mass[i], model.h[i], model.I_O[i]
    df = m * dl + np.cross(da, h) + np.cross(dw, np.cross(omega, h)) + np.cross(omega, np.cross(dw, h))
    dn = (da @ I_O.T + np.cross(dw, omega @ I_O.T) + np.cross(omega, dw @ I_O.T)
          + np.cross(h, dl))
    return df, dn


def _derivatives(model, q, qd, qdd, w, base):
    N, n = q.shape
    R, p, s = _forward(model, q, qd, qdd, w, base)
    dq, dqd = np.empty((N, n, n)), np.empty((N, n, n))
    for j in range(n):
        kind, omp = model.kind[j], s["omp"][:, j]
        # d/dq_j and d/dqd_j: the seeds of the module docstring
        seed = seed_q(kind, s["omega"][:, j], s["alp"][:, j], omp, s["acc"][:, j], s["ef"][:, j],
                      s["em"][:, j], qd[:, j])
        dq[:, :, j] = _sweep(model, R, p, s, qd, j, seed, True, w is not None)
        dqd[:, :, j] = _sweep(model, R, p, s, qd, j, seed_qd(kind, omp), False, False)
    return dq, dqd


def _sweep(model, R, p, s, qd, j, seed, turn, wrench):
    """d tau (N, n) along one direction seeded at body j: outward through the bodies below
    joint j (j and its descendants; the others do not move), inward through every body;
    ``turn``: joint j's own transform turns (d/dq_j)."""
    N, n = R.shape[0], R.shape[1]
    moved = np.zeros(n, dtype=bool)
    t = np.zeros((5, N, n, 3))                           # d omega, d alpha, d acc, d e (f, m)
    dfB, dnB = np.zeros((N, n, 3)), np.zeros((N, n, 3))
    for i in range(j, n):
        l = model.parent[i]
        if i == j:
            dw, da, dl, def_, dem = seed
        elif l >= 0 and moved[l]:   # rnea.py outward, linearized: acc + alpha x p + w x (w x p)
            dw, da, dl, def_, dem = t[:, :, l]
            w0 = s["omega"][:, l]
            dl = dl + np.cross(da, p[:, i]) + np.cross(dw, np.cross(w0, p[:, i])) \
                + np.cross(w0, np.cross(dw, p[:, i]))
            dl, dw, da = mtv(R[:, i], dl), mtv(R[:, i], dw), mtv(R[:, i], da)
            def_, dem = mtv(R[:, i], def_), mtv(R[:, i], dem)
            da, dl = rate_tangent(model.kind[i], da, dl, dw, qd[:, i])   # + d omega' x qd S
        else:
            continue
        moved[i] = True
        t[:, :, i] = dw, da, dl, def_, dem
        dfB[:, i], dnB[:, i] = _body_wrench_tangent(model, i, s["omega"][:, i], dw, da, dl)
    if wrench and moved[n - 1]:                           # the tip load -e, turned
        df = -t[3, :, n - 1]
        dfB[:, n - 1] += df
        dnB[:, n - 1] += -t[4, :, n - 1] + np.cross(model.Xtip_p, df)
    dtau = np.empty((N, n))
    for i in range(n - 1, -1, -1):                        # rnea.py inward, linearized
        df, dn = dfB[:, i], dnB[:, i]                     # with the children's, below
        dtau[:, i] = project(model.kind[i], dn, df)
        l = model.parent[i]
        if l < 0:
            continue
        df = mv(R[:, i], df)
        dn = mv(R[:, i], dn) + np.cross(p[:, i], df)
        if turn and i == j:                               # joint j's own turn (docstring)
            df, dn = own_turn(model.kind[j], R[:, j], p[:, j], s["f"][:, j], s["n"][:, j], df, dn)
        dfB[:, l] += df
        dnB[:, l] += dn
    return dtau
