"""Derivatives of inverse and forward dynamics of a fixed-base tree over a batch, compiled:
B states at a time in SIMD lanes (the lane index last, as in ``derivatives_lanes.py``).

``tree_derivatives.tree_derivatives_core``'s forward-mode pass, lane by lane through its
steps (``into_body``, ``joint_rate``, ``body_wrench``, ``tangent_through``, ``seeds``,
``_body_tangent``, ``own_turn``, ``force_to_parent``, ``tip_load``), in one depth-first walk
of the tree that keeps only what is live, so that a block of lanes fits on the stack:
entering body k, its outward step; leaving it (its subtree done), its inward step.

- The motion tangents of body k are its ancestors' directions and its own: one level of TM
  per depth holds them, column 2 depth + (0: q, 1: qd) of each ancestor (``_tm``).
- Body k's joint-wrench tangent lives from entering k (started from its body tangent, as
  in ``tree_derivatives_core``) to leaving it (carried into its parent's), on the level of
  its depth in TF: its ancestors' columns by depth as in TM, then directions k .. last(k)
  (the index range of its subtree, which ``tree_derivatives_core`` carries) from column
  2 depth on. Every other direction's entry is zero there as here.
- A body's joint transform, motion and wrench live from entering it to leaving it too,
  one level per depth.
- Children are walked in descending index, so that each parent sums its children's
  wrenches and tangents in ``tree_derivatives_core``'s order.

Each lane does ``tree_derivatives_core``'s operations in its order for each body and
direction, so a state's derivatives are bitwise its single call's, alone or in any batch.
Forward dynamics: qdd and M's sparse factor in lanes (``tree_lanes``, bitwise
``tree.tree_fd_core``), d tau at (q, qd, qdd) in lanes, then each state's solves
(``tree_derivatives.ltdl_solve_minus``), as ``tree_fd_derivatives_core``. A floating
base's instantaneous tree (``floating_derivatives.py``) runs the same blocks on each
state's tree inputs, then its base columns per state.
"""
from numba import njit

from . import flags as F
from .crba_lanes import lane_rotation
from .data import LANE_STACK_DOUBLES, heap_empty, new_chol, new_kin, scratch, stack_empty
from .derivatives import _body_tangent, _inertia_times, tangent_through
from .derivatives_lanes import DLANES
from .floating_derivatives import (ID_FLAGS, _bad_batch, _clear_base, base_columns,
                                   base_columns_fd, fd_rows, id_rows, tree_fd_loop,
                                   tree_id_loop, tree_wrench_turns)
from .joint import (axis, joint_rate, lane_transforms, lane_transforms_at, own_turn, rate_terms,
                    seeds)
from .layout import H, IO, KIND, LANES, MASS, PARENT, TIPP, TIPPATH, W_ALL
from .rnea import base_state, body_wrench, into_body, tip_load
from .rnea_lanes import gather
from .signatures import D2, In2, Out3, Pm, i8, internal, row
from .spatial import force_to_parent, rotate_t
from .status import BAD_LENGTH, NOT_FINITE, OK
from .tree_derivatives import (_scratch, ltdl_solve_minus, tree_derivatives_core,
                               tree_fd_derivatives_core)
from .tree_lanes import ancestor_rows, factor, fd_lanes, tree_composite_lanes, tree_scratch

WALK, DEPTH, LAST, WIDTH, OFFSET = range(5)     # rows of the walk's table (``tree_walk``)


