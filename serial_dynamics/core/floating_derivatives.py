"""Derivatives of inverse and forward dynamics on a free-floating base, compiled: the
fixed-base derivatives (``derivatives.py``, ``tree_derivatives.py``) on the instantaneous
chain or tree (``floating.py``), then the base's own columns, in one call.

In the base frame only gravity sees the base's pose: tau(q, v, a) is the instantaneous
tree's tau at its joint accelerations a + p(v) (p: the virtual joints' velocity products,
``floating._products``), its base accelerating at -g_b, g_b = R^T g. Turning the base,
R -> R Exp(dtheta), turns g_b by g_b x dtheta; moving it changes nothing. So, with the
tree's derivatives d tau_t/d q, d tau_t/d qd (their base columns not used):

    d tau/d q = [0 | -M[:, :3] [g_b]x | d tau_t/d q_joints]
    d tau/d v = d tau_t/d qd + M dp/dv
    d a/d q   = -M^-1 [0 | 0 | d tau_t/d q_joints] + [0 | E_3 [g_b]x | 0]   (M^-1 M E_3 = E_3)
    d a/d v   = -M^-1 d tau_t/d qd - dp/dv,        d a/d tau = M^-1

(the q direction is the tangent of q, Pinocchio's q (+) dq: the base's [dp; dtheta] in the
base frame, then the joints). Forward dynamics first solves for a by the Cholesky route
(chains) or the sparse factor (trees), whose factor the solves then reuse; M itself is not
needed there. A batch runs blocks of states in SIMD lanes (a chain's in
``derivatives_lanes.py``, a tree's in ``tree_derivatives_lanes.py``): the same bits.

A tip wrench w given in the world (flag WRENCH) reaches the tree as w_b = R^T w, which the
turn also turns, by w_b x dtheta: d tau/d dtheta_c gains tau's wrench part at [f_b x e_c;
m_b x e_c], -J^T of it, one Newton-Euler pass at rest each (``_chain_wrench_turns``,
``tree_wrench_turns``; in the forward case added before the solves).

Entry points: as ``floating.py``'s (q (n+7), v, a (n+6), ``gw``: the tip wrench, read with
flag WRENCH, and gravity; tau (n+6) or joint torques (n)); ``out`` (2, n+6, n+6) =
(d tau/d q, d tau/d v) or (3, n+6, n+6) = (d a/d q, d a/d v, M^-1); batches (N, n+6, n+6)
arrays. The trees' are ``floating_tree_*`` (``dispatch.TreeTable``).
"""
from numba import njit

from . import flags as F
from .crba import floating_crba_core
from .data import new_chol, new_kin, scratch, stack_empty
from .derivatives import derivatives_core, solve_minus
from .floating import GW, fd_inputs, rnea_inputs
from .forward import floating_cholesky_core
from .layout import W_ACC, W_ALL
from .rnea import floating_rnea_core
from .signatures import Pm, Vec, i8, row, rows_fit
from .status import BAD_LENGTH, NOT_FINITE, OK, status
from .tree import tree_crba_core, tree_fd_core, tree_rnea_core
from .tree_derivatives import Mat3, ltdl_solve_minus, tree_derivatives_core
from .tree_derivatives import _scratch as tree_scratch

ID_FLAGS = F.QD | F.QDD | F.BASE       # the tree's derivatives: gravity as the base's acceleration


@njit(cache=True, inline="always")
def base_columns(v, w, M, dq, dv):
    """The instantaneous tree's d tau/d q, d tau/d qd (dq, dv) into the floating base's,
    in place (module docstring): the base's q columns [0 | g_b x M[i, :3]], and + M dp/dv."""
    gx, gy, gz = -w[W_ACC], -w[W_ACC + 1], -w[W_ACC + 2]            # g_b = R^T g
    vx, vy, vz, wx, wy, wz = v[0], v[1], v[2], v[3], v[4], v[5]
    for i in range(dq.shape[0]):
        m0, m1, m2, m3, m4, m5 = M[i, 0], M[i, 1], M[i, 2], M[i, 3], M[i, 4], M[i, 5]
        dq[i, 0] = dq[i, 1] = dq[i, 2] = 0.0                         # d tau/d dp = 0
        dq[i, 3] = gy * m2 - gz * m1                                 # -M[i, :3] [g_b]x
        dq[i, 4] = gz * m0 - gx * m2
        dq[i, 5] = gx * m1 - gy * m0
        dv[i, 0] += m1 * wz - m2 * wy                                # + (M dp/dv)[i]
        dv[i, 1] += m2 * wx - m0 * wz
        dv[i, 2] += m0 * wy - m1 * wx
        dv[i, 3] += m2 * vy - m1 * vz + m4 * wz - m5 * wy
        dv[i, 4] += m0 * vz - m2 * vx - m3 * wz - m5 * wx
        dv[i, 5] += m1 * vx - m0 * vy - m3 * wy + m4 * wx


