"""The planar fast path for batches, compiled: B samples at a time in SIMD lanes.

The same equations, frames and symbols as ``planar.py`` (single states) and
``algorithms/planar.py`` (the reference); the lane layout of ``rnea_lanes.py``.

    planar_rnea_batch(Q, q, qd, qdd, w, flags, out)      N states, rows of length 1 broadcast
    planar_crba_batch(Q, q, out)                         N configurations, (N, n, n)
"""
import math

from . import flags as F
from .planar_layout import (ANG, ARM, E1, E2, GX, GY, HX, HY, IZ, MASS,
                                 NRM, RX, RY, SGN, TX, TY)
from .data import scratch, stack_empty
from .joint import planar_joint, planar_momentum, planar_origin, planar_project, planar_rate
from .planar import UNSUPPORTED, Qm
from .status import BAD_LENGTH, NOT_FINITE, OK
from .signatures import In2, Out2, Out3, i8, internal
from .spatial import SMALL_ANGLE, sincos


# ------------------------------------------------------------------ batches, in SIMD lanes
# B samples run in lock step, as in rnea_lanes.py: every quantity is stored with the sample
# index (lane) last, shape (rows, L), and each step is a branch-free loop over the lanes
# (the joint kind, the same in every lane, picks values by selects), which the compiler
# turns into vector instructions. The block functions are compiled apart from the entry points
# and get the lane count L as an argument, so that it is not a compile-time constant (the
# compiler vectorizes loops of run-time length; it unrolls one of known length instead).
# Every lane does the operations of the single-state kernels in the same order (libm's
# sine and cosine for a sample with an angle beyond SMALL_ANGLE, as there): a sample's
# result is bitwise the same alone or at any place in any batch.
B = 32                  # samples per block


