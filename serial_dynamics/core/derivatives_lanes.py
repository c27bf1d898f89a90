"""Derivatives of inverse dynamics over a batch, compiled: B states at a time in SIMD lanes.

The forward-mode pass of ``derivatives.py`` (the single-state kernel) with every quantity
stored lane last, as ``rnea_lanes.py`` does for inverse dynamics: the per-body state in
(rows, B) arrays, the tangents T (15, 2n, B), the body-wrench tangents dB (n, 6, 2n, B) and
the joint-wrench tangents Tf (6, 2n, B). The O(n^2) loops over the directions run the
lanes innermost, through the same inline steps as the single-state kernel
(``rnea.into_body``, ``joint_rate``, ``body_wrench``, ``derivatives.tangent_through``,
``_body_tangent``, ``own_turn``, ``spatial.force_to_parent``), so each lane does the
operations of ``derivatives_core`` in the same order: a state's derivatives are bitwise
the same alone or in any batch, at any place in it. The O(n) work per state (seeds, the
tip load, the torques) runs lane by lane on views of the same arrays.

A floating base's chain (``floating_*_derivatives_batch``) runs the same block on its
instantaneous chain (``floating_derivatives.py``): each state's inputs into the block's
rows, the derivatives (and, forward, qdd and M's factor by ``forward_lanes.fd_lanes_core``
with the free-flyer root) in lanes, then each state's base columns, wrench turns and
solves as its single call does them.
"""
from numba import njit

from . import flags as F
from .crba import floating_crba_core
from .data import LANE_STACK_DOUBLES, heap_empty, new_chol, new_kin, scratch, stack_empty
from .derivatives import (_body_tangent, _inertia_times, derivatives_core,
                          fd_derivatives_core, solve_minus, tangent_through, tip_tangents)
from .floating_derivatives import (ID_FLAGS, _bad_batch, _chain_wrench_turns, _clear_base,
                                   base_columns, base_columns_fd, chain_fd_loop, chain_id_loop,
                                   fd_rows, id_rows)
from .joint import axis, joint_rate, joint_transforms, lane_transforms, own_turn, rate_terms, seeds
from .layout import H, IO, KIND, LANES, MASS, W_ALL
from .rnea import base_state, body_wrench, into_body, tip_load
from .crba_lanes import composite_lanes, floating_composite_lanes
from .forward_lanes import fd_lanes_core, fd_scratch
from .rnea_lanes import fixed_base, free_flyer_root, gather, scatter
from .signatures import In2, Out3, Pm, i8, internal, row
from .spatial import force_to_parent, rotate_t
from .status import BAD_LENGTH, NOT_FINITE, OK

DLANES = 32     # lanes of this kernel at most (its tangents are O(n^2) per lane)