@njit(cache=True, inline="always")
def tree_walk(P, T):
    """The table T (5, 2n + 5) of the depth-first walk. T[WALK]: 2n steps, k for entering
    body k, -1 - k for leaving it (children by descending index); T[DEPTH, k], T[LAST, k]:
    body k's depth and the highest index in its subtree; T[WIDTH, d]: the columns of level
    d of TF (2 d + 2 (last(k) - k + 1) at most over its bodies), T[OFFSET, d] its first
    row. The levels alternate between two arrays of each (even and odd depths), so that a
    level and its parent's never share one: LLVM then knows that they do not overlap, and
    packs the loops that read one and write the other. Returns (and keeps in T[DEPTH, 2n:])
    the rows of TM's two arrays and TF's, and the number of levels D."""
    n = P.shape[0] - 1
    D = 0
    for i in range(n):
        l = int(P[i, PARENT])
        T[DEPTH, i] = 0.0 if l < 0 else T[DEPTH, l] + 1.0
        T[LAST, i] = i
        D = max(D, int(T[DEPTH, i]) + 1)
    for i in range(n - 1, -1, -1):
        l = int(P[i, PARENT])
        if l >= 0 and T[LAST, i] > T[LAST, l]:
            T[LAST, l] = T[LAST, i]
    for d in range(D):
        T[WIDTH, d] = 0.0
    for i in range(n):
        d = int(T[DEPTH, i])
        T[WIDTH, d] = max(T[WIDTH, d], 2.0 * d + 2.0 * (T[LAST, i] - i + 1.0))
    rows0, rows1 = 0, 0
    for d in range(D):
        if d % 2 == 0:
            T[OFFSET, d] = rows0
            rows0 += 6 * int(T[WIDTH, d])
        else:
            T[OFFSET, d] = rows1
            rows1 += 6 * int(T[WIDTH, d])
    t = 0
    for i in range(n - 1, -1, -1):       # the roots, then each subtree, by descending index
        if int(P[i, PARENT]) < 0:
            t = _walk(P, T, i, t)
    me, mo = (D + 1) // 2, D // 2
    sizes = (18 * me * me, max(18 * mo * (mo + 1), 1), rows0, max(rows1, 1), D)
    for j in range(5):
        T[DEPTH, 2 * n + j] = sizes[j]
    return sizes


@njit(cache=True)
def _walk(P, T, i, t):
    """The steps of the subtree of body i into T[WALK] from place t (no recursion: the
    parent array is climbed back). Returns the next free place."""
    k = i
    while True:
        T[WALK, t] = k                   # enter k
        t += 1
        c = int(T[LAST, k])              # k's highest-index child, else leave and climb
        while c > k and int(P[c, PARENT]) != k:
            c -= 1
        while c == k:
            T[WALK, t] = -1 - k          # leave k
            t += 1
            if k == i:
                return t
            l = int(P[k, PARENT])        # k's next sibling below it, else leave l
            c = k - 1
            while c > l and int(P[c, PARENT]) != l:
                c -= 1
            if c == l:
                c, k = l, l
        k = c


