"""The planar fast path, compiled: Newton-Euler and composite rigid bodies in planar
3-vectors, twists (omega_z; v_x, v_y) and wrenches (n_z; f_x, f_y) (Angeles, Sec. 7.6.1).

The same equations, frames and symbols as ``algorithms/planar.py`` (the readable
reference; its docstring defines the layout ``Q`` and says why the dropped components do
not change a joint torque). Kernels take ``Q`` (``planar_pack``), not ``P``: n = Q.shape[0]
- 1 joints. Status codes (status.py) and ``flags`` as ``rnea.py``'s entry points: OK,
NOT_FINITE (a NaN/Inf in an input), BAD_LENGTH (a wrong length, or a flag the planar path
does not model: BASE, a moving base); flags QD, QDD (and WRENCH: read by the batch kernel, implied by the wrench entry).

Entry points (``core.K.<name>``, compiled -- or loaded from numba's cache -- on first use,
each with its one signature):

    planar_rnea(Q, q, qd, qdd, flags, out)               tau of one state into out (n,)
    planar_rnea_wrench(Q, q, qd, qdd, w, flags, out)     the same with a tip wrench w (6,)
    planar_crba(Q, q, out)                               M of one configuration, (n, n)

and their batches in SIMD lanes in ``planar_lanes.py``.

``ENTRY_POINTS`` lists them in the format of ``core.ENTRY_POINTS``, which includes them:
they are ``core.K.planar_*``, compiled on first use like the others.

Scratch: each call makes its own ``S`` (n, 7) on its stack (``stack_empty``), per body:
cos theta, sin theta, p_x, p_y (body i in body i-1), then the body wrench f_x, f_y, n_z.
"""
import math

from numba import njit

from . import flags as F
from .planar_layout import (ANG, ARM, E1, E2, GX, GY, HX, HY, IZ, MASS,
                                 NRM, RX, RY, SGN, TX, TY)
from .data import stack_empty
from .joint import planar_joint, planar_momentum, planar_origin, planar_project, planar_rate
from .signatures import Mat, Pm, Vec, i8
from .status import BAD_LENGTH, status
from .spatial import SMALL_ANGLE, sincos

Qm = Pm                 # the packed planar model Q (never written), C-contiguous
UNSUPPORTED = getattr(F, "BASE", 0)   # flags the planar path does not model (a moving base):
                                      # BAD_LENGTH, so that the caller takes its general path
SCRATCH = 7             # columns of S: c, s, px, py, fx, fy, nz


@njit(cache=True, inline="always")
def planar_transforms(Q, S, q, n):
    """Body i in body i-1 (planar): theta_i = ANG + SGN q_i, its cosine and sine into S[i, 0],
    S[i, 1], the origin p_i = (RX, RY) + q_i Rot(theta_i) d_i into S[i, 2:4]. Returns 0.0,
    or NaN when some theta_i is NaN or Inf (q_i NaN or Inf, prismatic joints included:
    0 * Inf is NaN)."""
    small = True
    for i in range(n):
        th = Q[i, ANG] + Q[i, SGN] * q[i]
        S[i, 0] = th
        small &= abs(th) < SMALL_ANGLE
    chk = 0.0
    if small:                            # a loop of its own, so that it vectorizes
        for i in range(n):
            s, c = sincos(S[i, 0])
            S[i, 0], S[i, 1] = c, s
    else:                                # huge, NaN or Inf angles: libm's argument reduction
        for i in range(n):
            th = S[i, 0]
            chk += th * 0.0
            S[i, 0], S[i, 1] = math.cos(th), math.sin(th)
    for i in range(n):
        S[i, 2], S[i, 3] = planar_origin(planar_joint(Q, i), Q[i, RX], Q[i, RY], S[i, 0], S[i, 1], q[i])
    return chk


def planar_rnea_core(Q, S, q, qd, qdd, w, flags, tau):
    """tau = M(q) qdd + b(q, qd) - J^T w into ``tau`` (n,). Returns 0.0, or NaN if an input
    has a NaN/Inf entry."""
    n = tau.shape[0]
    use_qd, use_qdd, use_w = (flags & F.QD) != 0, (flags & F.QDD) != 0, (flags & F.WRENCH) != 0
    chk = planar_transforms(Q, S, q, n)
    wz = az = 0.0                                   # omega, alpha of the previous body (along N)
    lx, ly = -Q[n, GX], -Q[n, GY]                   # acc of its origin; base: -g
    ex = ey = mn = 0.0                              # tip wrench (in-plane f, N . m), carried outward
    if use_w:
        chk += w[0] * 0.0 + w[1] * 0.0 + w[2] * 0.0 + w[3] * 0.0 + w[4] * 0.0 + w[5] * 0.0
        ex = Q[n, E1] * w[0] + Q[n, E1 + 1] * w[1] + Q[n, E1 + 2] * w[2]
        ey = Q[n, E2] * w[0] + Q[n, E2 + 1] * w[1] + Q[n, E2 + 2] * w[2]
        mn = Q[n, NRM] * w[3] + Q[n, NRM + 1] * w[4] + Q[n, NRM + 2] * w[5]
    for i in range(n):
        dq = qd[i] if use_qd else 0.0
        ddq = qdd[i] if use_qdd else 0.0
        chk += dq * 0.0 + ddq * 0.0                 # 0.0, or NaN for a NaN or Inf
        c, s, px, py = S[i, 0], S[i, 1], S[i, 2], S[i, 3]
        # acc + alpha x p + omega x (omega x p), then into body i: Rot(theta)^T
        w2 = wz * wz
        tx = lx - az * py - w2 * px
        ty = ly + az * px - w2 * py
        lx, ly = c * tx + s * ty, -s * tx + c * ty
        wz, az, lx, ly = planar_rate(planar_joint(Q, i), wz, az, lx, ly, dq, ddq)
        # body wrench about its origin: f = m acc + alpha x h + omega x (omega x h),
        #                                n = I_nn alpha + h x acc
        m, hx, hy = Q[i, MASS], Q[i, HX], Q[i, HY]
        w2 = wz * wz
        S[i, 4] = m * lx - az * hy - w2 * hx
        S[i, 5] = m * ly + az * hx - w2 * hy
        S[i, 6] = Q[i, IZ] * az + (hx * ly - hy * lx)
        if use_w:
            ex, ey = c * ex + s * ey, -s * ex + c * ey
    # inward: f_i = body wrench + Xup_{i+1}^T f_{i+1}, tau_i = S_i^T f_i;
    # the last body carries the load -w (moment about its origin: -m + t x (-f))
    k = n - 1
    fx, fy = S[k, 4] - ex, S[k, 5] - ey
    nz = S[k, 6] + (-mn + (Q[n, TX] * -ey - Q[n, TY] * -ex))
    tau[k] = planar_project(planar_joint(Q, k), nz, fx, fy)
    for i in range(n - 2, -1, -1):
        c, s, px, py = S[i + 1, 0], S[i + 1, 1], S[i + 1, 2], S[i + 1, 3]
        gx, gy = c * fx - s * fy, s * fx + c * fy       # f' = Rot f, n' = n + p x f'
        nz = nz + (px * gy - py * gx)
        fx, fy, nz = gx + S[i, 4], gy + S[i, 5], nz + S[i, 6]
        tau[i] = planar_project(planar_joint(Q, i), nz, fx, fy)
    for i in range(n):              # tau_i += I_a,i qdd_i, after the passes (joint.armature_torques)
        tau[i] += Q[i, ARM] * (qdd[i] if use_qdd else 0.0)
    return chk


