"""Inverse dynamics of a batch, compiled: B samples at a time in SIMD lanes.

A batch shares one kinematic structure, so B samples can run in lock step: every
quantity is stored with the sample index (lane) last, shape (rows, B), and each step is a
loop over the lanes that the compiler turns into vector instructions (AVX: 4 or 8 lanes).
The lane count is read at run time (from P): LLVM vectorizes such loops with run-time
overlap checks between the arrays, which it cannot do once it has unrolled a loop of
known length. The steps are ``rnea.py``'s and ``joint.py``'s own (``into_body``,
``joint_rate``, ``rigid_wrench``, ``project``), called lane by lane on the lanes' rows, with
what a body or joint reads from ``P`` read once before its loop; every lane computes
exactly what ``rnea_core`` computes for its sample (same operations in the same order;
libm's sine and cosine for a sample with an angle beyond SMALL_ANGLE, as there), so a
sample's torques are bitwise the same alone or in any batch, at any place in it.
"""
from numba import njit

from . import flags as F
from .data import stack_empty
from .joint import armature_torques_lanes, free_flyer, joint_rate, lane_transforms, project
from .layout import G, KIND, LANES, TIPP, W_ACC, W_ALL
from .rnea import body_wrench, inertia, into_body, rigid_wrench, w_length
from .status import NOT_FINITE, OK
from .signatures import In2, Out2, Pm, i8, internal
from .spatial import SMALL_ANGLE


@njit(cache=True, inline="always")
def gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl):
    """The samples k0 .. k0 + nl - 1 into lanes: QV rows q, qd, qdd (0 where flag QD, QDD is
    off), then 1.0 where all of a sample's angles are below SMALL_ANGLE; WB the external
    inputs w. Returns (all angles small, every input finite)."""
    n = P.shape[0] - 1
    nq, nv, na, nw = q.shape[0] > 1, qd.shape[0] > 1, qdd.shape[0] > 1, w.shape[0] > 1
    use_qd, use_qdd = (flags & F.QD) != 0, (flags & F.QDD) != 0
    small = True                         # every angle of the block below SMALL_ANGLE
    fin = True                           # every rate, acceleration and wrench finite
    for b in range(nl):
        k = k0 + b
        lane_small = True
        for i in range(n):
            x = q[k if nq else 0, i]
            y = qd[k if nv else 0, i] if use_qd else 0.0
            z = qdd[k if na else 0, i] if use_qdd else 0.0
            QV[i, b], QV[n + i, b], QV[2 * n + i, b] = x, y, z
            lane_small &= abs(x) < SMALL_ANGLE
            fin &= y * 0.0 == 0.0 and z * 0.0 == 0.0
        QV[3 * n, b] = 1.0 if lane_small else 0.0
        small &= lane_small
        if (flags & (F.WRENCH | F.BASE)) != 0:
            for j in range(w_length(flags)):
                x = w[k if nw else 0, j]
                WB[j, b] = x
                fin &= x * 0.0 == 0.0
    if not small:                        # a huge angle is legal; NaN or Inf is not
        for b in range(nl):
            for i in range(n):
                fin &= QV[i, b] * 0.0 == 0.0
    return small, fin


@njit(cache=True, inline="always")
def lanes_block(P, q, qd, qdd, w, flags, out, k0, first, root):
    """Inverse dynamics of the samples k0 .. k0 + B - 1 of the batch (fewer at its end), in
    lock step, into the same rows of ``out``. Returns 1 if one of them has a NaN/Inf
    input, else 0. The lanes' scratch is on this function's stack, shape (rows, B), each
    written before it is read: QV rows q, qd, qdd, then a mask of the samples whose angles
    are all below SMALL_ANGLE (the others get libm's sine and cosine, as in
    ``joint_transforms``); WB tip wrenches (base frame); RB rotations, PB translations,
    FB body wrenches; ST the state (omega, alpha, acc, then the wrench force and moment);
    TB torques. Every lane loop is innermost and branch-free (the joint kind, the same in
    every lane, picks values by selects), so that it vectorizes."""
    N = out.shape[0]
    n = P.shape[0] - 1
    L = int(P[n, LANES])                 # lanes (= B), read at run time on purpose
    nl = min(L, N - k0)
    QV, WB, TB, ST, RB, PB, FB = lanes_scratch(n, L)
    small, fin = gather(P, q, qd, qdd, w, flags, QV, WB, k0, nl)
    newton_euler_lanes(P, flags, QV, WB, RB, PB, FB, ST, TB, nl, small, first, root)
    scatter(TB, out, k0, nl)
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def rnea_block(P, q, qd, qdd, w, flags, out, k0):
    """``lanes_block`` on a fixed base (``rnea.rnea_core`` in every lane)."""
    return lanes_block(P, q, qd, qdd, w, flags, out, k0, 0, fixed_base)


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def floating_rnea_block(P, q, qd, qdd, w, flags, out, k0):
    """``lanes_block`` with a free-flyer root (``rnea.floating_rnea_core`` in every lane)."""
    return lanes_block(P, q, qd, qdd, w, flags, out, k0, 6, free_flyer_root)


