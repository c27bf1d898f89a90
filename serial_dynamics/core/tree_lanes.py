"""Inverse dynamics and forward dynamics (the sparse factor) of a batch on a kinematic tree
(a fixed base, or a floating base's virtual tree with its free-flyer root), its mass matrices
on a fixed base, compiled: B samples at a time in SIMD lanes (``rnea_lanes.py``'s layout: every
quantity (rows, B), the lane innermost).

``tree.tree_rnea_core``'s steps, called lane by lane on the lanes' rows: ``into_body`` and
``joint_rate`` from the parent's motion (kept per body, MO, as ``mo`` there), ``body_wrench``,
the tip wrench carried along the tip's path and ``tip_load`` on the last body, then
``force_to_parent`` summed into each parent, children in descending order as there. A lane
computes exactly what ``tree_rnea_core`` computes for its sample, so a sample's torques are
bitwise the same alone or in any batch.
"""
import numpy as np
from numba import njit

from . import flags as F
from .crba_lanes import lane_rotation
from .data import stack_empty
from .crba import add_in_parent
from .joint import (armature_torques_lanes, has_armature, joint_momentum, joint_rate,
                    lane_transforms, project)
from .layout import ARM, G, H, IO, KIND, LANES, MASS, PARENT, TIPPATH, W_ACC, W_ALL, W_OMEGA
from .rnea import body_wrench, into_body, tip_load
from .rnea_lanes import gather, root_body, scatter, tau_minus_bias
from .signatures import In2, Out2, Out3, Pm, i8, internal
from .spatial import force_to_parent, rotate_t
from .status import NOT_FINITE, OK


@njit(cache=True, inline="always")
def tree_lanes_block(P, q, qd, qdd, w, flags, out, k0, nb):
    """Inverse dynamics of the samples k0 .. k0 + B - 1 of a tree (fewer at the batch's end)
    into the same rows of ``out``; ``nb``: 0 (a fixed base) or 6 (a floating base's virtual
    tree, its first six bodies one free-flyer root). Returns 1 if one of them has a NaN/Inf
    input, else 0."""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])
    nl = min(L, N - k0)
    QV, WB, RB, PB, MO, FB, EB, BS, TB = tree_scratch(n, L)
    small, fin = gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl)
    tree_newton_euler_lanes(P, flags, QV, WB, RB, PB, MO, FB, EB, BS, TB, nl, small, nb)
    scatter(TB, out, k0, nl)
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def tree_rnea_block(P, q, qd, qdd, w, flags, out, k0):
    """``tree_lanes_block`` on a fixed base (``tree.tree_rnea_core`` in every lane)."""
    return tree_lanes_block(P, q, qd, qdd, w, flags, out, k0, 0)


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def floating_tree_rnea_block(P, q, qd, qdd, w, flags, out, k0):
    """``tree_lanes_block`` on a floating base's virtual tree (``P[n, ROOT]`` = 6)."""
    return tree_lanes_block(P, q, qd, qdd, w, flags, out, k0, 6)


@njit(cache=True, inline="always")
def tree_scratch(n, L):
    """The lanes' scratch of ``tree_rnea_block`` on the caller's stack: QV, WB, RB, PB, MO,
    FB, EB, BS, TB."""
    return (stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L)), stack_empty((9 * n, L)),
            stack_empty((3 * n, L)), stack_empty((9 * n, L)), stack_empty((6 * n, L)),
            stack_empty((6, L)), stack_empty((9, L)), stack_empty((n, L)))