@internal(i8(Qm, In2, In2, In2, In2, i8, Out2, i8, i8))
def planar_rnea_block(Q, q, qd, qdd, w, flags, out, k0, L):
    """Inverse dynamics of the samples k0 .. k0 + L - 1 (fewer at the end) into the same
    rows of ``out``. Returns 1 if one of them has a NaN/Inf input, else 0. Scratch (rows,
    L): QV q, qd, qdd, then the mask of the samples whose angles are all below SMALL_ANGLE;
    TH theta, then cos theta; SN sin theta; PX, PY the origins p; FX, FY, NZ the body
    wrenches; ST the state: omega, alpha, acc x, y, then the tip wrench (in-plane f, N . m);
    TB the torques."""
    N = out.shape[0]
    n = Q.shape[0] - 1
    nl = min(L, N - k0)
    QV, TH, SN = stack_empty((3 * n + 1, L)), stack_empty((n, L)), stack_empty((n, L))
    PX, PY, TB = stack_empty((n, L)), stack_empty((n, L)), stack_empty((n, L))
    FX, FY, NZ, ST = stack_empty((n, L)), stack_empty((n, L)), stack_empty((n, L)), stack_empty((7, L))
    nq, nv, na, nw = q.shape[0] > 1, qd.shape[0] > 1, qdd.shape[0] > 1, w.shape[0] > 1
    use_qd, use_qdd, use_w = (flags & F.QD) != 0, (flags & F.QDD) != 0, (flags & F.WRENCH) != 0
    # --- gather the block, joint by joint: theta = ANG + SGN q, rates, accelerations
    for b in range(nl):                  # ST[4]: 0.0, or NaN for a NaN/Inf rate or acceleration;
        ST[4, b] = 0.0                   # QV[3n]: 1.0 if every angle of the lane is below SMALL_ANGLE
        QV[3 * n, b] = 1.0
    for i in range(n):
        an, sg = Q[i, ANG], Q[i, SGN]
        for b in range(nl):
            x = q[k0 + b if nq else 0, i]
            QV[i, b] = x
            th = an + sg * x
            TH[i, b] = th
            QV[3 * n, b] = QV[3 * n, b] if abs(th) < SMALL_ANGLE else 0.0
        if use_qd:
            for b in range(nl):
                y = qd[k0 + b if nv else 0, i]
                QV[n + i, b] = y
                ST[4, b] += y * 0.0
        else:
            for b in range(nl):
                QV[n + i, b] = 0.0
        if use_qdd:
            for b in range(nl):
                z = qdd[k0 + b if na else 0, i]
                QV[2 * n + i, b] = z
                ST[4, b] += z * 0.0
        else:
            for b in range(nl):
                QV[2 * n + i, b] = 0.0
    small = True
    fin = True
    for b in range(nl):
        small &= QV[3 * n, b] == 1.0
        fin &= ST[4, b] == 0.0
    # the state, and the tip wrench projected on the plane
    for b in range(nl):
        ex = ey = mn = 0.0
        if use_w:
            k = k0 + b if nw else 0
            w0, w1, w2, w3, w4, w5 = w[k, 0], w[k, 1], w[k, 2], w[k, 3], w[k, 4], w[k, 5]
            fin &= (w0 * 0.0 + w1 * 0.0 + w2 * 0.0 + w3 * 0.0 + w4 * 0.0 + w5 * 0.0) == 0.0
            ex = Q[n, E1] * w0 + Q[n, E1 + 1] * w1 + Q[n, E1 + 2] * w2
            ey = Q[n, E2] * w0 + Q[n, E2 + 1] * w1 + Q[n, E2 + 2] * w2
            mn = Q[n, NRM] * w3 + Q[n, NRM + 1] * w4 + Q[n, NRM + 2] * w5
        ST[0, b], ST[1, b], ST[2, b], ST[3, b] = 0.0, 0.0, -Q[n, GX], -Q[n, GY]
        ST[4, b], ST[5, b], ST[6, b] = ex, ey, mn
    # --- joint transforms
    for i in range(n):
        if small:
            for b in range(nl):
                s, c = sincos(TH[i, b])
                TH[i, b], SN[i, b] = c, s
        else:                            # a huge angle is legal; NaN or Inf is not
            for b in range(nl):
                th = TH[i, b]
                fin &= th * 0.0 == 0.0
                s, c = sincos(th) if QV[3 * n, b] == 1.0 else (math.sin(th), math.cos(th))
                TH[i, b], SN[i, b] = c, s
        rx, ry, jt = Q[i, RX], Q[i, RY], planar_joint(Q, i)
        for b in range(nl):              # p = r (+ q Rot(theta) d)
            PX[i, b], PY[i, b] = planar_origin(jt, rx, ry, TH[i, b], SN[i, b], QV[i, b])
    # --- outward: velocities, accelerations, body wrenches
    for i in range(n):
        m, hx, hy, Izz = Q[i, MASS], Q[i, HX], Q[i, HY], Q[i, IZ]
        jt = planar_joint(Q, i)          # the same in every lane: selects
        for b in range(nl):
            c, s, px, py = TH[i, b], SN[i, b], PX[i, b], PY[i, b]
            wz, az, lx, ly = ST[0, b], ST[1, b], ST[2, b], ST[3, b]
            dq, ddq = QV[n + i, b], QV[2 * n + i, b]
            # acc + alpha x p + omega x (omega x p), then into body i: Rot(theta)^T
            w2 = wz * wz
            tx = lx - az * py - w2 * px
            ty = ly + az * px - w2 * py
            lx, ly = c * tx + s * ty, -s * tx + c * ty
            wz, az, lx, ly = planar_rate(jt, wz, az, lx, ly, dq, ddq)     # spin or slide
            # body wrench about its origin
            w2 = wz * wz
            FX[i, b] = m * lx - az * hy - w2 * hx
            FY[i, b] = m * ly + az * hx - w2 * hy
            NZ[i, b] = Izz * az + (hx * ly - hy * lx)
            ST[0, b], ST[1, b], ST[2, b], ST[3, b] = wz, az, lx, ly
        if use_w:                        # the tip wrench, carried into body i
            for b in range(nl):
                c, s, ex, ey = TH[i, b], SN[i, b], ST[4, b], ST[5, b]
                ST[4, b], ST[5, b] = c * ex + s * ey, -s * ex + c * ey
    # --- inward (ST rows 0..2: f x, y, n); the last body carries the load -w
    k = n - 1
    tpx, tpy = Q[n, TX], Q[n, TY]
    jt = planar_joint(Q, k)
    for b in range(nl):
        ex, ey, mn = ST[4, b], ST[5, b], ST[6, b]
        fx, fy = FX[k, b] - ex, FY[k, b] - ey
        nz = NZ[k, b] + (-mn + (tpx * -ey - tpy * -ex))
        TB[k, b] = planar_project(jt, nz, fx, fy)
        ST[0, b], ST[1, b], ST[2, b] = fx, fy, nz
    for i in range(n - 2, -1, -1):
        jt = planar_joint(Q, i)
        for b in range(nl):              # f' = Rot f, n' = n + p x f', plus the body wrench
            c, s, px, py = TH[i + 1, b], SN[i + 1, b], PX[i + 1, b], PY[i + 1, b]
            fx, fy, nz = ST[0, b], ST[1, b], ST[2, b]
            gx, gy = c * fx - s * fy, s * fx + c * fy
            nz = nz + (px * gy - py * gx)
            fx, fy, nz = gx + FX[i, b], gy + FY[i, b], nz + NZ[i, b]
            TB[i, b] = planar_project(jt, nz, fx, fy)
            ST[0, b], ST[1, b], ST[2, b] = fx, fy, nz
    for i in range(n):                   # tau_i += I_a,i qdd_i, after the passes
        arm = Q[i, ARM]
        for b in range(nl):
            TB[i, b] += arm * QV[2 * n + i, b]
    # --- scatter
    for b in range(nl):
        for i in range(n):
            out[k0 + b, i] = TB[i, b]
    return OK if fin else NOT_FINITE


