"""Mass matrices of a batch, compiled: B samples at a time in SIMD lanes.

``crba.py``'s algorithm and steps (``add_in_parent``, ``force_to_parent``), called lane by
lane on the lanes' rows, as ``rnea_lanes.py`` does for Newton-Euler: every quantity is
stored with the sample index (lane) last, shape (rows, B), each loop over the lanes is
innermost and branch-free (the joint kind, the same in every lane, picks by selects), so
that it vectorizes; a lane computes exactly what ``crba_core`` computes for its sample
(same operations in the same order, the transforms of ``rnea_lanes.lane_transforms``), so
a sample's M is bitwise the same alone or in any batch.
"""
from numba import njit

from .crba import add_in_parent, crba_core, floating_crba_core
from .joint import has_armature, joint_momentum, joint_transforms, lane_transforms, project
from .layout import ARM, H, IO, KIND, LANES, MASS, W_ALL
from .data import new_kin, square_lanes_fit, stack_empty
from .rnea_lanes import gather
from .signatures import In2, Out3, Pm, i8, internal
from .spatial import force_to_parent
from .status import NOT_FINITE, OK


@njit(cache=True, inline="always")
def lane_rotation(RB, ri, b):
    """Lane b's rotation at rows ri .. ri + 8 of RB, as ``spatial.rotation``'s tuple."""
    return (RB[ri, b], RB[ri + 1, b], RB[ri + 2, b], RB[ri + 3, b], RB[ri + 4, b],
            RB[ri + 5, b], RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b])


@njit(cache=True, inline="always")
def composite_block(P, q, out, k0, first, composite):
    """Mass matrices of the samples k0 .. k0 + B - 1 (fewer at the batch's end) into the
    same rows of ``out``; 1 if one of them has a NaN/Inf angle, else 0. Lanes' scratch
    (rows, B) on the stack (``crba_batch`` calls it only where it fits): QV angles (and the
    small-angle mask), RB, PB the joint transforms, CB the composite's ten parameters (m, h,
    I_O: xx yy zz xy xz yz), FB the carried force (n; f), MB the matrix (n * n rows)."""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])                 # lanes (= B), read at run time on purpose
    nl = min(L, N - k0)
    QV, WB = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L))
    RB, PB = stack_empty((9 * n, L)), stack_empty((3 * n, L))
    CB, FB, MB = stack_empty((10, L)), stack_empty((6, L)), stack_empty((n * n, L))
    small, fin = gather(P, q, q, q, q, 0, QV, WB, k0, nl)
    for i in range(first, n):
        lane_transforms(P, i, QV, RB, PB, nl, small)
    composite(P, RB, PB, CB, FB, MB, nl)
    for b in range(nl):                  # scatter, M symmetric
        for i in range(n):
            for j in range(i, n):
                out[k0 + b, i, j] = out[k0 + b, j, i] = MB[i * n + j, b]
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, Out3, i8))
def crba_block(P, q, out, k0):
    """``composite_block`` on a fixed base (``crba.crba_core`` in every lane)."""
    return composite_block(P, q, out, k0, 0, composite_lanes)


@internal(i8(Pm, In2, Out3, i8))
def floating_crba_block(P, q, out, k0):
    """``composite_block`` with a free-flyer root (``crba.floating_crba_core`` in every lane)."""
    return composite_block(P, q, out, k0, 6, floating_composite_lanes)