@njit(cache=True, inline="always")
def tree_derivative_lanes(P, TM0, TM1, TF0, TF1, D):
    """The lanes of a block: at most P[n, LANES] and DLANES, as many as keep its scratch
    (the levels' rows + 39 D + 3 n + W_ALL + 40 doubles a lane) within
    data.LANE_STACK_DOUBLES, rounded down to a multiple of 8 (a loop over 8 + 6 lanes runs
    its last 6 one by one). 0, fewer than 8: one state at a time (on Talos, 4 lanes ran 1.2x
    slower than that, 8 lanes 1.3x faster: one core, 2026-11-28)."""
    n = P.shape[0] - 1
    per = TM0 + TM1 + TF0 + TF1 + 39 * D + 3 * n + W_ALL + 40
    m = min(int(P[n, LANES]), DLANES, LANE_STACK_DOUBLES // per)
    return m - m % 8


@njit(cache=True, inline="always")
def walk_lanes(P, T):
    """The walk into T (5, 2n + 5: ``tree_walk``) and the lanes of its blocks."""
    M0, M1, F0, F1, D = tree_walk(P, T)
    return tree_derivative_lanes(P, M0, M1, F0, F1, D)


@njit(cache=True, inline="always")
def _tm(d, s, c):
    """The row of level d's component s (0..8), column c (the ancestor at depth c // 2) in
    its array of TM (even or odd levels: 2 (d + 1) columns a component)."""
    m = d // 2
    return 18 * m * (m if d % 2 == 0 else m + 1) + 2 * (d + 1) * s + c


@internal(i8(Pm, D2, In2, In2, In2, In2, i8, Out3, Out3, i8))
def tree_derivatives_block(P, T, q, qd, qdd, w, flags, dq, dqd, k0):
    """d tau/d q, d tau/d qd of the states k0 .. k0 + B - 1 of a fixed-base tree (fewer at
    the batch's end) into the same rows of dq, dqd (N, n, n); T the walk (``tree_walk``);
    flags as ``tree_derivatives_core`` (QD, QDD always set). Returns NOT_FINITE if one of
    them has a NaN/Inf input, else OK. Scratch, lane last: QV, WB as ``rnea_lanes.gather``;
    by level (a body's from entering it to leaving it) RB, PB its joint transform, MO its
    (omega, alpha, acc), FB its body wrench, then its joint wrench; TM0, TM1 and TF0, TF1
    the tangents' levels (module docstring; even and odd depths); ST the base's motion,
    then the tip wrench (e; m); AUX the current body's parent omega, w0.p, rate terms,
    omega, I_O omega, omega.h; SD a body's seeds; TE the tip wrench's tangents along the
    tip's path (columns by depth); OT a joint's own turn; SL the TF row of each direction
    of the body left (-1: zero)."""
    N = dq.shape[0]
    n = P.shape[0] - 1
    L = tree_derivative_lanes(P, int(T[DEPTH, 2 * n]), int(T[DEPTH, 2 * n + 1]),
                              int(T[DEPTH, 2 * n + 2]), int(T[DEPTH, 2 * n + 3]),
                              int(T[DEPTH, 2 * n + 4]))
    nl = min(L, N - k0)
    QV, WB, ST = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L)), stack_empty((15, L))
    D = int(T[DEPTH, 2 * n + 4])
    RB, PB, MO = stack_empty((9 * D, L)), stack_empty((3 * D, L)), stack_empty((9 * D, L))
    FB, AUX, OT = stack_empty((6 * D, L)), stack_empty((13, L)), stack_empty((6, L))
    TM0, TM1 = stack_empty((int(T[DEPTH, 2 * n]), L)), stack_empty((int(T[DEPTH, 2 * n + 1]), L))
    TF0, TF1 = stack_empty((int(T[DEPTH, 2 * n + 2]), L)), stack_empty((int(T[DEPTH, 2 * n + 3]), L))
    TE, SD = stack_empty((6, 2 * D, L)), stack_empty((15, 2))
    SL = stack_empty((n,))
    use_w = (flags & F.WRENCH) != 0
    small, fin = gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl)
    for b in range(nl):
        (ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b], ST[6, b], ST[7, b],
         ST[8, b]), (ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b],
                     ST[14, b]), c = base_state(P, WB[:, b], flags, n, 0.0)
    for step in range(2 * n):
        k = int(T[WALK, step])
        d = int(T[DEPTH, k if k >= 0 else -1 - k])
        if k >= 0 and d % 2 == 0:        # body k's level in the even arrays, its parent's odd
            enter(P, T, k, QV, RB, PB, MO, FB, ST, AUX, SD, TE, TM0, TM1, TF0, use_w, small, nl)
        elif k >= 0:
            enter(P, T, k, QV, RB, PB, MO, FB, ST, AUX, SD, TE, TM1, TM0, TF1, use_w, small, nl)
        elif d % 2 == 0:
            leave(P, T, -1 - k, RB, PB, FB, ST, OT, SL, TE, TF0, TF1, dq, dqd, k0, use_w, nl)
        else:
            leave(P, T, -1 - k, RB, PB, FB, ST, OT, SL, TE, TF1, TF0, dq, dqd, k0, use_w, nl)
    return OK if fin else NOT_FINITE