@internal(i8(Qm, In2, Out3, i8, i8))
def planar_crba_block(Q, q, out, k0, L):
    """Mass matrices of the samples k0 .. k0 + L - 1 (fewer at the end) into out[k0 + b].
    Returns 1 if one of them has a NaN/Inf angle, else 0. Scratch (rows, L): TH theta then
    cos theta, SN sin theta, PX, PY the origins, QV q then the small-angle mask, CB the
    composite (m, h_x, h_y, I_nn) and F (n, f_x, f_y); MB the matrices, row-major (on the
    heap beyond 64 KiB)."""
    N = out.shape[0]
    n = Q.shape[0] - 1
    nl = min(L, N - k0)
    nq = q.shape[0] > 1
    QV, TH, SN = stack_empty((n + 1, L)), stack_empty((n, L)), stack_empty((n, L))
    PX, PY, CB = stack_empty((n, L)), stack_empty((n, L)), stack_empty((7, L))
    MB = scratch((n * n, L), n * n * L)
    for b in range(nl):                  # QV[n]: 1.0 if every angle of the lane is below SMALL_ANGLE
        QV[n, b] = 1.0
    for i in range(n):
        an, sg = Q[i, ANG], Q[i, SGN]
        for b in range(nl):
            x = q[k0 + b if nq else 0, i]
            th = an + sg * x
            QV[i, b], TH[i, b] = x, th
            QV[n, b] = QV[n, b] if abs(th) < SMALL_ANGLE else 0.0
    small = True
    for b in range(nl):
        small &= QV[n, b] == 1.0
    fin = True
    for i in range(n):
        if small:
            for b in range(nl):
                s, c = sincos(TH[i, b])
                TH[i, b], SN[i, b] = c, s
        else:
            for b in range(nl):
                th = TH[i, b]
                fin &= th * 0.0 == 0.0
                s, c = sincos(th) if QV[n, b] == 1.0 else (math.sin(th), math.cos(th))
                TH[i, b], SN[i, b] = c, s
        rx, ry, jt = Q[i, RX], Q[i, RY], planar_joint(Q, i)
        for b in range(nl):
            PX[i, b], PY[i, b] = planar_origin(jt, rx, ry, TH[i, b], SN[i, b], QV[i, b])
    k = n - 1
    for b in range(nl):
        CB[0, b], CB[1, b], CB[2, b], CB[3, b] = Q[k, MASS], Q[k, HX], Q[k, HY], Q[k, IZ]
    for i in range(n - 1, -1, -1):
        jt = planar_joint(Q, i)
        for b in range(nl):              # F = IC_i S_i, M_ii = S_i^T F
            (CB[4, b], CB[5, b], CB[6, b], MB[i * n + i, b]) = planar_momentum(
                jt, CB[0, b], CB[1, b], CB[2, b], CB[3, b])
        for j in range(i, 0, -1):        # F = Xup_j^T F, M_{j-1,i} = S_{j-1}^T F
            jt = planar_joint(Q, j - 1)
            for b in range(nl):
                c, s, px, py = TH[j, b], SN[j, b], PX[j, b], PY[j, b]
                nz, fx, fy = CB[4, b], CB[5, b], CB[6, b]
                gx, gy = c * fx - s * fy, s * fx + c * fy
                nz = nz + (px * gy - py * gx)
                MB[(j - 1) * n + i, b] = planar_project(jt, nz, gx, gy)
                CB[4, b], CB[5, b], CB[6, b] = nz, gx, gy
        if i > 0:                        # IC_{i-1} = I_{i-1} + IC_i carried into body i-1
            m0, hx0, hy0, I0 = Q[i - 1, MASS], Q[i - 1, HX], Q[i - 1, HY], Q[i - 1, IZ]
            for b in range(nl):
                c, s, px, py = TH[i, b], SN[i, b], PX[i, b], PY[i, b]
                m, hx, hy, Izz = CB[0, b], CB[1, b], CB[2, b], CB[3, b]
                gx, gy = c * hx - s * hy, s * hx + c * hy
                CB[3, b] = I0 + Izz + 2.0 * (px * gx + py * gy) + m * (px * px + py * py)
                CB[1, b], CB[2, b] = hx0 + gx + m * px, hy0 + gy + m * py
                CB[0, b] = m0 + m
    for i in range(n):                   # M_ii += I_a,i, after the pass
        arm = Q[i, ARM]
        for b in range(nl):
            MB[i * n + i, b] += arm
    # --- scatter: the upper triangle, mirrored
    for b in range(nl):
        M = out[k0 + b]
        for i in range(n):
            for j in range(i, n):
                v = MB[i * n + j, b]
                M[i, j] = v
                M[j, i] = v
    return OK if fin else NOT_FINITE