@njit(cache=True, inline="always")
def lanes_scratch(n, L):
    """The lanes' scratch of ``rnea_block`` on the caller's stack (22 n + 30 rows of B: 1.1 MB
    at n = 200; on the stack, LLVM sees they cannot overlap and packs the loops without
    run-time checks): QV, WB, TB, ST, RB, PB, FB."""
    return (stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L)), stack_empty((n, L)),
            stack_empty((15, L)), stack_empty((9 * n, L)), stack_empty((3 * n, L)),
            stack_empty((6 * n, L)))


@njit(cache=True, inline="always")
def scatter(TB, out, k0, nl):
    """Lane b's results (TB rows) into row k0 + b of ``out``."""
    for b in range(nl):
        for i in range(TB.shape[0]):
            out[k0 + b, i] = TB[i, b]


@njit(cache=True, inline="always")
def tau_minus_bias(tau, TB, k0, nl, fin):
    """x = tau - b in every lane (TB holds b, then x; a row of tau broadcasts); ``fin``
    and-ed with tau's being finite."""
    nt = tau.shape[0] > 1
    for i in range(TB.shape[0]):
        for b in range(nl):
            x = tau[k0 + b if nt else 0, i]
            fin &= x * 0.0 == 0.0
            TB[i, b] = x - TB[i, b]
    return fin


