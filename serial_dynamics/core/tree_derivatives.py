"""Derivatives of inverse and forward dynamics of a kinematic tree (fixed base), compiled:
``derivatives.py``'s forward-mode differentiation of Newton-Euler on the parent array
lambda(i), with its steps (``tangent_through``, ``seeds``, ``_body_tangent``, ``own_turn``,
``tip_tangents``).

What changes from the chain: a change of q_j or qd_j moves only j's descendants, and a
descendant k starts from its parent's motion, so the motion tangents are kept per body
(TM[k], the directions of k's ancestors and k's own: the rest are zero and never
touched); the joint-wrench tangents are summed per body (TF[k]) as the wrenches are,
body k's own tangent first, then each child's carried in (the directions of the child's
subtree and ancestors: its subtree is read as the index range up to its last descendant,
which may take in other bodies' zero columns); joint j's own turn adds to direction q_j in
its parent. The tip wrench is carried along the tip's path only (``P[i, TIPPATH]``), as in
``tree.tree_rnea_core``, so its tangents run along that path (TE, as the chain's T rows
9-14). Forward dynamics: qdd by ``tree.tree_fd_core`` (its sparse factor L^T D L of M),
then d tau at (q, qd, qdd), then -M^-1 d tau/d (q, qd) and M^-1 by solves with the
factor, every right-hand side at once (``cholesky.ltdl_solve_matrix``; each column's
operations those of a solve of its own).
"""
from numba import njit, types

from . import flags as F
from .cholesky import ltdl_solve_matrix
from .data import new_chol, new_kin, scratch, stack_empty
from .derivatives import (HAVE_TRANSFORMS, _bad_shapes, _body_tangent, _inertia_times, _torques,
                          tangent_through, tip_tangents)
from .joint import joint_rate, joint_transforms, own_turn, rate_terms, seeds
from .layout import H, IO, KIND, MASS, PARENT, TIPPATH
from .rnea import base_state, body_wrench, into_body, joint_rates, tip_load
from .signatures import D1, D2, D3, In1, Out2, Pm, Vec, f8, i8, internal
from .spatial import force_to_parent, rotate_t, rotation, to_parent
from .status import BAD_LENGTH, status
from .tree import tree_fd_core