@njit(cache=True, inline="always")
def derivative_lanes(n, L):
    """The lanes of a block for n joints: at most L and DLANES, and as many as keep the
    tangents T, Tf, dB (12 n^2 + 42 n doubles a lane) on the block's stack within
    data.LANE_STACK_DOUBLES, where LLVM sees they overlap nothing (chosen between heap and
    stack at run time, the batch ran 1.3x slower: one core, Panda and UR5, 2026-11-27).
    0 from n = 73 on: the batch then runs one state at a time (the same bits)."""
    return min(L, DLANES, LANE_STACK_DOUBLES // (12 * n * n + 42 * n))


@njit(cache=True, inline="always")
def _r(RB, i, b):
    """R_i of lane b from RB (``rnea_lanes.lane_transforms``), as ``spatial.rotation``."""
    k = 9 * i
    return (RB[k, b], RB[k + 1, b], RB[k + 2, b], RB[k + 3, b], RB[k + 4, b], RB[k + 5, b],
            RB[k + 6, b], RB[k + 7, b], RB[k + 8, b])


@njit(cache=True, inline="always")
def torques_lanes(P, Tf, i, dq, dqd, k0, nl):
    """``derivatives._torques`` of every lane: d tau_i = S_i^T (d n; d f) of each direction
    into row i of the states k0.. of dq, dqd (no view a lane)."""
    r = axis(P[i, KIND])
    for j in range(dq.shape[2]):
        for b in range(nl):
            dq[k0 + b, i, j] = Tf[r, 2 * j, b]
            dqd[k0 + b, i, j] = Tf[r, 2 * j + 1, b]


@internal(i8(Pm, In2, In2, In2, In2, i8, Out3, Out3, i8))
def derivatives_block(P, q, qd, qdd, w, flags, dq, dqd, k0):
    """d tau/d q, d tau/d qd of the states k0 .. k0 + B - 1 (fewer at the batch's end) into
    the same rows of dq, dqd (N, n, n); flags as ``derivatives_core`` (QD, QDD are always
    set by the caller). Returns NOT_FINITE if one of them has a NaN/Inf input, else OK.
    Scratch, lane last: QV, WB as ``rnea_lanes.gather``; RB, PB the joint transforms; FB
    the body wrenches; ST (omega, alpha, acc, tip wrench e, m) of the current body; AUX its
    parent's omega w0, w0.p, the rate terms ca, cl, then its omega, I_O omega, omega.h;
    JW the joint wrench, OT a joint's own turn (inward)."""
    N = dq.shape[0]
    n = P.shape[0] - 1
    L = derivative_lanes(n, int(P[n, LANES]))
    nl = min(L, N - k0)
    QV, WB, ST = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L)), stack_empty((15, L))
    RB, PB, FB = stack_empty((9 * n, L)), stack_empty((3 * n, L)), stack_empty((6 * n, L))
    AUX, JW, OT = stack_empty((13, L)), stack_empty((6, L)), stack_empty((6, L))
    T, Tf = stack_empty((15, 2 * n, L)), stack_empty((6, 2 * n, L))
    dB = stack_empty((n, 6, 2 * n, L))
    use_w = (flags & F.WRENCH) != 0
    small, fin = gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl)
    for b in range(nl):
        (ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b], ST[6, b], ST[7, b],
         ST[8, b]), (ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b],
                     ST[14, b]), c = base_state(P, WB[:, b], flags, n, 0.0)
    # --- outward
    for k in range(n):
        lane_transforms(P, k, QV, RB, PB, nl, small)
        kind = P[k, KIND]
        m = P[k, MASS]
        hx, hy, hz = P[k, H], P[k, H + 1], P[k, H + 2]
        I6 = (P[k, IO], P[k, IO + 1], P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5])
        for b in range(nl):              # the state through body k, and the seeds
            r = _r(RB, k, b)
            px, py, pz = PB[3 * k, b], PB[3 * k + 1, b], PB[3 * k + 2, b]
            wx, wy, wz = ST[0, b], ST[1, b], ST[2, b]
            AUX[0, b], AUX[1, b], AUX[2, b] = wx, wy, wz
            AUX[3, b] = wx * px + wy * py + wz * pz
            wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(r, px, py, pz, wx, wy, wz, ST[3, b],
                                                           ST[4, b], ST[5, b], ST[6, b], ST[7, b],
                                                           ST[8, b])
            wpx, wpy, apx, apy, lpx, lpy = wx, wy, ax, ay, lx, ly
            ex, ey, ez, mx, my, mz = ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b], ST[14, b]
            if use_w:
                ex, ey, ez = rotate_t(r, ex, ey, ez)
                mx, my, mz = rotate_t(r, mx, my, mz)
                ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b], ST[14, b] = ex, ey, ez, mx, my, mz
            dqk = QV[n + k, b]
            wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(P[k, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz,
                                                            dqk, QV[2 * n + k, b])
            ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = wx, wy, wz, ax, ay, az
            ST[6, b], ST[7, b], ST[8, b] = lx, ly, lz
            (FB[6 * k, b], FB[6 * k + 1, b], FB[6 * k + 2, b], FB[6 * k + 3, b], FB[6 * k + 4, b],
             FB[6 * k + 5, b]) = body_wrench(P, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
            AUX[4, b], AUX[5, b] = rate_terms(kind, dqk)
            AUX[6, b], AUX[7, b], AUX[8, b] = wx, wy, wz
            AUX[9, b], AUX[10, b], AUX[11, b] = _inertia_times(I6, wx, wy, wz)
            AUX[12, b] = wx * hx + wy * hy + wz * hz
            seeds(T[:, :, b], k, kind, dqk, wz, wpx, wpy, apx, apy, lpx, lpy, ex, ey, mx, my)
        for d in range(2 * k):           # the live tangents through body k
            for b in range(nl):
                (T[0, d, b], T[1, d, b], T[2, d, b], T[3, d, b], T[4, d, b], T[5, d, b], T[6, d, b],
                 T[7, d, b], T[8, d, b]) = tangent_through(
                    _r(RB, k, b), PB[3 * k, b], PB[3 * k + 1, b], PB[3 * k + 2, b], AUX[0, b],
                    AUX[1, b], AUX[2, b], AUX[3, b], AUX[4, b], AUX[5, b], T[0, d, b], T[1, d, b],
                    T[2, d, b], T[3, d, b], T[4, d, b], T[5, d, b], T[6, d, b], T[7, d, b], T[8, d, b])
            if use_w:
                for b in range(nl):
                    r = _r(RB, k, b)
                    T[9, d, b], T[10, d, b], T[11, d, b] = rotate_t(r, T[9, d, b], T[10, d, b], T[11, d, b])
                    T[12, d, b], T[13, d, b], T[14, d, b] = rotate_t(r, T[12, d, b], T[13, d, b],
                                                                     T[14, d, b])
        for d in range(2 * k + 2):       # the body-wrench tangents
            for b in range(nl):
                body = (m, hx, hy, hz, I6, AUX[6, b], AUX[7, b], AUX[8, b], AUX[9, b], AUX[10, b],
                        AUX[11, b], AUX[12, b])
                (dB[k, 0, d, b], dB[k, 1, d, b], dB[k, 2, d, b], dB[k, 3, d, b], dB[k, 4, d, b],
                 dB[k, 5, d, b]) = _body_tangent(body, T[0, d, b], T[1, d, b], T[2, d, b], T[3, d, b],
                                                 T[4, d, b], T[5, d, b], T[6, d, b], T[7, d, b],
                                                 T[8, d, b])
    # --- inward: the last body carries the tip load
    k = n - 1
    for d in range(2 * n):
        for c in range(6):
            for b in range(nl):
                Tf[c, d, b] = dB[k, c, d, b]
    for b in range(nl):
        (JW[0, b], JW[1, b], JW[2, b], JW[3, b], JW[4, b], JW[5, b]) = tip_load(
            P, n, FB[6 * k, b], FB[6 * k + 1, b], FB[6 * k + 2, b], FB[6 * k + 3, b],
            FB[6 * k + 4, b], FB[6 * k + 5, b], ST[9, b], ST[10, b], ST[11, b], ST[12, b],
            ST[13, b], ST[14, b])
        if use_w:
            tip_tangents(P, T[:, :, b], Tf[:, :, b])
    torques_lanes(P, Tf, k, dq, dqd, k0, nl)
    for i in range(n - 2, -1, -1):
        j = i + 1
        kind = P[j, KIND]
        for b in range(nl):              # joint j's own turn; the joint wrench into body i
            r = _r(RB, j, b)
            px, py, pz = PB[3 * j, b], PB[3 * j + 1, b], PB[3 * j + 2, b]
            nx, ny, nz, fx, fy, fz = JW[0, b], JW[1, b], JW[2, b], JW[3, b], JW[4, b], JW[5, b]
            (OT[0, b], OT[1, b], OT[2, b], OT[3, b], OT[4, b],
             OT[5, b]) = own_turn(kind, r, px, py, pz, nx, ny, nz, fx, fy)
            nx, ny, nz, fx, fy, fz = force_to_parent(r, px, py, pz, nx, ny, nz, fx, fy, fz)
            JW[0, b], JW[1, b], JW[2, b] = nx + FB[6 * i, b], ny + FB[6 * i + 1, b], nz + FB[6 * i + 2, b]
            JW[3, b], JW[4, b], JW[5, b] = fx + FB[6 * i + 3, b], fy + FB[6 * i + 4, b], fz + FB[6 * i + 5, b]
        for d in range(2 * n):           # Xup_j^T of every tangent, + body i's below 2i + 2
            for b in range(nl):
                ux, uy, uz, cx, cy, cz = force_to_parent(
                    _r(RB, j, b), PB[3 * j, b], PB[3 * j + 1, b], PB[3 * j + 2, b], Tf[0, d, b],
                    Tf[1, d, b], Tf[2, d, b], Tf[3, d, b], Tf[4, d, b], Tf[5, d, b])
                if d < 2 * i + 2:
                    ux, uy, uz = ux + dB[i, 0, d, b], uy + dB[i, 1, d, b], uz + dB[i, 2, d, b]
                    cx, cy, cz = cx + dB[i, 3, d, b], cy + dB[i, 4, d, b], cz + dB[i, 5, d, b]
                Tf[0, d, b], Tf[1, d, b], Tf[2, d, b], Tf[3, d, b], Tf[4, d, b], Tf[5, d, b] = ux, uy, uz, cx, cy, cz
        a = 2 * j
        for b in range(nl):
            Tf[0, a, b], Tf[1, a, b], Tf[2, a, b] = Tf[0, a, b] + OT[0, b], Tf[1, a, b] + OT[1, b], Tf[2, a, b] + OT[2, b]
            Tf[3, a, b], Tf[4, a, b], Tf[5, a, b] = Tf[3, a, b] + OT[3, b], Tf[4, a, b] + OT[4, b], Tf[5, a, b] + OT[5, b]
        torques_lanes(P, Tf, i, dq, dqd, k0, nl)
    return OK if fin else NOT_FINITE


@njit(cache=True, inline="always")
def cholesky_system(n, MB, b, dq, dqd, MF, X):
    """Lane b's Cholesky factor L out of MB (L_ij, i >= j, in row j n + i) into MF, and the
    state's d tau columns [dq | dqd] into X: what ``solve_minus`` takes."""
    for j in range(n):
        for i in range(j, n):
            MF[i, j] = MB[j * n + i, b]
    for i in range(n):
        for j in range(n):
            X[i, j], X[i, n + j] = dq[i, j], dqd[i, j]


# ------------------------------------------------------------------ entry point
def rnea_derivatives_batch(P, q, qd, qdd, w, flags, dq, dqd):
    """``derivatives.rnea_derivatives`` of N states (rows broadcast as in ``rnea_batch``)
    into (N, n, n) arrays, blocks of B states in lanes. Returns OK, or NOT_FINITE if some
    input had a NaN/Inf."""
    n, N = P.shape[0] - 1, dq.shape[0]
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD | F.QDD
    L = derivative_lanes(n, int(P[n, LANES]))
    bad = OK
    if L == 0:                           # too long for lanes: one state at a time
        d, T, Tf = new_kin(n), stack_empty((15, 2 * n)), stack_empty((6, 2 * n))
        dB = heap_empty((n, 6, 2 * n))
        nq, nv, na, nw = q.shape[0] > 1, qd.shape[0] > 1, qdd.shape[0] > 1, w.shape[0] > 1
        for k in range(N):
            if derivatives_core(P, d.sc, d.R, d.p, d.f, T, Tf, dB, q[k if nq else 0],
                                qd[k if nv else 0], qdd[k if na else 0], w[k if nw else 0],
                                flags, dq[k], dqd[k]) != 0.0:
                bad = NOT_FINITE
        return bad
    for k0 in range(0, N, L):
        bad |= derivatives_block(P, q, qd, qdd, w, flags, dq, dqd, k0)
    return bad


def fd_derivatives_batch(P, q, qd, tau, w, flags, dq, dqd, Minv):
    """``derivatives.fd_derivatives`` of N states into (N, n, n) arrays, the operations of
    ``fd_derivatives_core`` (``forward.cholesky_core``, then d tau at (q, qd, qdd), then the
    solves) regrouped per block: qdd and M's Cholesky factor in lanes
    (``forward_lanes.fd_lanes_core``, bitwise ``cholesky_core``'s), d tau/d (q, qd) in lanes,
    each state's solves (``derivatives.solve_minus``) on its factor. Returns OK, or
    NOT_FINITE on a NaN/Inf."""
    n, N = P.shape[0] - 1, dq.shape[0]
    L = derivative_lanes(n, int(P[n, LANES]))
    X = scratch((n, 3 * n), 3 * n * n)
    bad = OK
    if L == 0:                           # too long for lanes: one state at a time
        d, c, x = new_kin(n), new_chol(n), stack_empty((n,))
        T, Tf, dB = stack_empty((15, 2 * n)), stack_empty((6, 2 * n)), heap_empty((n, 6, 2 * n))
        nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
        for k in range(N):
            if fd_derivatives_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, x, T, Tf, dB, X,
                                   q[k if nq else 0], qd[k if nv else 0], tau[k if nt else 0],
                                   w[k if nw else 0], flags, dq[k], dqd[k], Minv[k]) != 0.0:
                bad = NOT_FINITE
        return bad
    qdd = heap_empty((N, n))
    MF = scratch((n, n), n * n)          # a state's factor L, out of the lanes
    QV, WB, TB, ST, RB, PB, FB, CB, SB = fd_scratch(n, L)
    MB = stack_empty((n * n, L))         # M's slots (n^2 L < 12 n^2 L: on the stack too)
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        if not fd_lanes_core(P, q, qd, tau, w, flags, k0, nl,
                             QV, WB, TB, ST, RB, PB, FB, CB, MB, SB, 0, fixed_base, composite_lanes):
            bad = NOT_FINITE
        scatter(TB, qdd, k0, nl)
        bad |= derivatives_block(P, q, qd, qdd, w, flags | F.QDD, dq, dqd, k0)
        for b in range(nl):
            k = k0 + b
            cholesky_system(n, MB, b, dq[k], dqd[k], MF, X)
            solve_minus(MF, X, dq[k], dqd[k], Minv[k])
    return bad


# ------------------------------------------------------------------ a floating base's chain
def floating_rnea_derivatives_batch(P, q, v, a, gw, flags, dq, dv):
    """``floating_derivatives.floating_rnea_derivatives`` of N states (rows broadcast) into
    (N, n+6, n+6) arrays: per block, each state's instantaneous-chain inputs (q, qd = v,
    qdd = a + p(v), w), their derivatives in lanes (``derivatives_block``), then each
    state's M, base columns and wrench turns as the single call computes them. Returns OK,
    NOT_FINITE or BAD_LENGTH."""
    nv, N = P.shape[0] - 1, dq.shape[0]
    if _bad_batch(P, q, v, a, gw, dq, False):
        return BAD_LENGTH
    L, wf = derivative_lanes(nv, int(P[nv, LANES])), flags & F.WRENCH
    if L == 0:
        return chain_id_loop(P, q, v, a, gw, flags, dq, dv)
    Qt, Vt, At, Wt = stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, W_ALL))
    M = scratch((nv, nv), nv * nv)
    d, y, col = new_kin(nv), stack_empty((W_ALL,)), stack_empty((nv,))
    bad = OK
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        bad |= id_rows(q, v, a, gw, wf, k0, nl, Qt, Vt, At, Wt)
        bad |= derivatives_block(P, Qt, Vt, At, Wt, ID_FLAGS | wf, dq[k0:k0 + nl],
                                 dv[k0:k0 + nl], 0)
        for b in range(nl):
            k = k0 + b
            joint_transforms(P, d.sc, d.R, d.p, Qt[b], nv)     # M, as the single call's
            floating_crba_core(P, d.R, d.p, M)                 # (in lanes: no faster)
            base_columns(row(v, k), Wt[b], M, dq[k], dv[k])
            if wf != 0:
                _chain_wrench_turns(P, d, Qt[b], Wt[b], y, col, dq[k])
    return bad