@njit(cache=True, inline="always")
def enter(P, T, k, QV, RB, PB, MO, FB, ST, AUX, SD, TE, TM, TMP, TF, use_w, small, nl):
    """Entering body k, outward (``tree_derivatives_core``'s step of body k): its joint
    transform, motion and body wrench (MO, FB), its seeds, its parent's live tangents
    through it (TMP, the parent's level, into TM, k's), the tip wrench's on its path;
    its joint-wrench tangent started on its level of TF: its body tangent on its and its
    ancestors' directions, zero on its subtree's."""
    n = P.shape[0] - 1
    l, dk = int(P[k, PARENT]), int(T[DEPTH, k])
    rk, pk, fk = 9 * dk, 3 * dk, 6 * dk   # body k's rows of its level's RB, PB, MO, FB
    lane_transforms_at(P, k, QV, RB, PB, nl, small, rk, pk)
    kind, m = P[k, KIND], P[k, MASS]
    hx, hy, hz = P[k, H], P[k, H + 1], P[k, H + 2]
    I6 = (P[k, IO], P[k, IO + 1], P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5])
    on_path = use_w and P[k, TIPPATH] != 0.0
    S, si = (MO, rk - 9) if l >= 0 else (ST, 0)         # the parent's motion, or the base's
    v = 2 * (dk + 1)                     # TM's columns at level dk
    own = _tm(dk, 0, 2 * dk)
    for b in range(nl):                  # the state through body k, and its seeds
        r = lane_rotation(RB, rk, b)
        px, py, pz = PB[pk, b], PB[pk + 1, b], PB[pk + 2, b]
        wx, wy, wz = S[si, b], S[si + 1, b], S[si + 2, b]
        AUX[0, b], AUX[1, b], AUX[2, b] = wx, wy, wz
        AUX[3, b] = wx * px + wy * py + wz * pz
        wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(
            r, px, py, pz, wx, wy, wz, S[si + 3, b], S[si + 4, b], S[si + 5, b], S[si + 6, b],
            S[si + 7, b], S[si + 8, b])
        wpx, wpy, apx, apy, lpx, lpy = wx, wy, ax, ay, lx, ly
        ex, ey, ez, mx, my, mz = ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b], ST[14, b]
        if on_path:
            ex, ey, ez = rotate_t(r, ex, ey, ez)
            mx, my, mz = rotate_t(r, mx, my, mz)
            ST[9, b], ST[10, b], ST[11, b], ST[12, b], ST[13, b], ST[14, b] = ex, ey, ez, mx, my, mz
        dqk = QV[n + k, b]
        wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(kind, wx, wy, wz, ax, ay, az, lx, ly, lz,
                                                        dqk, QV[2 * n + k, b])
        (MO[rk, b], MO[rk + 1, b], MO[rk + 2, b], MO[rk + 3, b], MO[rk + 4, b], MO[rk + 5, b],
         MO[rk + 6, b], MO[rk + 7, b], MO[rk + 8, b]) = wx, wy, wz, ax, ay, az, lx, ly, lz
        (FB[fk, b], FB[fk + 1, b], FB[fk + 2, b], FB[fk + 3, b], FB[fk + 4, b],
         FB[fk + 5, b]) = body_wrench(P, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
        AUX[4, b], AUX[5, b] = rate_terms(kind, dqk)
        AUX[6, b], AUX[7, b], AUX[8, b] = wx, wy, wz
        AUX[9, b], AUX[10, b], AUX[11, b] = _inertia_times(I6, wx, wy, wz)
        AUX[12, b] = wx * hx + wy * hy + wz * hz
        seeds(SD, 0, kind, dqk, wz, wpx, wpy, apx, apy, lpx, lpy, ex, ey, mx, my)
        for s in range(9):
            TM[own + v * s, b], TM[own + v * s + 1, b] = SD[s, 0], SD[s, 1]
        if on_path:                      # the tip wrench's seed (direction q_k)
            for s in range(6):
                TE[s, 2 * dk, b], TE[s, 2 * dk + 1, b] = SD[9 + s, 0], 0.0
    for c in range(2 * dk):              # the parent's live tangents through body k
        a, z, u = _tm(dk - 1, 0, c), _tm(dk, 0, c), 2 * dk
        for b in range(nl):
            (TM[z, b], TM[z + v, b], TM[z + 2 * v, b], TM[z + 3 * v, b], TM[z + 4 * v, b],
             TM[z + 5 * v, b], TM[z + 6 * v, b], TM[z + 7 * v, b],
             TM[z + 8 * v, b]) = tangent_through(
                lane_rotation(RB, rk, b), PB[pk, b], PB[pk + 1, b], PB[pk + 2, b], AUX[0, b],
                AUX[1, b], AUX[2, b], AUX[3, b], AUX[4, b], AUX[5, b], TMP[a, b], TMP[a + u, b],
                TMP[a + 2 * u, b], TMP[a + 3 * u, b], TMP[a + 4 * u, b], TMP[a + 5 * u, b],
                TMP[a + 6 * u, b], TMP[a + 7 * u, b], TMP[a + 8 * u, b])
    if on_path:                          # the tip wrench's tangents of k's ancestors, into k
        for c in range(2 * dk):
            for b in range(nl):
                r = lane_rotation(RB, rk, b)
                TE[0, c, b], TE[1, c, b], TE[2, c, b] = rotate_t(r, TE[0, c, b], TE[1, c, b], TE[2, c, b])
                TE[3, c, b], TE[4, c, b], TE[5, c, b] = rotate_t(r, TE[3, c, b], TE[4, c, b], TE[5, c, b])
    f0, wd = int(T[OFFSET, dk]), int(T[WIDTH, dk])
    for s in range(6):
        for c in range(v, 2 * dk + 2 * (int(T[LAST, k]) - k + 1)):
            for b in range(nl):
                TF[f0 + s * wd + c, b] = 0.0
    for c in range(v):
        z, e = _tm(dk, 0, c), f0 + c
        for b in range(nl):
            body = (m, hx, hy, hz, I6, AUX[6, b], AUX[7, b], AUX[8, b], AUX[9, b], AUX[10, b],
                    AUX[11, b], AUX[12, b])
            (TF[e, b], TF[e + wd, b], TF[e + 2 * wd, b], TF[e + 3 * wd, b], TF[e + 4 * wd, b],
             TF[e + 5 * wd, b]) = _body_tangent(body, TM[z, b], TM[z + v, b], TM[z + 2 * v, b],
                                                TM[z + 3 * v, b], TM[z + 4 * v, b],
                                                TM[z + 5 * v, b], TM[z + 6 * v, b],
                                                TM[z + 7 * v, b], TM[z + 8 * v, b])


@njit(cache=True, inline="always")
def leave(P, T, i, RB, PB, FB, ST, OT, SL, TE, TF, TFP, dq, dqd, k0, use_w, nl):
    """Leaving body i (its subtree done), inward (``tree_derivatives_core``'s step of body
    i): tau_i = S_i^T f_i, its row of d tau from its tangent (TF, its level); then
    f_lambda(i) += Xup_i^T f_i, the same for the tangent into its parent's (TFP), and joint
    i's own turn on direction q_i there."""
    n = P.shape[0] - 1
    l, di, li = int(P[i, PARENT]), int(T[DEPTH, i]), int(T[LAST, i])
    f0, wd = int(T[OFFSET, di]), int(T[WIDTH, di])
    ri, pi, fi = 9 * di, 3 * di, 6 * di
    if use_w and i == n - 1:             # the tip load -w on the last body (a leaf)
        for b in range(nl):
            (FB[fi, b], FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b], FB[fi + 4, b],
             FB[fi + 5, b]) = tip_load(P, n, FB[fi, b], FB[fi + 1, b], FB[fi + 2, b],
                                       FB[fi + 3, b], FB[fi + 4, b], FB[fi + 5, b], ST[9, b],
                                       ST[10, b], ST[11, b], ST[12, b], ST[13, b], ST[14, b])
        _tip_tangents(P, TE, TF, f0, wd, 2 * di + 2, nl)
    # d tau_i = S_i^T (d n; d f): its subtree's and ancestors' directions, zero elsewhere
    e = f0 + axis(P[i, KIND]) * wd
    for j in range(n):
        SL[j] = -1.0
    for j in range(i, li + 1):
        SL[j] = e + 2 * di + 2 * (j - i)
    j = l
    while j >= 0:
        SL[j] = e + 2 * T[DEPTH, j]
        j = int(P[j, PARENT])
    for b in range(nl):
        for j in range(n):
            c = int(SL[j])
            dq[k0 + b, i, j] = TF[c, b] if c >= 0 else 0.0
            dqd[k0 + b, i, j] = TF[c + 1, b] if c >= 0 else 0.0
    if l < 0:
        return
    kind, fl = P[i, KIND], fi - 6
    g0, wp = int(T[OFFSET, di - 1]), int(T[WIDTH, di - 1])
    for b in range(nl):                  # joint i's own turn, from its joint wrench
        (OT[0, b], OT[1, b], OT[2, b], OT[3, b], OT[4, b],
         OT[5, b]) = own_turn(kind, lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b],
                              PB[pi + 2, b], FB[fi, b], FB[fi + 1, b], FB[fi + 2, b],
                              FB[fi + 3, b], FB[fi + 4, b])
    # the tangent carried into the parent's columns: directions i .. last(i) from column
    # 2 di to 2 di - 2 + 2 (i - l), the ancestors' (l's among them) at the same columns
    for c in range(2 * di, 2 * di + 2 * (li - i + 1)):
        _carry(TF, f0 + c, wd, TFP, g0 + c - 2 + 2 * (i - l), wp, RB, PB, di, nl)
    for c in range(2 * di):
        _carry(TF, f0 + c, wd, TFP, g0 + c, wp, RB, PB, di, nl)
    a = g0 + 2 * di - 2 + 2 * (i - l)
    for s in range(6):
        for b in range(nl):
            TFP[a + s * wp, b] = TFP[a + s * wp, b] + OT[s, b]
    for b in range(nl):
        nx, ny, nz, fx, fy, fz = force_to_parent(
            lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], FB[fi, b],
            FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b], FB[fi + 4, b], FB[fi + 5, b])
        FB[fl, b], FB[fl + 1, b], FB[fl + 2, b] = FB[fl, b] + nx, FB[fl + 1, b] + ny, FB[fl + 2, b] + nz
        FB[fl + 3, b], FB[fl + 4, b], FB[fl + 5, b] = FB[fl + 3, b] + fx, FB[fl + 4, b] + fy, FB[fl + 5, b] + fz


