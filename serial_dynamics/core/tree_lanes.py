"""Inverse dynamics of a batch on a fixed-base kinematic tree, compiled: B samples at a time
in SIMD lanes (``rnea_lanes.py``'s layout: every quantity (rows, B), the lane innermost).

``tree.tree_rnea_core``'s steps, called lane by lane on the lanes' rows: ``into_body`` and
``joint_rate`` from the parent's motion (kept per body, MO, as ``mo`` there), ``body_wrench``,
the tip wrench carried along the tip's path and ``tip_load`` on the last body, then
``force_to_parent`` summed into each parent, children in descending order as there. A lane
computes exactly what ``tree_rnea_core`` computes for its sample, so a sample's torques are
bitwise the same alone or in any batch.
"""
from . import flags as F
from .crba_lanes import lane_rotation
from .data import stack_empty
from .layout import ARM, G, KIND, LANES, PARENT, TIPPATH, W_ACC, W_ALL, W_OMEGA
from .rnea import body_wrench, into_body, joint_rate, tip_load
from .rnea_lanes import gather, lane_transforms
from .signatures import In2, Out2, Pm, i8, internal
from .spatial import force_to_parent, rotate_t
from .status import NOT_FINITE, OK


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def tree_rnea_block(P, q, qd, qdd, w, flags, out, k0):
    """Inverse dynamics of the samples k0 .. k0 + B - 1 of a fixed-base tree (fewer at the
    batch's end) into the same rows of ``out``. Returns 1 if one of them has a NaN/Inf
    input, else 0. Lanes' scratch: QV, WB as ``rnea_block``'s; RB, PB the joint transforms;
    MO each body's (omega, alpha, acc), BS the base's, FB its wrench (n; f), then its joint wrench; EB
    the tip wrench [f; m] carried along the tip's path."""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])
    nl = min(L, N - k0)
    QV, WB = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L))
    RB, PB = stack_empty((9 * n, L)), stack_empty((3 * n, L))
    MO, FB, EB = stack_empty((9 * n, L)), stack_empty((6 * n, L)), stack_empty((6, L))
    BS = stack_empty((9, L))
    small, fin = gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl)
    use_w, use_base = (flags & F.WRENCH) != 0, (flags & F.BASE) != 0
    for s in range(6):                   # the tip wrench (base frame): w[:6] or 0
        for b in range(nl):
            EB[s, b] = WB[s, b] if use_w else 0.0
    for s in range(9):                   # the base's motion (base_state): BS rows 0..8
        for b in range(nl):
            if use_base:
                BS[s, b] = (WB[W_OMEGA + s, b] if s < 6 else WB[W_ACC + s - 6, b] - P[n, G + s - 6])
            else:
                BS[s, b] = 0.0 if s < 6 else -P[n, G + s - 6]
    for i in range(n):
        lane_transforms(P, i, QV, RB, PB, nl, small)
        l, ri, pi, fi = int(P[i, PARENT]), 9 * i, 3 * i, 6 * i
        S, si = (MO, 9 * l) if l >= 0 else (BS, 0)       # the parent's motion, or the base's
        for b in range(nl):
            r = lane_rotation(RB, ri, b)
            wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(
                r, PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], S[si, b], S[si + 1, b], S[si + 2, b],
                S[si + 3, b], S[si + 4, b], S[si + 5, b], S[si + 6, b], S[si + 7, b], S[si + 8, b])
            wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(P, i, wx, wy, wz, ax, ay, az, lx, ly, lz,
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
    # inward: tau_i = S_i^T f_i + I_a,i qdd_i;  f_lambda(i) += Xup_i^T f_i
    for i in range(n - 1, -1, -1):
        l, fi, ri, pi = int(P[i, PARENT]), 6 * i, 9 * i, 3 * i
        rev, arm, li = P[i, KIND] == 0.0, P[i, ARM], 6 * int(P[i, PARENT])
        for b in range(nl):
            out[k0 + b, i] = (FB[fi + 2, b] if rev else FB[fi + 5, b]) + arm * QV[2 * n + i, b]
        if l >= 0:
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, ri, b), PB[pi, b], PB[pi + 1, b], PB[pi + 2, b],
                    FB[fi, b], FB[fi + 1, b], FB[fi + 2, b], FB[fi + 3, b], FB[fi + 4, b], FB[fi + 5, b])
                FB[li, b], FB[li + 1, b], FB[li + 2, b] = FB[li, b] + nx, FB[li + 1, b] + ny, FB[li + 2, b] + nz
                FB[li + 3, b], FB[li + 4, b], FB[li + 5, b] = FB[li + 3, b] + fx, FB[li + 4, b] + fy, FB[li + 5, b] + fz
    return OK if fin else NOT_FINITE