@njit(cache=True, inline="always")
def base_columns_fd(v, w, dq, dv):
    """After the solves: d a/d q's base columns + [0 | E_3 [g_b]x] and d a/d v - dp/dv."""
    gx, gy, gz = -w[W_ACC], -w[W_ACC + 1], -w[W_ACC + 2]
    vx, vy, vz, wx, wy, wz = v[0], v[1], v[2], v[3], v[4], v[5]
    dq[0, 4] -= gz                                                   # [g_b]x
    dq[0, 5] += gy
    dq[1, 3] += gz
    dq[1, 5] -= gx
    dq[2, 3] -= gy
    dq[2, 4] += gx
    dv[0, 1] += wz                                                   # - dp/dv
    dv[0, 2] -= wy
    dv[0, 4] -= vz
    dv[0, 5] += vy
    dv[1, 0] -= wz
    dv[1, 2] += wx
    dv[1, 3] += vz
    dv[1, 5] -= vx
    dv[2, 0] += wy
    dv[2, 1] -= wx
    dv[2, 3] -= vy
    dv[2, 4] += vx
    dv[3, 4] += wz
    dv[3, 5] += wy
    dv[4, 3] -= wz
    dv[4, 5] -= wx
    dv[5, 3] += wy
    dv[5, 4] += wx


@njit(cache=True, inline="always")
def _cross_axis(x, y, z, c):
    """(x, y, z) x e_c."""
    if c == 0:
        return 0.0, z, -y
    if c == 1:
        return -z, 0.0, x
    return y, -x, 0.0


@njit(cache=True, inline="always")
def turned_wrench(w, c, y):
    """y (W_ALL) = [f_b x e_c; m_b x e_c], the change of the tip wrench w_b = w[:6] as the
    base turns about its axis c (module docstring); the rest zero."""
    for i in range(W_ALL):
        y[i] = 0.0
    y[0], y[1], y[2] = _cross_axis(w[0], w[1], w[2], c)
    y[3], y[4], y[5] = _cross_axis(w[3], w[4], w[5], c)


@njit(cache=True, inline="always")
def _chain_wrench_turns(P, d, qv, w, y, col, dq):
    """dq[:, 3 + c] += tau's wrench part at ``turned_wrench`` c (the tip wrench turned with
    the base), c = 0, 1, 2: Newton-Euler at rest on the instantaneous chain (col: scratch)."""
    for c in range(3):
        turned_wrench(w, c, y)
        floating_rnea_core(P, d.sc, d.R, d.p, d.f, qv, qv, qv, y, F.WRENCH, col)
        for i in range(col.shape[0]):
            dq[i, 3 + c] += col[i]


@njit(cache=True, inline="always")
def tree_wrench_turns(P, d, mo, qv, w, y, col, dq):
    """``_chain_wrench_turns`` on the instantaneous tree."""
    for c in range(3):
        turned_wrench(w, c, y)
        tree_rnea_core(P, d.sc, d.R, d.p, d.f, mo, qv, qv, qv, y, F.WRENCH, col)
        for i in range(col.shape[0]):
            dq[i, 3 + c] += col[i]


@njit(cache=True, inline="always")
def _clear_base(X):
    """The tree's base q columns are not used: zeros, before the solves."""
    for i in range(X.shape[0]):
        for c in range(6):
            X[i, c] = 0.0


# ------------------------------------------------------------------ one state, a chain
@njit(cache=True, inline="always")
def _chain_id(P, d, qv, w, qddv, M, T, Tf, dB, y, col, q, v, a, gw, flags, dq, dv):
    wf = flags & F.WRENCH
    chk = rnea_inputs(q, v, a, gw, F.QD | F.QDD | wf, qv, w, qddv)  # qdd_t = a + p(v)
    chk += derivatives_core(P, d.sc, d.R, d.p, d.f, T, Tf, dB, qv, v, qddv, w, ID_FLAGS | wf,
                            dq, dv)
    floating_crba_core(P, d.R, d.p, M)
    base_columns(v, w, M, dq, dv)
    if wf != 0:
        _chain_wrench_turns(P, d, qv, w, y, col, dq)
    return chk