@njit(cache=True, inline="always")
def _carry(TF, x, wx, TFP, y, wy, RB, PB, d, nl):
    """``tree_derivatives.carry_tangent`` in every lane: the column at row x (stride wx) of
    a body's tangent TF carried into its parent's TFP at row y (stride wy): += Xup^T, its
    transform at level d of RB, PB."""
    ri, pi = 9 * d, 3 * d
    for b in range(nl):
        ux, uy, uz, cx, cy, cz = force_to_parent(
            lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], TF[x, b],
            TF[x + wx, b], TF[x + 2 * wx, b], TF[x + 3 * wx, b], TF[x + 4 * wx, b], TF[x + 5 * wx, b])
        TFP[y, b], TFP[y + wy, b], TFP[y + 2 * wy, b] = TFP[y, b] + ux, TFP[y + wy, b] + uy, TFP[y + 2 * wy, b] + uz
        TFP[y + 3 * wy, b] = TFP[y + 3 * wy, b] + cx
        TFP[y + 4 * wy, b] = TFP[y + 4 * wy, b] + cy
        TFP[y + 5 * wy, b] = TFP[y + 5 * wy, b] + cz


@njit(cache=True, inline="always")
def _tip_tangents(P, TE, TF, f0, wd, cols, nl):
    """``derivatives.tip_tangents`` in every lane on the tip body's tangent (rows f0 + s wd
    of TF), TE holding the tip wrench's tangents (T rows 9..14 there) by depth: d(-e),
    d(-m + Xtip_p x -e). Its other directions' are zero: they stay zero."""
    n = P.shape[0] - 1
    tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
    for c in range(cols):
        for b in range(nl):
            gx, gy, gz = TE[0, c, b], TE[1, c, b], TE[2, c, b]
            TF[f0 + 3 * wd + c, b] -= gx
            TF[f0 + 4 * wd + c, b] -= gy
            TF[f0 + 5 * wd + c, b] -= gz
            TF[f0 + c, b] -= TE[3, c, b] + tpy * gz - tpz * gy
            TF[f0 + wd + c, b] -= TE[4, c, b] + tpz * gx - tpx * gz
            TF[f0 + 2 * wd + c, b] -= TE[5, c, b] + tpx * gy - tpy * gx


