"""Mimic joints, compiled: the reduced system of the independent coordinates in one call.

A joint that mimics another moves as q_i = m q_leader + o, so every joint's state is
x_all = G x (+ o for q), G constant (n, k), and by virtual work (Featherstone 2008,
Sec. 3.2; robot/mimic.py holds the maths and the general path):

    tau = G^T tau_all(q_all, qd_all, qdd_all)    M = G^T M_all G    (G^T M_all G) qdd = tau - G^T b_all

The entry points run the whole-model kernels (a chain's or a tree's, on a fixed base or a
floating one's instantaneous chain or tree, as ``P[n, TREE]`` and ``P[n, ROOT]`` say)
between a gather (G x + o) and a sum (G^T y), with the maps in one array ``Gm`` of
``layout.WIDTH`` columns (``robot/mimic.py``'s ``mimic_layout``), one row per coordinate:

    Gm[j, QSRC], Gm[j, QMUL], Gm[j, QOFF]  q_all[j] = q[QSRC] QMUL + QOFF  (j < nq_all)
    Gm[i, VSRC], Gm[i, VMUL], Gm[i, VOFF]  x_all[i] = x[VSRC] VMUL + VOFF (0.0) for the rates
                                           (i < nv_all)
    Gm[k, IW]                              the whole coordinate of reduced coordinate k
                                           (its independent joint; k < nv)
    Gm[f, FW], Gm[f, FT], Gm[f, FM]        follower f (f < nf, in joint order): its whole
                                           coordinate, its reduced one, its multiplier
    Gm[k, PARENT]                          the reduced coordinate k's parent in the reduced
                                           tree (k < nv), for the sparse factor L^T D L
    Gm[-1, SPARSE]                         1.0 (a tree whose reduced M keeps a tree's zeros):
                                           G^T M G from M's nonzeros (``reduce_mass``) and
                                           factored by L^T D L on those parents; 0.0 (a
                                           chain's bits): ``reduce_matrix``, dense Cholesky
    Gm[-1, NF], Gm[-1, NPAIRS]             nf, the number of followers; np, of pairs
    Gm[nq_all:-1], flat                    (SPARSE) the np pairs (i, j) of whole
                                           coordinates with j = i or an ancestor of i (M's
                                           nonzeros) of which one is a follower, PAIR
                                           numbers each, packed: i, j, m_i m_j, s_i, s_j;
                                           the indices are int64 bit patterns (read
                                           through a view: no conversion a pair)

Batches (``mimic_*_batch``) run each state through the single call's steps. Each gather
and sum also does the operations of robot/mimic.py's general path (a wrench, a base motion,
the other kinds' batches) in the same order (x[src] m + o; G^T y as the independent
coordinates' entries, then each follower's m y in joint order), which calls
``reduce_mass`` and ``reduced_fd`` state by state, so a row is the single call's bits on
every path.
"""
import numpy as np
from numba import njit

from . import flags as F
from .cholesky import cholesky_factor, cholesky_solve_factored, ltdl_factor, ltdl_solve_factored
from .crba import crba_core, floating_crba_core
from .data import new_kin, scratch, stack_empty
from .floating import GW, _chain_inputs, rnea_inputs
from .joint import joint_transforms
from .layout import ROOT, TREE, W_ALL
from .rnea import floating_rnea_core, rnea_core
from .signatures import In2, Mat, Out2, Out3, Pm, Vec, i8, row, rows_fit
from .status import BAD_LENGTH, status
from .tree import tree_crba_core, tree_rnea_core

QSRC, QMUL, QOFF, VSRC, VMUL, VOFF, IW, FW, FT, FM = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
PI, PJ, PM, PSI, PSJ, PAIR = 0, 1, 2, 3, 4, 5
SPARSE, NF, NPAIRS = 0, 1, 2