planar_rnea_core = njit(cache=True, inline="always")(planar_rnea_core)   # into the entries


def planar_crba_core(Q, S, M):
    """M into ``M`` (n, n); S holds the joint transforms (``planar_transforms``). The
    composite of bodies i..n-1 about body i's origin is carried as (m, h, I_nn)."""
    n = M.shape[0]
    k = n - 1
    m, hx, hy, Izz = Q[k, MASS], Q[k, HX], Q[k, HY], Q[k, IZ]
    for i in range(n - 1, -1, -1):
        nz, fx, fy, M[i, i] = planar_momentum(planar_joint(Q, i), m, hx, hy, Izz)  # F = IC_i S_i
        for j in range(i, 0, -1):   # F = Xup_j^T F: f' = Rot f, n' = n + p x f'; M_{j-1,i} = S^T F
            c, s, px, py = S[j, 0], S[j, 1], S[j, 2], S[j, 3]
            gx, gy = c * fx - s * fy, s * fx + c * fy
            nz = nz + (px * gy - py * gx)
            fx, fy = gx, gy
            v = planar_project(planar_joint(Q, j - 1), nz, fx, fy)
            M[j - 1, i] = v
            M[i, j - 1] = v
        if i > 0:   # IC_{i-1} = I_{i-1} + IC_i carried into body i-1 (parallel axes, eq. 2.63)
            c, s, px, py = S[i, 0], S[i, 1], S[i, 2], S[i, 3]
            gx, gy = c * hx - s * hy, s * hx + c * hy      # h_R = Rot h
            Izz = Q[i - 1, IZ] + Izz + 2.0 * (px * gx + py * gy) + m * (px * px + py * py)
            hx, hy = Q[i - 1, HX] + gx + m * px, Q[i - 1, HY] + gy + m * py
            m = Q[i - 1, MASS] + m
    for i in range(n):              # M_ii += I_a,i, after the pass (joint.armature_diagonal)
        M[i, i] += Q[i, ARM]


planar_crba_core = njit(cache=True, inline="always")(planar_crba_core)


# ------------------------------------------------------------------ entry points
def _planar_rnea(Q, q, qd, qdd, flags, out):
    """Inverse dynamics of one state into ``out`` (n,). Returns OK, NOT_FINITE or BAD_LENGTH."""
    n = Q.shape[0] - 1
    if (n < 1 or q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n
            or (flags & UNSUPPORTED) != 0):
        return BAD_LENGTH
    S = stack_empty((n, SCRATCH))
    return status(planar_rnea_core(Q, S, q, qd, qdd, q, flags & ~F.WRENCH, out))


def _planar_rnea_wrench(Q, q, qd, qdd, w, flags, out):
    """``planar_rnea`` with the tip wrench ``w`` (6,), [f; m] in base coordinates, on the tip."""
    n = Q.shape[0] - 1
    if (n < 1 or q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n
            or w.shape[0] != 6 or (flags & UNSUPPORTED) != 0):
        return BAD_LENGTH
    S = stack_empty((n, SCRATCH))
    return status(planar_rnea_core(Q, S, q, qd, qdd, w, flags | F.WRENCH, out))


def _planar_crba(Q, q, out):
    """Mass matrix of one configuration into ``out`` (n, n). Returns OK, NOT_FINITE or BAD_LENGTH."""
    n = Q.shape[0] - 1
    if n < 1 or q.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return BAD_LENGTH
    S = stack_empty((n, SCRATCH))
    chk = planar_transforms(Q, S, q, n)
    planar_crba_core(Q, S, out)
    return status(chk)


ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "planar_rnea": (_planar_rnea, i8(Qm, Vec, Vec, Vec, i8, Vec), False, ()),
    "planar_rnea_wrench": (_planar_rnea_wrench, i8(Qm, Vec, Vec, Vec, Vec, i8, Vec), False, ()),
    "planar_crba": (_planar_crba, i8(Qm, Vec, Mat), False, ()),
}