# ------------------------------------------------------------------ entry points
def tree_rnea_derivatives_batch(P, q, qd, qdd, w, flags, dq, dqd):
    """``tree_derivatives.tree_rnea_derivatives`` of N states (rows broadcast as in
    ``rnea_batch``) into (N, n, n) arrays, blocks of B states in lanes (one state at a
    time where a block does not fit). Returns OK, or NOT_FINITE on a NaN/Inf input."""
    N, n = dq.shape[0], P.shape[0] - 1
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD | F.QDD
    T = stack_empty((5, 2 * n + 5))
    L = walk_lanes(P, T)
    bad = OK
    if L == 0:
        d = new_kin(n)
        mo, TM, TE, TF, last = _scratch(n)
        nq, nv, na, nw = q.shape[0] > 1, qd.shape[0] > 1, qdd.shape[0] > 1, w.shape[0] > 1
        for k in range(N):
            if tree_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, TM, TE, TF, last, q[k if nq else 0],
                                     qd[k if nv else 0], qdd[k if na else 0], w[k if nw else 0],
                                     flags, dq[k], dqd[k]) != 0.0:
                bad = NOT_FINITE
        return bad
    for k0 in range(0, N, L):
        bad |= tree_derivatives_block(P, T, q, qd, qdd, w, flags, dq, dqd, k0)
    return bad