@njit(cache=True, inline="always")
def _chain_fd(P, d, c, qv, w, tv, qddv, T, Tf, dB, X, y, q, v, tau, gw, flags, dq, dv, Minv):
    wf = flags & F.WRENCH
    chk = fd_inputs(q, tau, gw, wf, qv, w, tv)
    chk += floating_cholesky_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, qv, v, tv, w, tv,
                                  F.QD | F.BASE | wf, qddv)          # qdd_t; c.M <- L
    n = qddv.shape[0]
    chk += derivatives_core(P, d.sc, d.R, d.p, d.f, T, Tf, dB, qv, v, qddv, w, ID_FLAGS | wf,
                            X[:, :n], X[:, n:2 * n])
    _clear_base(X)
    if wf != 0:                          # before the solves (qddv: scratch now)
        _chain_wrench_turns(P, d, qv, w, y, qddv, X[:, :n])
    solve_minus(c.M, X, dq, dv, Minv)
    base_columns_fd(v, w, dq, dv)
    return chk


@njit(cache=True, inline="always")
def _chain_id_scratch(nv):
    return (new_kin(nv), stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,)),
            scratch((nv, nv), nv * nv), stack_empty((15, 2 * nv)), stack_empty((6, 2 * nv)),
            scratch((nv, 6, 2 * nv), 12 * nv * nv), stack_empty((W_ALL,)), stack_empty((nv,)))


@njit(cache=True, inline="always")
def _chain_fd_scratch(nv):
    return (new_kin(nv), new_chol(nv), stack_empty((nv,)), stack_empty((W_ALL,)),
            stack_empty((nv,)), stack_empty((nv,)), stack_empty((15, 2 * nv)),
            stack_empty((6, 2 * nv)), scratch((nv, 6, 2 * nv), 12 * nv * nv),
            scratch((nv, 3 * nv), 3 * nv * nv), stack_empty((W_ALL,)))


# ------------------------------------------------------------------ one state, a tree
@njit(cache=True, inline="always")
def _tree_id(P, d, mo, TM, TE, TF, last, qv, w, qddv, IC, M, y, col, q, v, a, gw, flags, dq, dv):
    wf = flags & F.WRENCH
    chk = rnea_inputs(q, v, a, gw, F.QD | F.QDD | wf, qv, w, qddv)
    chk += tree_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, TM, TE, TF, last, qv, v, qddv, w,
                                 ID_FLAGS | wf, dq, dv)
    tree_crba_core(P, d.R, d.p, IC, M)
    base_columns(v, w, M, dq, dv)
    if wf != 0:
        tree_wrench_turns(P, d, mo, qv, w, y, col, dq)
    return chk


@njit(cache=True, inline="always")
def _tree_fd(P, d, c, mo, TM, TE, TF, last, qv, w, tv, qddv, IC, X, y, q, v, tau, gw, flags,
             dq, dv, Minv):
    wf = flags & F.WRENCH
    chk = fd_inputs(q, tau, gw, wf, qv, w, tv)
    chk += tree_fd_core(P, d.sc, d.R, d.p, d.f, mo, IC, c.M, qv, v, tv, w, F.QD | F.BASE | wf,
                        qddv)                                        # qdd_t; c.M <- L^T D L
    n = qddv.shape[0]
    chk += tree_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, TM, TE, TF, last, qv, v, qddv, w,
                                 ID_FLAGS | wf, X[:, :n], X[:, n:2 * n])
    _clear_base(X)
    if wf != 0:                          # before the solves (qddv: scratch now)
        tree_wrench_turns(P, d, mo, qv, w, y, qddv, X[:, :n])
    ltdl_solve_minus(P, c.M, X, dq, dv, Minv)
    base_columns_fd(v, w, dq, dv)
    return chk


# ------------------------------------------------------------------ a batch's blocks
@njit(cache=True, inline="always")
def id_rows(q, v, a, gw, wf, k0, nl, Qt, Vt, At, Wt):
    """States k0 .. k0 + nl - 1 as rows 0 .. nl - 1 of a block of the instantaneous chain's
    or tree's inputs: q, qd = v, qdd = a + p(v), w (``floating.rnea_inputs``; flag WRENCH in
    ``wf``). Returns NOT_FINITE if one of them has a NaN/Inf, else OK."""
    bad = OK
    for b in range(nl):
        k = k0 + b
        if rnea_inputs(row(q, k), row(v, k), row(a, k), row(gw, k), F.QD | F.QDD | wf,
                       Qt[b], Wt[b], At[b]) != 0.0:
            bad = NOT_FINITE
        for i in range(Vt.shape[1]):
            Vt[b, i] = row(v, k)[i]
    return bad