@njit(cache=True, inline="always")
def newton_euler_lanes(P, flags, QV, WB, RB, PB, FB, ST, TB, nl, small, first, root):
    """The recursions of ``rnea_block`` on gathered lanes: the torques into TB (n, B),
    the joint transforms left in RB, PB (scratch as there), from body ``first`` on, ``root``
    the caller's root joint: ``fixed_base`` (first 0), or ``free_flyer_root`` (first 6)."""
    n = P.shape[0] - 1
    use_w, use_base = (flags & F.WRENCH) != 0, (flags & F.BASE) != 0
    for k in range(15):          # omega = alpha = 0, a = -g; moving base: WB[6:15] - (0, 0, g)
        v = -P[n, G + k - 6] if 6 <= k < 9 else 0.0
        for b in range(nl):
            if k < 9:
                ST[k, b] = (WB[W_ACC + k - 6, b] - P[n, G + k - 6] if k >= 6 else WB[6 + k, b]) if use_base else v
            else:
                ST[k, b] = WB[k - 9, b] if use_w else 0.0
    root(P, QV, RB, PB, FB, ST, TB, nl, False)   # a floating base's root joint: its motion
    for i in range(first, n):
        ri, pi, fi = 9 * i, 3 * i, 6 * i
        kind = P[i, KIND]                # the same in every lane: selects, not branches
        lane_transforms(P, i, QV, RB, PB, nl, small)
        # carry omega, alpha, a into body i, add the joint rates
        for b in range(nl):
            r0, r1, r2 = RB[ri, b], RB[ri + 1, b], RB[ri + 2, b]
            r3, r4, r5 = RB[ri + 3, b], RB[ri + 4, b], RB[ri + 5, b]
            r6, r7, r8 = RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b]
            px, py, pz = PB[pi, b], PB[pi + 1, b], PB[pi + 2, b]
            wx, wy, wz = ST[0, b], ST[1, b], ST[2, b]
            ax, ay, az = ST[3, b], ST[4, b], ST[5, b]
            # the parent's motion into body i, then the joint's rate (rnea.outward_step's steps)
            wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(
                (r0, r1, r2, r3, r4, r5, r6, r7, r8), px, py, pz, wx, wy, wz, ax, ay, az,
                ST[6, b], ST[7, b], ST[8, b])
            (ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b], ST[6, b], ST[7, b],
             ST[8, b]) = joint_rate(kind, wx, wy, wz, ax, ay, az, lx, ly, lz, QV[n + i, b],
                                    QV[2 * n + i, b])
        I10 = inertia(P, i)              # the body wrench about its origin (rnea.body_wrench)
        for b in range(nl):
            (FB[fi + 3, b], FB[fi + 4, b], FB[fi + 5, b], FB[fi, b], FB[fi + 1, b],
             FB[fi + 2, b]) = rigid_wrench(I10, ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b],
                                           ST[5, b], ST[6, b], ST[7, b], ST[8, b])
        if use_w:                        # the tip wrench, carried into body i
            for b in range(nl):
                r0, r1, r2 = RB[ri, b], RB[ri + 1, b], RB[ri + 2, b]
                r3, r4, r5 = RB[ri + 3, b], RB[ri + 4, b], RB[ri + 5, b]
                r6, r7, r8 = RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b]
                x, y, z = ST[9, b], ST[10, b], ST[11, b]
                ST[9, b], ST[10, b], ST[11, b] = (r0 * x + r3 * y + r6 * z, r1 * x + r4 * y + r7 * z,
                                                  r2 * x + r5 * y + r8 * z)
                x, y, z = ST[12, b], ST[13, b], ST[14, b]
                ST[12, b], ST[13, b], ST[14, b] = (r0 * x + r3 * y + r6 * z, r1 * x + r4 * y + r7 * z,
                                                   r2 * x + r5 * y + r8 * z)
    # inward recursion (ST rows 0..5: f, m); the tip load -w acts on the environment
    tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
    fi = 6 * (n - 1)
    kind = P[n - 1, KIND]
    for b in range(nl):
        fx, fy, fz = FB[fi, b] - ST[9, b], FB[fi + 1, b] - ST[10, b], FB[fi + 2, b] - ST[11, b]
        mx = FB[fi + 3, b] - ST[12, b] - tpy * ST[11, b] + tpz * ST[10, b]
        my = FB[fi + 4, b] - ST[13, b] - tpz * ST[9, b] + tpx * ST[11, b]
        mz = FB[fi + 5, b] - ST[14, b] - tpx * ST[10, b] + tpy * ST[9, b]
        ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = fx, fy, fz, mx, my, mz
        TB[n - 1, b] = project(kind, mz, fz)                   # S_i^T (n; f)
    for i in range(n - 2, first - 1, -1):
        kind = P[i, KIND]
        for b in range(nl):
            fx, fy, fz, mx, my, mz = carry_in(RB, PB, FB, ST, i, b)
            ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = fx, fy, fz, mx, my, mz
            TB[i, b] = project(kind, mz, fz)
    armature_torques_lanes(P, QV, TB, nl, first)     # tau_i += I_a,i qdd_i
    root(P, QV, RB, PB, FB, ST, TB, nl, True)    # and its generalized forces


@njit(cache=True, inline="always")
def fixed_base(P, QV, RB, PB, FB, ST, TB, nl, end):
    """``newton_euler_lanes``' root joint on a fixed base: none."""
    return 0


@njit(cache=True, inline="always")
def free_flyer_root(P, QV, RB, PB, FB, ST, TB, nl, end):
    """``newton_euler_lanes``' root joint on a floating base's virtual chain, bodies 0-5 as one
    free-flyer (``rnea.newton_euler``'s nb = 6): before the outward pass (``end`` False) the
    root body's motion into ST and its wrench into FB (``root_body``); after the inward
    pass its joint wrench [f; n], the base's generalized forces, into TB[:6]: body 6's
    carried in (``carry_in``), or on a free body (no body 6: the root is the last body,
    whose joint wrench the inward pass's first step left in ST) ST's own."""
    k = 5
    fk = 6 * k
    alone = P.shape[0] - 1 == 6          # a free body: nothing hangs from the root
    for b in range(nl):
        if end and alone:
            TB[0, b], TB[1, b], TB[2, b], TB[3, b], TB[4, b], TB[5, b] = (
                ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b])
        elif end:
            TB[0, b], TB[1, b], TB[2, b], TB[3, b], TB[4, b], TB[5, b] = carry_in(
                RB, PB, FB, ST, k, b)
        else:
            (wx, wy, wz, ax, ay, az, lx, ly, lz), (nx, ny, nz, fx, fy, fz) = root_body(
                P, QV, b, ST[6, b], ST[7, b], ST[8, b])
            ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = wx, wy, wz, ax, ay, az
            ST[6, b], ST[7, b], ST[8, b] = lx, ly, lz
            FB[fk, b], FB[fk + 1, b], FB[fk + 2, b] = fx, fy, fz
            FB[fk + 3, b], FB[fk + 4, b], FB[fk + 5, b] = nx, ny, nz
    return 0