@njit(cache=True, inline="always")
def _gather(Gm, x, xa, src, mul, off):
    """xa = G x + o by the columns src, mul, off of Gm (q's: QSRC, QMUL, QOFF; the rates':
    VSRC, VMUL, VOFF, whose offsets are 0.0 as the batch path's); returns 0.0, or NaN for
    a NaN/Inf entry."""
    chk = 0.0
    for j in range(xa.shape[0]):
        v = x[int(Gm[j, src])]
        chk += v * 0.0
        xa[j] = v * Gm[j, mul] + Gm[j, off]
    return chk


@njit(cache=True, inline="always")
def reduce_vector(Gm, y, out):
    """out = G^T y: the independent coordinates' entries, then each follower's m y."""
    for k in range(out.shape[0]):
        out[k] = y[int(Gm[k, IW])]
    for f in range(int(Gm[Gm.shape[0] - 1, NF])):
        out[int(Gm[f, FT])] += Gm[f, FM] * y[int(Gm[f, FW])]


@njit(cache=True, inline="always")
def reduce_matrix(Gm, M, A, out):
    """out = G^T M G: A = M G row by row (``reduce_vector``'s sums), then G^T A by rows."""
    nv, k = M.shape[0], out.shape[0]
    for r in range(nv):
        reduce_vector(Gm, M[r], A[r])
    for a in range(k):
        src, dst = A[int(Gm[a, IW])], out[a]
        for c in range(k):
            dst[c] = src[c]
    for f in range(int(Gm[Gm.shape[0] - 1, NF])):
        src, dst, m = A[int(Gm[f, FW])], out[int(Gm[f, FT])], Gm[f, FM]
        for c in range(k):
            dst[c] += m * src[c]


@njit(cache=True, inline="always")
def reduce_mass(Gm, M, A, out):
    """out = G^T M G of a mass matrix. On a tree (SPARSE) from M's nonzeros: the
    independent coordinates' entries M[iw_a, iw_c], then each pair (i, j) with a follower
    (j = i or an ancestor of i) adding m_i m_j M_ij to out[s_i, s_j] and, off the diagonal,
    to out[s_j, s_i] (the same sums: out stays exactly symmetric). On a chain
    ``reduce_matrix`` (A: its scratch)."""
    h = Gm.shape[0] - 1
    if Gm[h, SPARSE] == 0.0:
        reduce_matrix(Gm, M, A, out)
        return
    k = out.shape[0]
    iw = stack_empty((k,)).view(np.int64)
    for a in range(k):
        iw[a] = int(Gm[a, IW])
    for a in range(k):
        row, dst = M[iw[a]], out[a]
        for c in range(k):
            dst[c] = row[iw[c]]
    pairs = Gm.reshape(-1)[pair_rows(Gm) * Gm.shape[1]:]
    index = pairs.view(np.int64)                   # i, j, s_i, s_j: int64 bit patterns
    for p in range(0, PAIR * int(Gm[h, NPAIRS]), PAIR):
        i, j, si, sj = index[p + PI], index[p + PJ], index[p + PSI], index[p + PSJ]
        x = pairs[p + PM] * M[i, j]
        out[si, sj] += x
        if i != j:
            out[sj, si] += x


@njit(cache=True, inline="always")
def pair_rows(Gm):
    """The first row of the packed pairs (nq_all): Gm's rows less the pairs' and the head."""
    cols = Gm.shape[1]
    return Gm.shape[0] - 1 - (PAIR * int(Gm[Gm.shape[0] - 1, NPAIRS]) + cols - 1) // cols


@njit(cache=True, inline="always")
def reduced_solve(Gm, Mr, out):
    """out <- (G^T M G)^-1 out, Mr = G^T M G factored in place: L^T D L on the reduced tree
    (SPARSE), else L L^T."""
    if Gm[Gm.shape[0] - 1, SPARSE] != 0.0:
        ltdl_factor(Gm, Mr)
        ltdl_solve_factored(Gm, Mr, out)
    else:
        cholesky_factor(Mr)
        cholesky_solve_factored(Mr, out)