@njit(cache=True, inline="always")
def composite_lanes(P, RB, PB, CB, FB, MB, nl):
    """``crba_core`` on lanes whose joint transforms are in RB, PB: M's upper triangle
    into MB (row i * n + j holds M_ij, j >= i); CB, FB scratch (10, B), (6, B)."""
    n = P.shape[0] - 1
    k = n - 1                            # composite n-1: body n-1
    for r in range(10):
        v = P[k, MASS] if r == 0 else (P[k, H + r - 1] if r < 4 else P[k, IO + r - 4])
        for b in range(nl):
            CB[r, b] = v
    for i in range(n - 1, -1, -1):
        kind = P[i, KIND]                # (the same in every lane: selects, joint.py)
        for b in range(nl):              # F = IC_i S_i, M_ii = S_i^T F
            (FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b],
             MB[i * n + i, b]) = joint_momentum(kind, CB[0, b], CB[1, b], CB[2, b], CB[8, b],
                                                CB[9, b], CB[6, b])
        for j in range(i, 1, -1):        # F = Xup_j^T F, M_(j-1)i = S_(j-1)^T F
            rj, pj = 9 * j, 3 * j
            up = P[j - 1, KIND]
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, rj, b), PB[pj, b], PB[pj + 1, b], PB[pj + 2, b],
                    FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b])
                FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b] = nx, ny, nz, fx, fy, fz
                MB[(j - 1) * n + i, b] = project(up, nz, fz)
        if i == 0:
            break
        kind0 = P[0, KIND]               # the last step, into body 0: the z rows of Xup_1^T F
        for b in range(nl):
            nx, ny, nz, fx, fy, fz = FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b]
            gx = RB[9, b] * fx + RB[10, b] * fy + RB[11, b] * fz
            gy = RB[12, b] * fx + RB[13, b] * fy + RB[14, b] * fz
            MB[i, b] = project(kind0, RB[15, b] * nx + RB[16, b] * ny + RB[17, b] * nz + PB[3, b] * gy
                               - PB[4, b] * gx, RB[15, b] * fx + RB[16, b] * fy + RB[17, b] * fz)
        if i == 1:                       # of composite 0 only S_0^T IC_0 S_0
            for b in range(nl):
                m, hx, hy, hz = CB[0, b], CB[1, b], CB[2, b], CB[3, b]
                Ixx, Iyy, Izz, Ixy, Ixz, Iyz = CB[4, b], CB[5, b], CB[6, b], CB[7, b], CB[8, b], CB[9, b]
                r6, r7, r8 = RB[15, b], RB[16, b], RB[17, b]
                px, py = PB[3, b], PB[4, b]
                gx = RB[9, b] * hx + RB[10, b] * hy + RB[11, b] * hz
                gy = RB[12, b] * hx + RB[13, b] * hy + RB[14, b] * hz
                t6 = r6 * Ixx + r7 * Ixy + r8 * Ixz
                t7 = r6 * Ixy + r7 * Iyy + r8 * Iyz
                t8 = r6 * Ixz + r7 * Iyz + r8 * Izz
                d = 2.0 * (gx * px + gy * py) + m * (px * px + py * py)
                MB[0, b] = project(kind0, P[0, IO + 2] + t6 * r6 + t7 * r7 + t8 * r8 + d,
                                   P[0, MASS] + m)
            break
        k, ri, pi = i - 1, 9 * i, 3 * i  # composite i-1 = body i-1 + composite i in frame i-1
        for b in range(nl):
            (CB[0, b], CB[1, b], CB[2, b], CB[3, b], CB[4, b], CB[5, b], CB[6, b], CB[7, b],
             CB[8, b], CB[9, b]) = add_in_parent(
                P[k, MASS], P[k, H], P[k, H + 1], P[k, H + 2], P[k, IO], P[k, IO + 1],
                P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5], lane_rotation(RB, ri, b),
                PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], CB[0, b], CB[1, b], CB[2, b], CB[3, b],
                CB[4, b], CB[5, b], CB[6, b], CB[7, b], CB[8, b], CB[9, b])
    armature_lanes(P, MB, nl, 0)         # M_ii += I_a,i