@njit(cache=True, inline="always")
def tree_newton_euler_lanes(P, flags, QV, WB, RB, PB, MO, FB, EB, BS, TB, nl, small, nb):
    """``tree_rnea_core`` on gathered lanes: the torques into TB (n, B), the joint transforms
    left in RB, PB (bodies nb ..; nb, the caller's constant: 0, or 6 on a floating base's
    virtual tree, whose first six bodies are one free-flyer root joint, as there).
    Scratch: MO each body's (omega, alpha, acc), BS the base's, FB each body's wrench
    (n; f), then its joint wrench; EB the tip wrench [f; m] carried along
    the tip's path; PM (on this stack) a copy of the parent's motion, then of the child's
    wrench carried in: each lane loop then reads rows of one array and writes another's,
    which LLVM sees, and packs the loop (reading and writing rows of MO or FB at offsets
    known only at run time, the inverse dynamics ran 1.6-2x slower: Baxter, Talos, one
    core, 2026-11-28)."""
    n = P.shape[0] - 1
    use_w, use_base = (flags & F.WRENCH) != 0, (flags & F.BASE) != 0
    PM = stack_empty((9, BS.shape[1]))
    for s in range(6):                   # the tip wrench (base frame): w[:6] or 0
        for b in range(nl):
            EB[s, b] = WB[s, b] if use_w else 0.0
    for s in range(9):                   # the base's motion (base_state): BS rows 0..8
        for b in range(nl):
            if use_base:
                BS[s, b] = (WB[W_OMEGA + s, b] if s < 6 else WB[W_ACC + s - 6, b] - P[n, G + s - 6])
            else:
                BS[s, b] = 0.0 if s < 6 else -P[n, G + s - 6]
    if nb > 0:                           # the free-flyer root: its body's motion at once
        k = nb - 1                       # (rnea_lanes.root_body) and its wrench
        rk, fk = 9 * k, 6 * k
        for b in range(nl):
            ((MO[rk, b], MO[rk + 1, b], MO[rk + 2, b], MO[rk + 3, b], MO[rk + 4, b],
              MO[rk + 5, b], MO[rk + 6, b], MO[rk + 7, b], MO[rk + 8, b]),
             (FB[fk, b], FB[fk + 1, b], FB[fk + 2, b], FB[fk + 3, b], FB[fk + 4, b],
              FB[fk + 5, b])) = root_body(P, QV, b, BS[6, b], BS[7, b], BS[8, b])
    for i in range(nb, n):
        lane_transforms(P, i, QV, RB, PB, nl, small)
        l, ri, pi, fi = int(P[i, PARENT]), 9 * i, 3 * i, 6 * i
        for s in range(9):               # the parent's motion, or the base's (a copy: LLVM
            for b in range(nl):          # then sees that MO's rows written below are not read)
                PM[s, b] = MO[9 * l + s, b] if l >= 0 else BS[s, b]
        for b in range(nl):
            r = lane_rotation(RB, ri, b)
            wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(
                r, PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], PM[0, b], PM[1, b], PM[2, b],
                PM[3, b], PM[4, b], PM[5, b], PM[6, b], PM[7, b], PM[8, b])
            wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(P[i, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz,
                                                            QV[n + i, b], QV[2 * n + i, b])
            (MO[ri, b], MO[ri + 1, b], MO[ri + 2, b], MO[ri + 3, b], MO[ri + 4, b],
             MO[ri + 5, b], MO[ri + 6, b], MO[ri + 7, b], MO[ri + 8, b]) = (wx, wy, wz, ax, ay, az,
                                                                          lx, ly, lz)
            (FB[fi, b], FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b], FB[fi + 4, b],
             FB[fi + 5, b]) = body_wrench(P, i, wx, wy, wz, ax, ay, az, lx, ly, lz)
        if use_w and P[i, TIPPATH] != 0.0:             # the tip wrench into frame i
            for b in range(nl):
                r = lane_rotation(RB, ri, b)
                EB[0, b], EB[1, b], EB[2, b] = rotate_t(r, EB[0, b], EB[1, b], EB[2, b])
                EB[3, b], EB[4, b], EB[5, b] = rotate_t(r, EB[3, b], EB[4, b], EB[5, b])
    if use_w:                            # the load -w on the tip's body
        fi = 6 * (n - 1)
        for b in range(nl):
            (FB[fi, b], FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b], FB[fi + 4, b],
             FB[fi + 5, b]) = tip_load(P, n, FB[fi, b], FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b],
                                       FB[fi + 4, b], FB[fi + 5, b], EB[0, b], EB[1, b], EB[2, b],
                                       EB[3, b], EB[4, b], EB[5, b])
    # inward: tau_i = S_i^T f_i;  f_lambda(i) += Xup_i^T f_i
    for i in range(n - 1, nb - 1, -1):
        l, fi, ri, pi = int(P[i, PARENT]), 6 * i, 9 * i, 3 * i
        kind, li = P[i, KIND], 6 * int(P[i, PARENT])
        for b in range(nl):
            TB[i, b] = project(kind, FB[fi + 2, b], FB[fi + 5, b])
        if l >= 0:
            for s in range(6):           # the child's wrench, a copy (as PM above)
                for b in range(nl):
                    PM[s, b] = FB[fi + s, b]
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b], PB[pi + 2, b],
                    PM[0, b], PM[1, b], PM[2, b], PM[3, b], PM[4, b], PM[5, b])
                FB[li, b], FB[li + 1, b] = FB[li, b] + nx, FB[li + 1, b] + ny
                FB[li + 2, b], FB[li + 3, b] = FB[li + 2, b] + nz, FB[li + 3, b] + fx
                FB[li + 4, b], FB[li + 5, b] = FB[li + 4, b] + fy, FB[li + 5, b] + fz
    if nb > 0:                           # the free-flyer's generalized forces: [f; n] on the base
        fk = 6 * (nb - 1)
        for b in range(nl):
            TB[0, b], TB[1, b], TB[2, b] = FB[fk + 3, b], FB[fk + 4, b], FB[fk + 5, b]
            TB[3, b], TB[4, b], TB[5, b] = FB[fk, b], FB[fk + 1, b], FB[fk + 2, b]
    armature_torques_lanes(P, QV, TB, nl, nb)        # tau_i += I_a,i qdd_i