def reduced_fd(Gm, M, b, tau, out):
    """out = (G^T M G)^-1 (tau - G^T b) for one state's whole-model M and b. Returns 0."""
    k, nv = out.shape[0], M.shape[0]
    A, Mr = scratch((nv, k), nv * k), scratch((k, k), k * k)
    reduce_mass(Gm, M, A, Mr)
    reduce_vector(Gm, b, out)
    for i in range(k):
        out[i] = tau[i] - out[i]
    reduced_solve(Gm, Mr, out)
    return 0


@njit(cache=True, inline="always")
def _lengths(P, Gm, q, k):
    """The whole model's nv and nq, or (-1, -1) if q (reduced) or Gm does not fit P."""
    nv = P.shape[0] - 1
    nb = 1 if P[nv, ROOT] != 0.0 else 0            # a floating base: q has one more
    if pair_rows(Gm) != nv + nb or q.shape[0] != k + nb:
        return -1, -1
    return nv, nv + nb


@njit(cache=True, inline="always")
def _whole_rnea(P, d, mo, qa, va, aa, gw, flags, ta):
    """tau_all of the whole model (fixed, or floating through its instantaneous chain or
    tree, as the kinds' own entry points call the cores); flags QD, QDD."""
    nv = ta.shape[0]
    tree = P[nv, TREE] != 0.0
    if P[nv, ROOT] == 0.0:
        if tree:
            return tree_rnea_core(P, d.sc, d.R, d.p, d.f, mo, qa, va, aa, qa, flags, ta)
        return rnea_core(P, d.sc, d.R, d.p, d.f, qa, va, aa, qa, flags, ta)
    qv, w, qddv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    chk = rnea_inputs(qa, va, aa, gw, flags, qv, w, qddv)
    if tree:
        return chk + tree_rnea_core(P, d.sc, d.R, d.p, d.f, mo, qv, va, qddv, w,
                                    flags | F.BASE | F.QDD, ta)
    return chk + floating_rnea_core(P, d.sc, d.R, d.p, d.f, qv, va, qddv, w,
                                    flags | F.BASE | F.QDD, ta)


@njit(cache=True, inline="always")
def _whole_transforms(P, d, qa, nv):
    """The joint transforms (d.sc, d.R, d.p) of the whole model at q_all (a floating base's
    instantaneous chain or tree at its q)."""
    if P[nv, ROOT] == 0.0:
        return joint_transforms(P, d.sc, d.R, d.p, qa, nv)
    qv, w, gw = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((GW,))
    for i in range(GW):
        gw[i] = 0.0
    return _chain_inputs(qa, gw, 0, qv, w) + joint_transforms(P, d.sc, d.R, d.p, qv, nv)


@njit(cache=True, inline="always")
def _whole_crba(P, d, M):
    """M_all of the whole model from the joint transforms in d."""
    nv = M.shape[0]
    if P[nv, TREE] != 0.0:
        tree_crba_core(P, d.R, d.p, stack_empty((nv, 10)), M)
    elif P[nv, ROOT] != 0.0:
        floating_crba_core(P, d.R, d.p, M)
    else:
        crba_core(P, d.R, d.p, M)


@njit(cache=True, inline="always")
def _whole_tau(P, Gm, d, q, qd, qdd, gw, flags, nq, nv, ta):
    """tau_all at q_all = G q + o, qd_all = G qd, qdd_all = G qdd (flag QDD; else 0) into
    ``ta``; leaves the joint transforms of q_all in d. Returns the inputs' check."""
    qa, va, aa = stack_empty((nq,)), stack_empty((nv,)), stack_empty((nv,))
    chk = _gather(Gm, q, qa, QSRC, QMUL, QOFF) + _gather(Gm, qd, va, VSRC, VMUL, VOFF)
    if (flags & F.QDD) != 0:
        chk += _gather(Gm, qdd, aa, VSRC, VMUL, VOFF)
    else:
        for i in range(nv):
            aa[i] = 0.0
    return chk + _whole_rnea(P, d, stack_empty((nv, 9)), qa, va, aa, gw, flags, ta)