@njit(cache=True, inline="always")
def root_body(P, QV, b, bx, by, bz):
    """Lane b's free-flyer root body (the virtual chain's or tree's body 5): its motion
    (omega, alpha, acc), from the six rates and accelerations in QV and the base's start
    acceleration (bx, by, bz) (-g) by ``joint.free_flyer``, and its wrench (n, f)
    (``rnea.body_wrench``)."""
    n = P.shape[0] - 1
    wx, wy, wz, ax, ay, az, lx, ly, lz = free_flyer(
        QV[n + 3, b], QV[n + 4, b], QV[n + 5, b], QV[2 * n, b], QV[2 * n + 1, b],
        QV[2 * n + 2, b], QV[2 * n + 3, b], QV[2 * n + 4, b], QV[2 * n + 5, b], bx, by, bz)
    return (wx, wy, wz, ax, ay, az, lx, ly, lz), body_wrench(P, 5, wx, wy, wz, ax, ay, az,
                                                             lx, ly, lz)


@njit(cache=True, inline="always")
def carry_in(RB, PB, FB, ST, i, b):
    """Lane b's joint wrench of body i (f; m): body i+1's (ST rows 0..5) carried into frame
    i (f = R f, m = R m + p x f; ``spatial.to_parent``) plus body i's wrench (FB rows 6i..)."""
    fi, rj, pj = 6 * i, 9 * (i + 1), 3 * (i + 1)
    r0, r1, r2 = RB[rj, b], RB[rj + 1, b], RB[rj + 2, b]
    r3, r4, r5 = RB[rj + 3, b], RB[rj + 4, b], RB[rj + 5, b]
    r6, r7, r8 = RB[rj + 6, b], RB[rj + 7, b], RB[rj + 8, b]
    px, py, pz = PB[pj, b], PB[pj + 1, b], PB[pj + 2, b]
    fx, fy, fz = ST[0, b], ST[1, b], ST[2, b]
    mx, my, mz = ST[3, b], ST[4, b], ST[5, b]
    fx, fy, fz = r0 * fx + r1 * fy + r2 * fz, r3 * fx + r4 * fy + r5 * fz, r6 * fx + r7 * fy + r8 * fz
    mx, my, mz = r0 * mx + r1 * my + r2 * mz, r3 * mx + r4 * my + r5 * mz, r6 * mx + r7 * my + r8 * mz
    mx, my, mz = mx + py * fz - pz * fy, my + pz * fx - px * fz, mz + px * fy - py * fx
    fx, fy, fz = fx + FB[fi, b], fy + FB[fi + 1, b], fz + FB[fi + 2, b]
    mx, my, mz = mx + FB[fi + 3, b], my + FB[fi + 4, b], mz + FB[fi + 5, b]
    return fx, fy, fz, mx, my, mz


# ------------------------------------------------------------------ entry point
def rnea_batch(P, q, qd, qdd, w, flags, out):
    """Inverse dynamics of N states: q, qd, qdd (N, n) or (1, n) broadcast; w (N, 6) or
    (1, 6), with flag BASE (N or 1, W_ALL) (layout.W_*). Blocks of B samples run in lanes (the last one with the samples left). Returns
    0, or 1 if some input had a NaN/Inf (its rows are then not meaningful)."""
    bad = OK
    for k0 in range(0, out.shape[0], int(P[P.shape[0] - 1, LANES])):
        bad |= rnea_block(P, q, qd, qdd, w, flags, out, k0)
    return bad


def floating_rnea_batch(P, q, qd, qdd, w, flags, out):
    """``rnea_batch`` on a floating base's virtual chain (``floating_rnea_block``)."""
    bad = OK
    for k0 in range(0, out.shape[0], int(P[P.shape[0] - 1, LANES])):
        bad |= floating_rnea_block(P, q, qd, qdd, w, flags, out, k0)
    return bad