def tree_derivatives_core(P, sc, R, p, f, mo, TM, TE, TF, last, q, qd, qdd, w, flags, dq, dqd):
    """d tau/d q into ``dq``, d tau/d qd into ``dqd`` (n, n) of a fixed-base tree, flags as
    ``tree_rnea_core``'s (and HAVE_TRANSFORMS: R, p already hold q's). Scratch: sc, R, p, f
    (Data Kin), mo (n, 9) each body's omega, alpha, acc, TM (n, 15, 2n), TF (n, 6, 2n),
    TE (15, 2n), last (n,). Returns 0.0 or NaN."""
    n = dq.shape[0]
    use_w = (flags & F.WRENCH) != 0
    # R, p (and the check of q) may come from the caller (tree_fd_derivatives_core)
    chk = joint_transforms(P, sc, R, p, q, n) if (flags & HAVE_TRANSFORMS) == 0 else 0.0
    base, (ex, ey, ez, mx, my, mz), chk = base_state(P, w, flags, n, chk)
    for i in range(n):
        last[i] = i
    for i in range(n - 1, -1, -1):       # each body's last descendant (index)
        l = int(P[i, PARENT])
        if l >= 0 and last[i] > last[l]:
            last[l] = last[i]
    for d in range(2 * n):
        for r in range(15):
            TE[r, d] = 0.0
    for k in range(n):
        dqk, ddqk, c = joint_rates(qd, qdd, k, flags)
        chk += c
        l = int(P[k, PARENT])
        px, py, pz = p[k, 0], p[k, 1], p[k, 2]
        kind = P[k, KIND]
        r = rotation(R, k)
        wx, wy, wz, ax, ay, az, lx, ly, lz = base if l < 0 else (
            mo[l, 0], mo[l, 1], mo[l, 2], mo[l, 3], mo[l, 4], mo[l, 5], mo[l, 6], mo[l, 7], mo[l, 8])
        w0x, w0y, w0z = wx, wy, wz                        # the parent's omega
        wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(r, px, py, pz, wx, wy, wz, ax, ay, az, lx, ly, lz)
        wpx, wpy, apx, apy, lpx, lpy = wx, wy, ax, ay, lx, ly
        on_path = use_w and P[k, TIPPATH] != 0.0
        if on_path:
            ex, ey, ez = rotate_t(r, ex, ey, ez)
            mx, my, mz = rotate_t(r, mx, my, mz)
        wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(P[k, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz,
                                                        dqk, ddqk)
        mo[k, 0], mo[k, 1], mo[k, 2], mo[k, 3], mo[k, 4] = wx, wy, wz, ax, ay
        mo[k, 5], mo[k, 6], mo[k, 7], mo[k, 8] = az, lx, ly, lz
        m = P[k, MASS]
        hx, hy, hz = P[k, H], P[k, H + 1], P[k, H + 2]
        I6 = (P[k, IO], P[k, IO + 1], P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5])
        Lx, Ly, Lz = _inertia_times(I6, wx, wy, wz)
        body = (m, hx, hy, hz, I6, wx, wy, wz, Lx, Ly, Lz, wx * hx + wy * hy + wz * hz)
        f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5] = body_wrench(
            P, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
        # the parent's live tangents (its ancestors' directions) through body k
        ca, cl = rate_terms(kind, dqk)
        wp = w0x * px + w0y * py + w0z * pz
        j = l
        while j >= 0:
            for d in range(2 * j, 2 * j + 2):
                (TM[k, 0, d], TM[k, 1, d], TM[k, 2, d], TM[k, 3, d], TM[k, 4, d], TM[k, 5, d],
                 TM[k, 6, d], TM[k, 7, d], TM[k, 8, d]) = tangent_through(
                    r, px, py, pz, w0x, w0y, w0z, wp, ca, cl, TM[l, 0, d], TM[l, 1, d],
                    TM[l, 2, d], TM[l, 3, d], TM[l, 4, d], TM[l, 5, d], TM[l, 6, d],
                    TM[l, 7, d], TM[l, 8, d])
            j = int(P[j, PARENT])
        seeds(TM[k], k, kind, dqk, wz, wpx, wpy, apx, apy, lpx, lpy, ex, ey, mx, my)
        if on_path:                      # the tip wrench's tangents along its path
            j = l
            while j >= 0:
                for d in range(2 * j, 2 * j + 2):
                    TE[9, d], TE[10, d], TE[11, d] = rotate_t(r, TE[9, d], TE[10, d], TE[11, d])
                    TE[12, d], TE[13, d], TE[14, d] = rotate_t(r, TE[12, d], TE[13, d], TE[14, d])
                j = int(P[j, PARENT])
            for s in range(9, 15):
                TE[s, 2 * k] = TM[k, s, 2 * k]
        # body k's wrench tangent starts its joint-wrench tangent: zero off its live columns
        for d in range(2 * n):
            for s in range(6):
                TF[k, s, d] = 0.0
        j = k
        while j >= 0:
            for d in range(2 * j, 2 * j + 2):
                (TF[k, 0, d], TF[k, 1, d], TF[k, 2, d], TF[k, 3, d], TF[k, 4, d],
                 TF[k, 5, d]) = _body_tangent(body, TM[k, 0, d], TM[k, 1, d], TM[k, 2, d],
                                              TM[k, 3, d], TM[k, 4, d], TM[k, 5, d],
                                              TM[k, 6, d], TM[k, 7, d], TM[k, 8, d])
            j = int(P[j, PARENT])
    if use_w:                            # the tip load -w on the last body
        k = n - 1
        f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5] = tip_load(
            P, n, f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5], ex, ey, ez, mx, my, mz)
        tip_tangents(P, TE, TF[k])
    # inward: tau_i = S_i^T f_i; f_lambda(i) += Xup_i^T f_i, and the same for the tangents
    # (the subtree's and the ancestors' directions), plus joint i's own turn on q_i
    for i in range(n - 1, -1, -1):
        _torques(P, TF[i], i, dq, dqd)
        l = int(P[i, PARENT])
        if l < 0:
            continue
        r = rotation(R, i)
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        nx, ny, nz, fx, fy, fz = f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5]
        sx, sy, sz, gx, gy, gz = own_turn(P[i, KIND], r, px, py, pz, nx, ny, nz, fx, fy)
        for d in range(2 * i, 2 * int(last[i]) + 2):
            carry_tangent(TF, i, l, d, r, px, py, pz)
        j = l
        while j >= 0:
            for d in range(2 * j, 2 * j + 2):
                carry_tangent(TF, i, l, d, r, px, py, pz)
            j = int(P[j, PARENT])
        a = 2 * i
        TF[l, 0, a], TF[l, 1, a], TF[l, 2, a] = TF[l, 0, a] + sx, TF[l, 1, a] + sy, TF[l, 2, a] + sz
        TF[l, 3, a], TF[l, 4, a], TF[l, 5, a] = TF[l, 3, a] + gx, TF[l, 4, a] + gy, TF[l, 5, a] + gz
        nx, ny, nz, fx, fy, fz = to_parent(R, p, i, nx, ny, nz, fx, fy, fz)
        f[l, 0], f[l, 1], f[l, 2] = f[l, 0] + nx, f[l, 1] + ny, f[l, 2] + nz
        f[l, 3], f[l, 4], f[l, 5] = f[l, 3] + fx, f[l, 4] + fy, f[l, 5] + fz
    return chk