@njit(cache=True, inline="always")
def tree_composite_lanes(P, off, RB, PB, IC, FB, MB, nl, nb):
    """``tree.tree_crba_core`` on lanes whose joint transforms are in RB, PB (bodies nb ..;
    nb, the caller's constant: 0, or 6 on a floating base's virtual tree, whose first six
    bodies are one free-flyer root): M_ij for j = i and i's ancestors into MB row off[i] +
    (steps from i up to j) (the rest of M is zero; ``ancestor_rows``; the root's coordinates
    are the virtual bodies 0-5, a chain). IC (10 n, B) the composite bodies, FB (6, B) the
    carried force: scratch."""
    n = P.shape[0] - 1
    for i in range(n):
        for r in range(10):
            v = P[i, MASS] if r == 0 else (P[i, H + r - 1] if r < 4 else P[i, IO + r - 4])
            for b in range(nl):
                IC[10 * i + r, b] = v
    for i in range(n - 1, nb - 1, -1):
        kind, c = P[i, KIND], 10 * i
        for b in range(nl):              # F = IC_i S_i; M_ii = S_i^T F
            (FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b],
             MB[off[i], b]) = joint_momentum(kind, IC[c, b], IC[c + 1, b], IC[c + 2, b],
                                             IC[c + 8, b], IC[c + 9, b], IC[c + 6, b])
        j, row = i, off[i]
        while P[j, PARENT] >= nb:        # up the ancestors: F = Xup_j^T F, M_ij = S_j^T F
            rj, pj = 9 * j, 3 * j
            j, row = int(P[j, PARENT]), row + 1
            up = P[j, KIND]
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, rj, b), PB[pj, b], PB[pj + 1, b], PB[pj + 2, b],
                    FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b])
                FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b] = nx, ny, nz, fx, fy, fz
                MB[row, b] = project(up, nz, fz)
        if nb > 0:                       # into the base frame: M_root,i = F (v = [v_O, omega]),
            rj, pj = 9 * j, 3 * j        # coordinate 5 (virtual body 5) first up the chain
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, rj, b), PB[pj, b], PB[pj + 1, b], PB[pj + 2, b],
                    FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b])
                MB[row + 1, b], MB[row + 2, b], MB[row + 3, b] = nz, ny, nx
                MB[row + 4, b], MB[row + 5, b], MB[row + 6, b] = fz, fy, fx
        l = int(P[i, PARENT])
        if l >= 0:                       # IC_lambda(i) += Xup_i^T IC_i Xup_i
            ri, pi, d = 9 * i, 3 * i, 10 * l
            for b in range(nl):
                (IC[d, b], IC[d + 1, b], IC[d + 2, b], IC[d + 3, b], IC[d + 4, b], IC[d + 5, b],
                 IC[d + 6, b], IC[d + 7, b], IC[d + 8, b], IC[d + 9, b]) = add_in_parent(
                    IC[d, b], IC[d + 1, b], IC[d + 2, b], IC[d + 3, b], IC[d + 4, b],
                    IC[d + 5, b], IC[d + 6, b], IC[d + 7, b], IC[d + 8, b], IC[d + 9, b],
                    lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b], PB[pi + 2, b],
                    IC[c, b], IC[c + 1, b], IC[c + 2, b], IC[c + 3, b], IC[c + 4, b],
                    IC[c + 5, b], IC[c + 6, b], IC[c + 7, b], IC[c + 8, b], IC[c + 9, b])
    if nb > 0:                           # the root's block: IC of everything, base frame
        root_block_lanes(off, IC, 10 * (nb - 1), MB, nl)
    if has_armature(P):  # M_ii += I_a,i (joint.armature_diagonal)
        for i in range(nb, n):
            arm = P[i, ARM]
            for b in range(nl):
                MB[off[i], b] += arm