@njit(cache=True, inline="always")
def fd_rows(q, v, tau, gw, wf, k0, nl, Qt, Vt, Tt, Wt):
    """``id_rows`` for forward dynamics: q, qd = v, the generalized forces, w
    (``floating.fd_inputs``)."""
    bad = OK
    for b in range(nl):
        k = k0 + b
        if fd_inputs(row(q, k), row(tau, k), row(gw, k), wf, Qt[b], Wt[b], Tt[b]) != 0.0:
            bad = NOT_FINITE
        for i in range(Vt.shape[1]):
            Vt[b, i] = row(v, k)[i]
    return bad


# ------------------------------------------------------------------ entry points
@njit(cache=True, inline="always")
def _bad_single(P, q, v, x, gw, out, k):
    nv = P.shape[0] - 1
    return (q.shape[0] != nv + 1 or v.shape[0] != nv or gw.shape[0] != GW or out.shape[0] != k
            or out.shape[1] != nv or out.shape[2] != nv
            or not (x.shape[0] == nv or (k == 3 and x.shape[0] == nv - 6)))


@njit(cache=True, inline="always")
def _bad_batch(P, q, v, x, gw, dq, fd):
    nv, N = P.shape[0] - 1, dq.shape[0]
    return not (rows_fit(N, nv + 1, (q,)) and rows_fit(N, nv, (v,)) and rows_fit(N, GW, (gw,))
                and (rows_fit(N, nv, (x,)) or (fd and rows_fit(N, nv - 6, (x,)))))


def floating_rnea_derivatives(P, q, v, a, gw, flags, out):
    """d tau/d q, d tau/d v of one floating state into out[0], out[1] (flag WRENCH: the tip
    wrench gw[:6], world). Returns OK, NOT_FINITE or BAD_LENGTH."""
    if _bad_single(P, q, v, a, gw, out, 2):
        return BAD_LENGTH
    d, qv, w, qddv, M, T, Tf, dB, y, col = _chain_id_scratch(P.shape[0] - 1)
    return status(_chain_id(P, d, qv, w, qddv, M, T, Tf, dB, y, col, q, v, a, gw, flags,
                            out[0], out[1]))


def floating_fd_derivatives(P, q, v, tau, gw, flags, out):
    """d a/d q, d a/d v, M^-1 of one floating state into out[0], out[1], out[2]."""
    if _bad_single(P, q, v, tau, gw, out, 3):
        return BAD_LENGTH
    d, c, qv, w, tv, qddv, T, Tf, dB, X, y = _chain_fd_scratch(P.shape[0] - 1)
    return status(_chain_fd(P, d, c, qv, w, tv, qddv, T, Tf, dB, X, y, q, v, tau, gw, flags,
                            out[0], out[1], out[2]))


@njit(cache=True, inline="always")
def chain_id_loop(P, q, v, a, gw, flags, dq, dv):
    """``floating_rnea_derivatives`` of N states one after the other (the batch of a chain
    too long for lanes: ``derivatives_lanes.floating_rnea_derivatives_batch``)."""
    d, qv, w, qddv, M, T, Tf, dB, y, col = _chain_id_scratch(P.shape[0] - 1)
    bad = OK
    for k in range(dq.shape[0]):
        if _chain_id(P, d, qv, w, qddv, M, T, Tf, dB, y, col, row(q, k), row(v, k), row(a, k),
                     row(gw, k), flags, dq[k], dv[k]) != 0.0:
            bad = NOT_FINITE
    return bad


@njit(cache=True, inline="always")
def chain_fd_loop(P, q, v, tau, gw, flags, dq, dv, Minv):
    """``floating_fd_derivatives`` of N states one after the other."""
    d, c, qv, w, tv, qddv, T, Tf, dB, X, y = _chain_fd_scratch(P.shape[0] - 1)
    bad = OK
    for k in range(dq.shape[0]):
        if _chain_fd(P, d, c, qv, w, tv, qddv, T, Tf, dB, X, y, row(q, k), row(v, k),
                     row(tau, k), row(gw, k), flags, dq[k], dv[k], Minv[k]) != 0.0:
            bad = NOT_FINITE
    return bad


@njit(cache=True, inline="always")
def _tree_id_scratch(nv):
    mo, TM, TE, TF, last = tree_scratch(nv)
    return (new_kin(nv), mo, TM, TE, TF, last, stack_empty((nv,)), stack_empty((W_ALL,)),
            stack_empty((nv,)), stack_empty((nv, 10)), scratch((nv, nv), nv * nv),
            stack_empty((W_ALL,)), stack_empty((nv,)))