def _planar_rnea_batch(Q, q, qd, qdd, w, flags, out):
    """Inverse dynamics of N = out.shape[0] states: q, qd, qdd (N, n) or (1, n) broadcast;
    w (N, 6) or (1, 6), read with the flag WRENCH. Blocks of B samples run in lanes (the
    last one with the samples left). Returns OK, NOT_FINITE if some input had a NaN/Inf (its rows
    are then not meaningful), 2 on a wrong shape."""
    n, N = Q.shape[0] - 1, out.shape[0]
    use_qd, use_qdd, use_w = (flags & F.QD) != 0, (flags & F.QDD) != 0, (flags & F.WRENCH) != 0
    if (n < 1 or (flags & UNSUPPORTED) != 0 or out.shape[1] != n or q.shape[1] != n
            or (q.shape[0] != N and q.shape[0] != 1) or (use_qd and (qd.shape[1] != n or (qd.shape[0] != N and qd.shape[0] != 1)))
            or (use_qdd and (qdd.shape[1] != n or (qdd.shape[0] != N and qdd.shape[0] != 1)))
            or (use_w and (w.shape[1] != 6 or (w.shape[0] != N and w.shape[0] != 1)))):
        return BAD_LENGTH
    L = min(B, N)                        # known at run time only (see above)
    bad = OK
    for k0 in range(0, N, B):
        bad |= planar_rnea_block(Q, q, qd, qdd, w, flags, out, k0, L)
    return bad


def _planar_crba_batch(Q, q, out):
    """Mass matrices (N, n, n) of N = out.shape[0] configurations (N, n), or one (1, n)
    broadcast; blocks of B samples in lanes. Returns OK, NOT_FINITE or BAD_LENGTH."""
    n, N = Q.shape[0] - 1, out.shape[0]
    if (n < 1 or out.shape[1] != n or out.shape[2] != n or q.shape[1] != n
            or (q.shape[0] != N and q.shape[0] != 1)):
        return BAD_LENGTH
    L = min(B, N)
    bad = OK
    for k0 in range(0, N, B):
        bad |= planar_crba_block(Q, q, out, k0, L)
    return bad


ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "planar_rnea_batch": (_planar_rnea_batch, i8(Qm, In2, In2, In2, In2, i8, Out2), True,
                          ("planar_rnea_block",)),
    "planar_crba_batch": (_planar_crba_batch, i8(Qm, In2, Out3), True, ("planar_crba_block",)),
}