@njit(cache=True, inline="always")
def carry_tangent(TF, i, l, d, r, px, py, pz):
    """Direction d of body i's joint-wrench tangent carried into its parent l's: += Xup_i^T."""
    ux, uy, uz, cx, cy, cz = force_to_parent(r, px, py, pz, TF[i, 0, d], TF[i, 1, d], TF[i, 2, d],
                                             TF[i, 3, d], TF[i, 4, d], TF[i, 5, d])
    TF[l, 0, d], TF[l, 1, d], TF[l, 2, d] = TF[l, 0, d] + ux, TF[l, 1, d] + uy, TF[l, 2, d] + uz
    TF[l, 3, d], TF[l, 4, d], TF[l, 5, d] = TF[l, 3, d] + cx, TF[l, 4, d] + cy, TF[l, 5, d] + cz


tree_derivatives_core = internal(
    f8(Pm, D2, D3, D2, D2, D2, D3, D2, D3, D1, In1, In1, In1, In1, i8, Out2, Out2),
    calls=())(tree_derivatives_core)


def tree_fd_derivatives_core(P, sc, R, p, f, mo, IC, M, x, TM, TE, TF, last, X, q, qd, tau, w,
                             flags, dq, dqd, Minv):
    """d qdd/d q, d qdd/d qd, d qdd/d tau = -M^-1 d tau/d q, -M^-1 d tau/d qd, M^-1 at
    qdd = FD(q, qd, tau) of a tree (flags WRENCH, BASE; qd always read): qdd by
    ``tree_fd_core`` (which leaves the factor L^T D L in M), d tau at (q, qd, qdd), then
    the 3n right-hand sides [d tau/d q, d tau/d qd, 1] (X, (n, 3n)) solved at once
    (``ltdl_solve_minus``; x (n,): qdd); M^-1 mirrored from its upper triangle. Returns 0.0
    or NaN."""
    n = x.shape[0]
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD
    qdd = Minv[0]                        # scratch until M^-1 is written
    chk = tree_fd_core(P, sc, R, p, f, mo, IC, M, q, qd, tau, w, flags, qdd)
    for i in range(n):
        x[i] = qdd[i]
    chk += tree_derivatives_core(P, sc, R, p, f, mo, TM, TE, TF, last, q, qd, x, w,
                                 flags | F.QDD | HAVE_TRANSFORMS, X[:, :n], X[:, n:2 * n])
    ltdl_solve_minus(P, M, X, dq, dqd, Minv)
    return chk