@njit(cache=True, inline="always")
def _tree_fd_scratch(nv):
    mo, TM, TE, TF, last = tree_scratch(nv)
    return (new_kin(nv), new_chol(nv), mo, TM, TE, TF, last, stack_empty((nv,)),
            stack_empty((W_ALL,)), stack_empty((nv,)), stack_empty((nv,)),
            stack_empty((nv, 10)), scratch((nv, 3 * nv), 3 * nv * nv), stack_empty((W_ALL,)))


def floating_tree_rnea_derivatives(P, q, v, a, gw, flags, out):
    """``floating_rnea_derivatives`` on a floating base's instantaneous tree."""
    if _bad_single(P, q, v, a, gw, out, 2):
        return BAD_LENGTH
    d, mo, TM, TE, TF, last, qv, w, qddv, IC, M, y, col = _tree_id_scratch(P.shape[0] - 1)
    return status(_tree_id(P, d, mo, TM, TE, TF, last, qv, w, qddv, IC, M, y, col, q, v, a, gw,
                           flags, out[0], out[1]))


def floating_tree_fd_derivatives(P, q, v, tau, gw, flags, out):
    """``floating_fd_derivatives`` on a floating base's instantaneous tree."""
    if _bad_single(P, q, v, tau, gw, out, 3):
        return BAD_LENGTH
    d, c, mo, TM, TE, TF, last, qv, w, tv, qddv, IC, X, y = _tree_fd_scratch(P.shape[0] - 1)
    return status(_tree_fd(P, d, c, mo, TM, TE, TF, last, qv, w, tv, qddv, IC, X, y, q, v, tau,
                           gw, flags, out[0], out[1], out[2]))


@njit(cache=True, inline="always")
def tree_id_loop(P, q, v, a, gw, flags, dq, dv):
    """``floating_tree_rnea_derivatives`` of N states one after the other (the batch of a
    tree too big for lanes: ``tree_derivatives_lanes``)."""
    d, mo, TM, TE, TF, last, qv, w, qddv, IC, M, y, col = _tree_id_scratch(P.shape[0] - 1)
    bad = OK
    for k in range(dq.shape[0]):
        if _tree_id(P, d, mo, TM, TE, TF, last, qv, w, qddv, IC, M, y, col, row(q, k),
                    row(v, k), row(a, k), row(gw, k), flags, dq[k], dv[k]) != 0.0:
            bad = NOT_FINITE
    return bad


@njit(cache=True, inline="always")
def tree_fd_loop(P, q, v, tau, gw, flags, dq, dv, Minv):
    """``floating_tree_fd_derivatives`` of N states one after the other."""
    d, c, mo, TM, TE, TF, last, qv, w, tv, qddv, IC, X, y = _tree_fd_scratch(P.shape[0] - 1)
    bad = OK
    for k in range(dq.shape[0]):
        if _tree_fd(P, d, c, mo, TM, TE, TF, last, qv, w, tv, qddv, IC, X, y, row(q, k),
                    row(v, k), row(tau, k), row(gw, k), flags, dq[k], dv[k],
                    Minv[k]) != 0.0:
            bad = NOT_FINITE
    return bad


_ID = i8(Pm, Vec, Vec, Vec, Vec, i8, Mat3)
_CHAIN_ID = ("derivatives_core", "floating_crba_core", "floating_rnea_core")
_CHAIN_FD = ("floating_cholesky_core", "derivatives_core", "cholesky_solve_matrix",
             "floating_rnea_core")
_TREE_ID = ("tree_derivatives_core", "tree_crba_core", "tree_rnea_core")
_TREE_FD = ("tree_fd_core", "tree_derivatives_core", "ltdl_solve_matrix", "tree_rnea_core")
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "floating_rnea_derivatives": (floating_rnea_derivatives, _ID, False, _CHAIN_ID),
    "floating_fd_derivatives": (floating_fd_derivatives, _ID, False, _CHAIN_FD),
    "floating_tree_rnea_derivatives": (floating_tree_rnea_derivatives, _ID, False, _TREE_ID),
    "floating_tree_fd_derivatives": (floating_tree_fd_derivatives, _ID, False, _TREE_FD),
}
SINGLE_STATE = ("floating_rnea_derivatives", "floating_fd_derivatives",
                "floating_tree_rnea_derivatives", "floating_tree_fd_derivatives")