def tree_fd_derivatives_batch(P, q, qd, tau, w, flags, dq, dqd, Minv):
    """``tree_derivatives.tree_fd_derivatives`` of N states into (N, n, n) arrays: per
    block, qdd and M's sparse factor in lanes (``tree_lanes.fd_lanes``), d tau
    at (q, qd, qdd) in lanes, then each state's solves (``ltdl_solve_minus``) on its
    factor. Returns OK or NOT_FINITE."""
    N, n = dq.shape[0], P.shape[0] - 1
    T = stack_empty((5, 2 * n + 5))
    L = walk_lanes(P, T)
    X = scratch((n, 3 * n), 3 * n * n)
    bad = OK
    if L == 0:
        d, c, x = new_kin(n), new_chol(n), stack_empty((n,))
        mo, TM, TE, TF, last = _scratch(n)
        IC = stack_empty((n, 10))
        nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
        for k in range(N):
            if tree_fd_derivatives_core(P, d.sc, d.R, d.p, d.f, mo, IC, c.M, x, TM, TE, TF, last,
                                        X, q[k if nq else 0], qd[k if nv else 0],
                                        tau[k if nt else 0], w[k if nw else 0], flags, dq[k],
                                        dqd[k], Minv[k]) != 0.0:
                bad = NOT_FINITE
        return bad
    qdd, MF = heap_empty((N, n)), scratch((n, n), n * n)
    off, dep, rows = ancestor_rows(P)
    QV, WB, RB, PB, MO, FB, EB, BS, TB = tree_scratch(n, L)
    IC, MB = stack_empty((10 * n, L)), stack_empty((rows, L))
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        if not fd_lanes(P, off, dep, QV, WB, RB, PB, MO, FB, EB, BS, TB, IC, MB, q, qd, tau, w,
                        flags, k0, nl, qdd, 0):
            bad = NOT_FINITE
        bad |= tree_derivatives_block(P, T, q, qd, qdd, w, flags | F.QDD, dq, dqd, k0)
        for b in range(nl):
            k = k0 + b
            lane_system(P, off, MB, b, dq[k], dqd[k], MF, X)
            ltdl_solve_minus(P, MF, X, dq[k], dqd[k], Minv[k])
    return bad


@njit(cache=True, inline="always")
def lane_system(P, off, MB, b, dq, dqd, MF, X):
    """Lane b's solves' inputs: its sparse factor from MB into MF (``tree_lanes.factor``),
    its d tau/d q, d tau/d qd (dq, dqd) into X's first 2n columns."""
    factor(P, off, MB, b, MF)
    n = dq.shape[0]
    for i in range(n):
        for j in range(n):
            X[i, j], X[i, n + j] = dq[i, j], dqd[i, j]


# ------------------------------------------------------------------ a floating base
# floating_derivatives.py's floating_tree_* on the instantaneous tree, a block at a time:
# each state's tree inputs (floating.rnea_inputs, fd_inputs) into the block's rows, the
# tree's derivatives (and qdd, M or its factor) in lanes as above, then each state's base
# columns, wrench turns and solves as there (the same operations, so the same bits).
def floating_tree_rnea_derivatives_batch(P, q, v, a, gw, flags, dq, dv):
    """``floating_derivatives.floating_tree_rnea_derivatives`` of N states (rows
    broadcast) into (N, n+6, n+6) arrays. Returns OK, NOT_FINITE or BAD_LENGTH."""
    nv, N, T = P.shape[0] - 1, dq.shape[0], stack_empty((5, 2 * P.shape[0] + 3))
    if _bad_batch(P, q, v, a, gw, dq, False):
        return BAD_LENGTH
    L, wf = walk_lanes(P, T), flags & F.WRENCH
    if L == 0:
        return tree_id_loop(P, q, v, a, gw, flags, dq, dv)
    Qt, Vt, At, Wt = stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, W_ALL))
    off, dep, rows = ancestor_rows(P)
    QV, WB, RB, PB = stack_empty((3 * nv + 1, L)), stack_empty((W_ALL, L)), stack_empty((9 * nv, L)), stack_empty((3 * nv, L))
    IC, FB, MB = stack_empty((10 * nv, L)), stack_empty((6, L)), stack_empty((rows, L))
    M = scratch((nv, nv), nv * nv)
    d, mo, y, col = new_kin(nv), stack_empty((nv, 9)), stack_empty((W_ALL,)), stack_empty((nv,))
    bad = OK
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        bad |= id_rows(q, v, a, gw, wf, k0, nl, Qt, Vt, At, Wt)
        bad |= tree_derivatives_block(P, T, Qt, Vt, At, Wt, ID_FLAGS | wf, dq[k0:k0 + nl],
                                      dv[k0:k0 + nl], 0)
        small, fin = gather(P, Qt, Qt, Qt, Qt, 0, QV, WB, 0, nl)   # M, as tree_crba_core
        for i in range(nv):
            lane_transforms(P, i, QV, RB, PB, nl, small)
        tree_composite_lanes(P, off, RB, PB, IC, FB, MB, nl, 0)
        for b in range(nl):
            k = k0 + b
            factor(P, off, MB, b, M)     # M[i, j], j = i and its ancestors: the virtual
            for i in range(6):           # joints 0..5 for every i >= 6; the rest by symmetry
                for j in range(i + 1, 6):
                    M[i, j] = M[j, i]
            base_columns(row(v, k), Wt[b], M, dq[k], dv[k])
            if wf != 0:
                tree_wrench_turns(P, d, mo, Qt[b], Wt[b], y, col, dq[k])
    return bad