@njit(cache=True, inline="always")
def ltdl_solve_minus(P, M, X, dq, dqd, Minv):
    """``derivatives.solve_minus`` with the sparse factor L^T D L of a tree in M: X =
    [d tau/d q, d tau/d qd, 1] (n, 3n) solved at once (``ltdl_solve_matrix``) into
    -M^-1 d tau/d q, -M^-1 d tau/d qd and M^-1 (mirrored from its upper triangle)."""
    n = M.shape[0]
    for i in range(n):
        for c in range(n):
            X[i, 2 * n + c] = 1.0 if i == c else 0.0
    ltdl_solve_matrix(P, M, X)
    for i in range(n):
        for c in range(n):
            dq[i, c] = -X[i, c]
            dqd[i, c] = -X[i, n + c]
            Minv[i, c] = X[i, 2 * n + c] if c >= i else X[c, 2 * n + i]


tree_fd_derivatives_core = internal(
    f8(Pm, D2, D3, D2, D2, D2, D2, D2, D1, D3, D2, D3, D1, D2, In1, In1, In1, In1, i8, Out2, Out2,
       Out2), calls=("tree_fd_core", "tree_derivatives_core", "ltdl_solve_matrix"))(
    tree_fd_derivatives_core)


# ------------------------------------------------------------------ entry points
@njit(cache=True, inline="always")
def _scratch(n):
    return (stack_empty((n, 9)), scratch((n, 15, 2 * n), 30 * n * n),
            stack_empty((15, 2 * n)), scratch((n, 6, 2 * n), 12 * n * n), stack_empty((n,)))


def tree_rnea_derivatives(P, q, qd, qdd, w, flags, out):
    """``derivatives.rnea_derivatives`` of a fixed-base tree: out (2, n, n)."""
    if out.shape[0] != 2:
        return BAD_LENGTH
    dq, dqd = out[0], out[1]
    if _bad_shapes(P, q, qd, qdd, w, flags, dq, dqd):
        return BAD_LENGTH
    n = dq.shape[0]
    d = new_kin(n)
    mo, TM, TE, TF, last = _scratch(n)
    return status(tree_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, TM, TE, TF, last, q, qd, qdd,
                                        w, (flags & (F.WRENCH | F.BASE)) | F.QD | F.QDD, dq, dqd))


def tree_fd_derivatives(P, q, qd, tau, w, flags, out):
    """``derivatives.fd_derivatives`` of a fixed-base tree: out (3, n, n)."""
    if out.shape[0] != 3:
        return BAD_LENGTH
    dq, dqd, Minv = out[0], out[1], out[2]
    if _bad_shapes(P, q, qd, tau, w, flags, dq, dqd):
        return BAD_LENGTH
    n = dq.shape[0]
    d, c, x = new_kin(n), new_chol(n), stack_empty((n,))
    mo, TM, TE, TF, last = _scratch(n)
    IC, X = stack_empty((n, 10)), scratch((n, 3 * n), 3 * n * n)
    return status(tree_fd_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, IC, c.M, x, TM, TE, TF,
                                           last, X, q, qd, tau, w, flags, dq, dqd, Minv))


_CALLS = ("tree_derivatives_core", "tree_fd_derivatives_core")
SINGLE_STATE = ("tree_rnea_derivatives", "tree_fd_derivatives")
Mat3 = types.Array(f8, 3, "C")
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "tree_rnea_derivatives": (tree_rnea_derivatives, i8(Pm, Vec, Vec, Vec, Vec, i8, Mat3), False,
                              _CALLS[:1]),
    "tree_fd_derivatives": (tree_fd_derivatives, i8(Pm, Vec, Vec, Vec, Vec, i8, Mat3), False,
                            _CALLS[1:]),
}