# ------------------------------------------------------------------ one state
@njit(cache=True, inline="always")
def _rnea_state(P, Gm, q, qd, qdd, gw, flags, nq, nv, out):
    """tau = G^T tau_all into ``out``; returns the inputs' check."""
    ta = stack_empty((nv,))
    chk = _whole_tau(P, Gm, new_kin(nv), q, qd, qdd, gw, flags, nq, nv, ta)
    reduce_vector(Gm, ta, out)
    return chk


@njit(cache=True, inline="always")
def _crba_state(P, Gm, q, nq, nv, out):
    """M = G^T M_all G into ``out``."""
    k = out.shape[0]
    qa = stack_empty((nq,))
    chk = _gather(Gm, q, qa, QSRC, QMUL, QOFF)
    d = new_kin(nv)
    M = scratch((nv, nv), nv * nv)
    chk += _whole_transforms(P, d, qa, nv)
    _whole_crba(P, d, M)
    reduce_mass(Gm, M, scratch((nv, k), nv * k), out)
    return chk


@njit(cache=True, inline="always")
def _fd_state(P, Gm, q, qd, tau, gw, nq, nv, out):
    """qdd = (G^T M_all G)^-1 (tau - G^T b_all) into ``out``."""
    k = out.shape[0]
    d, b = new_kin(nv), stack_empty((nv,))
    chk = _whole_tau(P, Gm, d, q, qd, tau, gw, F.QD, nq, nv, b)    # b_all (tau: unread)
    M = scratch((nv, nv), nv * nv)
    _whole_crba(P, d, M)                 # on the joint transforms the Newton-Euler pass left
    for i in range(k):
        chk += tau[i] * 0.0
    reduced_fd_inline(Gm, M, b, tau, out)
    return chk


# ------------------------------------------------------------------ entry points
# q, qd, qdd, tau, out: the reduced system's (nq, nv); gw: a floating base's (core/floating.py:
# gravity in the world), not read on a fixed base.
def mimic_rnea(P, Gm, q, qd, qdd, gw, flags, out):
    """tau = G^T tau_all of one state into ``out``; flags QD, QDD (QD alone: b; qdd unread).
    A floating base's qdd_all without QDD is 0.0 as with it and qdd = 0: the same bits."""
    k = out.shape[0]
    nv, nq = _lengths(P, Gm, q, k)
    if nv < 0 or qd.shape[0] != k or qdd.shape[0] != k or gw.shape[0] != GW:
        return BAD_LENGTH
    return status(_rnea_state(P, Gm, q, qd, qdd, gw, flags, nq, nv, out))


def mimic_crba(P, Gm, q, out):
    """M = G^T M_all G of one configuration into ``out``."""
    k = out.shape[0]
    nv, nq = _lengths(P, Gm, q, k)
    if nv < 0 or out.shape[1] != k:
        return BAD_LENGTH
    return status(_crba_state(P, Gm, q, nq, nv, out))


def mimic_fd(P, Gm, q, qd, tau, gw, flags, out):
    """qdd = (G^T M_all G)^-1 (tau - G^T b_all) of one state into ``out`` (flags: none
    read; the reduced system has one route)."""
    k = out.shape[0]
    nv, nq = _lengths(P, Gm, q, k)
    if nv < 0 or qd.shape[0] != k or tau.shape[0] != k or gw.shape[0] != GW:
        return BAD_LENGTH
    return status(_fd_state(P, Gm, q, qd, tau, gw, nq, nv, out))


# Batches: each state through the single call's steps, compiled as a function of its own
# (``_*_frame``: its scratch on its own stack frame, freed as it returns; inlined into the
# loop, the scratch would grow the stack state after state): the single call's bits. The
# map Gm comes after the states, so that robot/batches.run_split splits only the states.
_rnea_frame = njit(cache=True)(_rnea_state.py_func)
_crba_frame = njit(cache=True)(_crba_state.py_func)
_fd_frame = njit(cache=True)(_fd_state.py_func)