def floating_tree_fd_derivatives_batch(P, q, v, tau, gw, flags, dq, dv, Minv):
    """``floating_derivatives.floating_tree_fd_derivatives`` of N states into (N, n+6,
    n+6) arrays: per block, the tree's qdd and sparse factor in lanes (``fd_lanes``), its
    d tau in lanes, then each state's base columns, wrench turns and solves."""
    nv, N, T = P.shape[0] - 1, dq.shape[0], stack_empty((5, 2 * P.shape[0] + 3))
    if _bad_batch(P, q, v, tau, gw, dq, True):
        return BAD_LENGTH
    L, wf = walk_lanes(P, T), flags & F.WRENCH
    if L == 0:
        return tree_fd_loop(P, q, v, tau, gw, flags, dq, dv, Minv)
    Qt, Vt, Tt, Wt = stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, nv)), stack_empty((L, W_ALL))
    At = heap_empty((L, nv))
    off, dep, rows = ancestor_rows(P)
    QV, WB, RB, PB, MO, FB, EB, BS, TB = tree_scratch(nv, L)
    IC, MB = stack_empty((10 * nv, L)), stack_empty((rows, L))
    MF, X = scratch((nv, nv), nv * nv), scratch((nv, 3 * nv), 3 * nv * nv)
    d, mo, y = new_kin(nv), stack_empty((nv, 9)), stack_empty((W_ALL,))
    bad = OK
    for k0 in range(0, N, L):
        nl = min(L, N - k0)
        bad |= fd_rows(q, v, tau, gw, wf, k0, nl, Qt, Vt, Tt, Wt)
        if not fd_lanes(P, off, dep, QV, WB, RB, PB, MO, FB, EB, BS, TB, IC, MB, Qt, Vt, Tt, Wt,
                        F.QD | F.BASE | wf, 0, nl, At, 0):
            bad = NOT_FINITE
        bad |= tree_derivatives_block(P, T, Qt, Vt, At, Wt, ID_FLAGS | wf, dq[k0:k0 + nl],
                                      dv[k0:k0 + nl], 0)
        for b in range(nl):
            k = k0 + b
            lane_system(P, off, MB, b, dq[k], dv[k], MF, X)
            _clear_base(X)
            if wf != 0:                  # before the solves
                tree_wrench_turns(P, d, mo, Qt[b], Wt[b], y, At[b], X[:, :nv])
            ltdl_solve_minus(P, MF, X, dq[k], dv[k], Minv[k])
            base_columns_fd(row(v, k), Wt[b], dq[k], dv[k])
    return bad


_FLOATING = ("tree_derivatives_block", "tree_derivatives_core", "tree_crba_core",
             "tree_rnea_core")
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "tree_rnea_derivatives_batch": (tree_rnea_derivatives_batch,
                                    i8(Pm, In2, In2, In2, In2, i8, Out3, Out3), True,
                                    ("tree_derivatives_block", "tree_derivatives_core")),
    "tree_fd_derivatives_batch": (tree_fd_derivatives_batch,
                                  i8(Pm, In2, In2, In2, In2, i8, Out3, Out3, Out3), True,
                                  ("tree_derivatives_block", "tree_fd_derivatives_core",
                                   "ltdl_solve_matrix")),
    "floating_tree_rnea_derivatives_batch": (floating_tree_rnea_derivatives_batch,
                                             i8(Pm, In2, In2, In2, In2, i8, Out3, Out3), True,
                                             _FLOATING),
    "floating_tree_fd_derivatives_batch": (floating_tree_fd_derivatives_batch,
                                           i8(Pm, In2, In2, In2, In2, i8, Out3, Out3, Out3), True,
                                           _FLOATING + ("tree_fd_core", "ltdl_solve_matrix")),
}