@njit(cache=True, inline="always")
def root_block_lanes(off, IC, c, MB, nl):
    """``crba.root_block`` in every lane from the composite body at IC rows c ..: M_rs
    (r <= s < 6, the virtual chain's coordinates) into MB row off[s] + s - r."""
    for s in range(6):
        for r in range(s + 1):
            for b in range(nl):
                MB[off[s] + s - r, b] = 0.0
    for b in range(nl):
        m, hx, hy, hz = IC[c, b], IC[c + 1, b], IC[c + 2, b], IC[c + 3, b]
        MB[off[0], b] = MB[off[1], b] = MB[off[2], b] = m
        MB[off[4] + 4, b], MB[off[5] + 5, b] = hz, -hy          # (0, 4), (0, 5)
        MB[off[3] + 2, b], MB[off[5] + 4, b] = -hz, hx          # (1, 3), (1, 5)
        MB[off[3] + 1, b], MB[off[4] + 2, b] = hy, -hx          # (2, 3), (2, 4)
        MB[off[3], b], MB[off[4], b], MB[off[5], b] = IC[c + 4, b], IC[c + 5, b], IC[c + 6, b]
        MB[off[4] + 1, b] = IC[c + 7, b]                        # (3, 4): I_xy
        MB[off[5] + 2, b], MB[off[5] + 1, b] = IC[c + 8, b], IC[c + 9, b]   # (3, 5), (4, 5)


@njit(cache=True, inline="always")
def _scatter_tree_matrix(P, off, MB, out, k0, nl):
    """M of each lane into out[k0 + b]: the ancestor entries from MB, zero elsewhere."""
    n = P.shape[0] - 1
    for b in range(nl):
        for i in range(n):
            for j in range(n):
                out[k0 + b, i, j] = 0.0
        for i in range(n):
            j, row = i, off[i]
            while j >= 0:
                out[k0 + b, i, j] = out[k0 + b, j, i] = MB[row, b]
                j, row = int(P[j, PARENT]), row + 1


@njit(cache=True, inline="always")
def ancestor_rows(P):
    """(off, dep, rows): body i's depth dep[i] (0 at a root) and the first of its rows in
    the lanes' sparse M, off[i]: row off[i] + dep[i] - dep[j] holds M_ij for j = i and each
    of i's ancestors (sum of depths + n rows in all, against n^2 dense)."""
    n = P.shape[0] - 1
    off, dep = np.empty(n, np.int64), np.empty(n, np.int64)
    rows = 0
    for i in range(n):
        l = int(P[i, PARENT])
        dep[i] = 0 if l < 0 else dep[l] + 1
        off[i] = rows
        rows += dep[i] + 1
    return off, dep, rows


@internal(i8(Pm, In2, Out3, i8))
def tree_crba_block(P, q, out, k0):
    """Mass matrices of the samples k0 .. k0 + B - 1 of a fixed-base tree into the same rows
    of ``out``; 1 if one of them has a NaN/Inf angle, else 0. (A floating base's tree runs
    its mass matrices one state at a time: in lanes with the free-flyer root they measured
    1.2x slower on Solo12 and the same on Talos, 2026-11-29; the dense output's writes
    dominate.)"""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])
    nl = min(L, N - k0)
    QV, WB = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L))
    RB, PB = stack_empty((9 * n, L)), stack_empty((3 * n, L))
    off, dep, rows = ancestor_rows(P)
    IC, FB, MB = stack_empty((10 * n, L)), stack_empty((6, L)), stack_empty((rows, L))
    small, fin = gather(P, q, q, q, q, 0, QV, WB, k0, nl)
    for i in range(n):
        lane_transforms(P, i, QV, RB, PB, nl, small)
    tree_composite_lanes(P, off, RB, PB, IC, FB, MB, nl, 0)
    _scatter_tree_matrix(P, off, MB, out, k0, nl)
    return OK if fin else NOT_FINITE