@njit(cache=True, inline="always")
def _batch_lengths(P, Gm, q, rates, gw, out):
    """``_lengths`` of a batch (N = out's rows, k its columns) whose rows q (k + 1 on a
    floating base), the rates (k) and gw (GW) fit, one each or N; else (-1, -1)."""
    N, k = out.shape[0], out.shape[1]
    nv, nq = _lengths(P, Gm, q[0], k)
    if (nv < 0 or not rows_fit(N, k, rates) or not rows_fit(N, nq - nv + k, (q,))
            or not rows_fit(N, GW, (gw,))):
        return -1, -1
    return nv, nq


def mimic_rnea_batch(P, q, qd, qdd, gw, Gm, flags, out):
    """``mimic_rnea`` of N states (rows broadcast) into ``out`` (N, k)."""
    nv, nq = _batch_lengths(P, Gm, q, (qd, qdd), gw, out)
    if nv < 0:
        return BAD_LENGTH
    chk = 0.0
    for s in range(out.shape[0]):
        chk += _rnea_frame(P, Gm, row(q, s), row(qd, s), row(qdd, s), row(gw, s), flags,
                           nq, nv, out[s])
    return status(chk)


def mimic_crba_batch(P, q, Gm, out):
    """``mimic_crba`` of N configurations into ``out`` (N, k, k)."""
    N, k = out.shape[0], out.shape[1]
    nv, nq = _lengths(P, Gm, q[0], k)
    if nv < 0 or out.shape[2] != k or not rows_fit(N, nq - nv + k, (q,)):
        return BAD_LENGTH
    chk = 0.0
    for s in range(N):
        chk += _crba_frame(P, Gm, row(q, s), nq, nv, out[s])
    return status(chk)


def mimic_fd_batch(P, q, qd, tau, gw, Gm, flags, out):
    """``mimic_fd`` of N states into ``out`` (N, k)."""
    nv, nq = _batch_lengths(P, Gm, q, (qd, tau), gw, out)
    if nv < 0:
        return BAD_LENGTH
    chk = 0.0
    for s in range(out.shape[0]):
        chk += _fd_frame(P, Gm, row(q, s), row(qd, s), row(tau, s), row(gw, s), nq, nv,
                         out[s])
    return status(chk)


reduced_fd_inline = njit(cache=True, inline="always")(reduced_fd)
reduced_fd = njit(cache=True)(reduced_fd)        # the general path's, state by state

_CALLS = ("rnea_core", "floating_rnea_core", "tree_rnea_core", "crba_core", "floating_crba_core", "tree_crba_core", "cholesky_factor",
          "cholesky_solve_factored", "ltdl_factor", "ltdl_solve_factored")
ENTRY_POINTS = {
    "mimic_rnea": (mimic_rnea, i8(Pm, Mat, Vec, Vec, Vec, Vec, i8, Vec), False, _CALLS),
    "mimic_crba": (mimic_crba, i8(Pm, Mat, Vec, Mat), False, _CALLS),
    "mimic_fd": (mimic_fd, i8(Pm, Mat, Vec, Vec, Vec, Vec, i8, Vec), False, _CALLS),
    "mimic_rnea_batch": (mimic_rnea_batch, i8(Pm, In2, In2, In2, In2, Pm, i8, Out2), True, _CALLS),
    "mimic_crba_batch": (mimic_crba_batch, i8(Pm, In2, Pm, Out3), True, _CALLS),
    "mimic_fd_batch": (mimic_fd_batch, i8(Pm, In2, In2, In2, In2, Pm, i8, Out2), True, _CALLS),
}
SINGLE_STATE = ("mimic_rnea", "mimic_crba", "mimic_fd")