def floating_fd_derivatives_batch(P, q, v, tau, gw, flags, dq, dv, Minv):
    """``floating_derivatives.floating_fd_derivatives`` of N states into (N, n+6, n+6)
    arrays: per block, qdd of the instantaneous chain and M's Cholesky factor in lanes
    (``forward_lanes.fd_lanes_core`` with the free-flyer root, bitwise
    ``forward.floating_cholesky_core``), d tau in lanes, then each state's wrench turns,
    solves and base columns."""
    nv, N = P.shape[0] - 1, dq.shape[0]
    if _bad_batch(P, q, v, tau, gw, dq, True):
        return BAD_LENGTH
    L, wf = derivative_lanes(nv, int(P[nv, LANES])), flags & F.WRENCH
    if L == 0:
        return chain_fd_loop(P, q, v, tau, gw, flags, dq, dv, Minv)
    Qt, Vt, Tt, Wt = stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, W_ALL))
    At = heap_empty((L, nv))
    QV, WB, TB, ST, RB, PB, FB, CB, SB = fd_scratch(nv, L)
    MB = stack_empty((nv * nv, L))
    MF, X = scratch((nv, nv), nv * nv), scratch((nv, 3 * nv), 3 * nv * nv)
    d, y = new_kin(nv), stack_empty((W_ALL,))
    bad = OK
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        bad |= fd_rows(q, v, tau, gw, wf, k0, nl, Qt, Vt, Tt, Wt)
        if not fd_lanes_core(P, Qt, Vt, Tt, Wt, F.QD | F.BASE | wf, 0, nl, QV, WB, TB, ST, RB,
                             PB, FB, CB, MB, SB, 6, free_flyer_root, floating_composite_lanes):
            bad = NOT_FINITE
        scatter(TB, At, 0, nl)
        bad |= derivatives_block(P, Qt, Vt, At, Wt, ID_FLAGS | wf, dq[k0:k0 + nl],
                                 dv[k0:k0 + nl], 0)
        for b in range(nl):
            k = k0 + b
            cholesky_system(nv, MB, b, dq[k], dv[k], MF, X)
            _clear_base(X)
            if wf != 0:                  # before the solves (At[b]: scratch now)
                _chain_wrench_turns(P, d, Qt[b], Wt[b], y, At[b], X[:, :nv])
            solve_minus(MF, X, dq[k], dv[k], Minv[k])
            base_columns_fd(row(v, k), Wt[b], dq[k], dv[k])
    return bad


_FLOATING = ("derivatives_block", "derivatives_core", "floating_crba_core", "floating_rnea_core")
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "rnea_derivatives_batch": (rnea_derivatives_batch, i8(Pm, In2, In2, In2, In2, i8, Out3, Out3),
                               True, ("derivatives_block", "derivatives_core")),
    "fd_derivatives_batch": (fd_derivatives_batch, i8(Pm, In2, In2, In2, In2, i8, Out3, Out3, Out3),
                             True, ("derivatives_block", "fd_derivatives_core",
                                    "cholesky_solve_matrix")),
    "floating_rnea_derivatives_batch": (floating_rnea_derivatives_batch,
                                        i8(Pm, In2, In2, In2, In2, i8, Out3, Out3), True,
                                        _FLOATING),
    "floating_fd_derivatives_batch": (floating_fd_derivatives_batch,
                                      i8(Pm, In2, In2, In2, In2, i8, Out3, Out3, Out3), True,
                                      _FLOATING + ("floating_cholesky_core", "cholesky_solve_matrix")),
}