@njit(cache=True, inline="always")
def ltdl_lanes(P, off, dep, MB, XB, AB, nl):
    """x <- M^-1 x in every lane by ``cholesky.ltdl_factor`` and ``ltdl_solve_factored``'s
    operations: MB holds M_ij (j = i and its ancestors) in row off[i] + dep[i] - dep[j]
    (``ancestor_rows``) and receives the factor there; XB (n, B) the right-hand sides; AB
    (1, B) scratch."""
    n = P.shape[0] - 1
    for k in range(n - 1, -1, -1):       # M = L^T D L, from the leaves
        i = int(P[k, PARENT])
        while i >= 0:
            ki, kk = off[k] + dep[k] - dep[i], off[k]
            for b in range(nl):
                AB[0, b] = MB[ki, b] / MB[kk, b]         # L_ki = M_ki / D_k
            j = i
            while j >= 0:                # M_ij -= M_kj L_ki (M_ki itself as it was)
                ij, kj = off[i] + dep[i] - dep[j], off[k] + dep[k] - dep[j]
                for b in range(nl):
                    MB[ij, b] -= MB[kj, b] * AB[0, b]
                j = int(P[j, PARENT])
            for b in range(nl):
                MB[ki, b] = AB[0, b]
            i = int(P[i, PARENT])
    for i in range(n - 1, -1, -1):       # L^T z = x
        j = int(P[i, PARENT])
        while j >= 0:
            ij = off[i] + dep[i] - dep[j]
            for b in range(nl):
                XB[j, b] -= MB[ij, b] * XB[i, b]
            j = int(P[j, PARENT])
    for i in range(n):
        for b in range(nl):
            XB[i, b] /= MB[off[i], b]
    for i in range(n):                   # L x = z
        j = int(P[i, PARENT])
        while j >= 0:
            ij = off[i] + dep[i] - dep[j]
            for b in range(nl):
                XB[i, b] -= MB[ij, b] * XB[j, b]
            j = int(P[j, PARENT])


@njit(cache=True, inline="always")
def tree_fd_lanes_block(P, q, qd, tau, w, flags, out, k0, nb):
    """``tree.tree_fd_core`` of the samples k0 .. k0 + B - 1 into the same rows of ``out``
    (``fd_lanes``; nb: 0, or 6 on a floating base's virtual tree). Returns 1 on a NaN/Inf
    input, else 0."""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])
    QV, WB, RB, PB, MO, FB, EB, BS, TB = tree_scratch(n, L)
    off, dep, rows = ancestor_rows(P)
    IC, MB = stack_empty((10 * n, L)), stack_empty((rows, L))   # rows <= n (n + 1) / 2: it fits
    fin = fd_lanes(P, off, dep, QV, WB, RB, PB, MO, FB, EB, BS, TB, IC, MB, q, qd, tau, w,
                   flags & (F.QD | F.WRENCH | F.BASE), k0, min(L, N - k0), out, nb)
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def tree_fd_block(P, q, qd, tau, w, flags, out, k0):
    """``tree_fd_lanes_block`` on a fixed base."""
    return tree_fd_lanes_block(P, q, qd, tau, w, flags, out, k0, 0)


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def floating_tree_fd_block(P, q, qd, tau, w, flags, out, k0):
    """``tree_fd_lanes_block`` on a floating base's virtual tree (``P[n, ROOT]`` = 6)."""
    return tree_fd_lanes_block(P, q, qd, tau, w, flags, out, k0, 6)


@njit(cache=True, inline="always")
def fd_lanes(P, off, dep, QV, WB, RB, PB, MO, FB, EB, BS, TB, IC, MB, q, qd, tau, w, flags, k0,
             nl, qdd, nb):
    """``tree.tree_fd_core`` on the states k0 .. k0 + nl - 1, lane by lane (the scratch of
    ``tree_scratch``, IC (10 n, B), MB (rows of ``ancestor_rows``, B)): b by Newton-Euler
    at qdd = 0, x = tau - b, M on the same transforms, its sparse factor (left in MB) and
    solves; qdd into the same rows of ``qdd``. Returns whether every input was finite."""
    small, fin = gather(P, q, qd, q, w, flags, QV, WB, k0, nl)
    tree_newton_euler_lanes(P, flags, QV, WB, RB, PB, MO, FB, EB, BS, TB, nl, small, nb)
    fin = tau_minus_bias(tau, TB, k0, nl, fin)
    tree_composite_lanes(P, off, RB, PB, IC, FB, MB, nl, nb)
    ltdl_lanes(P, off, dep, MB, TB, BS, nl)
    scatter(TB, qdd, k0, nl)
    return fin


@njit(cache=True, inline="always")
def factor(P, off, MB, b, MF):
    """Lane b's sparse factor (or M) from MB into the entries of MF the solves read: each
    i's row at i and its ancestors."""
    for i in range(P.shape[0] - 1):
        j, r = i, off[i]
        while j >= 0:
            MF[i, j] = MB[r, b]
            j, r = int(P[j, PARENT]), r + 1