@njit(cache=True, inline="always")
def floating_composite_lanes(P, RB, PB, CB, FB, MB, nl):
    """``crba.floating_crba_core`` on lanes (``composite_lanes``' layout and scratch): a
    floating base's virtual chain, its first six bodies one free-flyer root joint."""
    n, nb = P.shape[0] - 1, 6
    k = n - 1                            # composite n-1: body n-1
    for r in range(10):
        v = P[k, MASS] if r == 0 else (P[k, H + r - 1] if r < 4 else P[k, IO + r - 4])
        for b in range(nl):
            CB[r, b] = v
    for i in range(n - 1, nb - 1, -1):
        kind = P[i, KIND]
        for b in range(nl):              # F = IC_i S_i, M_ii = S_i^T F
            (FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b],
             MB[i * n + i, b]) = joint_momentum(kind, CB[0, b], CB[1, b], CB[2, b], CB[8, b],
                                                CB[9, b], CB[6, b])
        for j in range(i, nb, -1):       # F = Xup_j^T F, M_(j-1)i = S_(j-1)^T F
            rj, pj = 9 * j, 3 * j
            up = P[j - 1, KIND]
            for b in range(nl):
                nx, ny, nz, fx, fy, fz = force_to_parent(
                    lane_rotation(RB, rj, b), PB[pj, b], PB[pj + 1, b], PB[pj + 2, b],
                    FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b])
                FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b] = nx, ny, nz, fx, fy, fz
                MB[(j - 1) * n + i, b] = project(up, nz, fz)
        rj, pj = 9 * nb, 3 * nb          # into the base frame: M_root,i = F
        for b in range(nl):
            nx, ny, nz, fx, fy, fz = force_to_parent(
                lane_rotation(RB, rj, b), PB[pj, b], PB[pj + 1, b], PB[pj + 2, b],
                FB[0, b], FB[1, b], FB[2, b], FB[3, b], FB[4, b], FB[5, b])
            MB[i, b], MB[n + i, b], MB[2 * n + i, b] = fx, fy, fz
            MB[3 * n + i, b], MB[4 * n + i, b], MB[5 * n + i, b] = nx, ny, nz
        k, ri, pi = i - 1, 9 * i, 3 * i  # composite i-1 = body i-1 + composite i in frame i-1
        for b in range(nl):
            (CB[0, b], CB[1, b], CB[2, b], CB[3, b], CB[4, b], CB[5, b], CB[6, b], CB[7, b],
             CB[8, b], CB[9, b]) = add_in_parent(
                P[k, MASS], P[k, H], P[k, H + 1], P[k, H + 2], P[k, IO], P[k, IO + 1],
                P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5], lane_rotation(RB, ri, b),
                PB[pi, b], PB[pi + 1, b], PB[pi + 2, b], CB[0, b], CB[1, b], CB[2, b], CB[3, b],
                CB[4, b], CB[5, b], CB[6, b], CB[7, b], CB[8, b], CB[9, b])
    for r in range(6):                   # composite nb-1, the whole robot: M's root block
        for c in range(r, 6):            # (crba.root_block; M_rc in row r n + c, c >= r)
            for b in range(nl):
                MB[r * n + c, b] = 0.0
    for b in range(nl):
        m, hx, hy, hz = CB[0, b], CB[1, b], CB[2, b], CB[3, b]
        MB[0, b] = MB[n + 1, b] = MB[2 * n + 2, b] = m
        MB[4, b], MB[5, b] = hz, -hy
        MB[n + 3, b], MB[n + 5, b] = -hz, hx
        MB[2 * n + 3, b], MB[2 * n + 4, b] = hy, -hx
        MB[3 * n + 3, b], MB[4 * n + 4, b], MB[5 * n + 5, b] = CB[4, b], CB[5, b], CB[6, b]
        MB[3 * n + 4, b], MB[3 * n + 5, b], MB[4 * n + 5, b] = CB[7, b], CB[8, b], CB[9, b]
    armature_lanes(P, MB, nl, nb)


@njit(cache=True, inline="always")
def armature_lanes(P, MB, nl, first):
    """``joint.armature_diagonal`` in every lane: M_ii += I_a,i after the pass (MB row i n + i)."""
    n = P.shape[0] - 1
    if has_armature(P):
        for i in range(first, n):
            arm = P[i, ARM]
            for b in range(nl):
                MB[i * n + i, b] += arm


@njit(cache=True, inline="always")
def batch(P, q, out, block, one, first):
    """Mass matrices (N, n, n) of N configurations (N, n), B at a time in lanes (``block``; a
    chain too long for the lanes' stack, ``data.square_lanes_fit``, one at a time by
    ``one`` on the transforms from joint ``first`` on). Returns OK, or NOT_FINITE on a
    NaN/Inf. The kernels are the caller's: a fixed base's or a floating one's."""
    n = P.shape[0] - 1
    L = int(P[n, LANES])
    bad = OK
    if not square_lanes_fit(n, L):
        d = new_kin(n)
        for k in range(q.shape[0]):
            if joint_transforms(P, d.sc, d.R, d.p, q[k], n, first) != 0.0:
                bad = NOT_FINITE
            one(P, d.R, d.p, out[k])
        return bad
    for k0 in range(0, out.shape[0], L):
        bad |= block(P, q, out, k0)
    return bad


def crba_batch(P, q, out):
    """``batch`` on a fixed base."""
    return batch(P, q, out, crba_block, crba_core, 0)


def floating_crba_batch(P, q, out):
    """``batch`` on a floating base's virtual chain: the free-flyer root's kernels."""
    return batch(P, q, out, floating_crba_block, floating_crba_core, 6)
