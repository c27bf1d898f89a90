"""The torque regressor, compiled: Y(q, qd, qdd) with tau = Y phi, one state at a time, on
a chain or a fixed-base tree (the parent array; a chain is lambda(i) = i - 1).

The same quantities as ``algorithms/regressor.py`` (the reference), computed by projection
instead of by carrying 6x10 blocks inward: with s_{j,i} = X_{i<-j} S_j, joint j's motion
axis seen from body i (a motion vector, carried outward like a velocity:
s_w' = R^T s_w, s_v' = R^T (s_v + s_w x p); Featherstone 2008, Sec. 2.8),

    tau_j = sum_{i in j's subtree} S_j^T X_{j<-i}^* (n_i; f_i) = sum_i s_{j,i} . (n_i; f_i)

and with the body wrench of Newton-Euler (``rnea.py``; Atkeson, An & Hollerbach 1986),
s . (n; f) is linear in (m, h, I_O):

    m:    s_v . acc
    h:    s_v x alpha + (s_v . omega) omega - |omega|^2 s_v + acc x s_w
    I_O:  u1^T I v1 + u2^T I v2,   u1 = s_w, v1 = alpha,  u2 = s_w x omega, v2 = omega

(from s_v . (alpha x h) = h . (s_v x alpha), s_v . (omega x (omega x h)) = (s_v . omega)
(omega . h) - |omega|^2 (s_v . h), s_w . (h x acc) = h . (acc x s_w), s_w . (omega x I omega)
= (s_w x omega)^T I omega). Every vector is first turned into body i's URDF link frame
(x_link = A x_joint), so the columns are the link-frame parameters (Pinocchio's
``toDynamicParameters``) directly. O(n^2) 6-vector transforms and dot products: no 6x10
block is ever carried.

The kernels' model is ``regressor_layout(P, A)``: the core layout ``P`` (``layout.py``) with
the joint frames' axes A (row-major, columns AR..AR+8) and AID (1.0 where A = 1) appended.
``flags``: ARMATURE_COLUMNS (n columns qdd_i e_i after the bodies'), FRICTION_COLUMNS (then
3 n columns qd_i e_i, sign(qd_i) e_i, e_i).
"""
import numpy as np
from numba import njit

from . import flags as F
from .data import new_kin, scratch, stack_empty
from .floating import GW, rnea_inputs
from .joint import add_rate, joint_transforms
from .layout import G, KIND, PARENT, W_ACC, W_ALL, WIDTH
from .rnea import outward_step
from .status import BAD_LENGTH, status
from .signatures import (D2, D3, In1, In2, Mat, Out2, Out3, Pm, Vec, f8, i8, internal, row,
                         rows_fit)
from .spatial import finite, to_child

AR, AID = WIDTH, WIDTH + 9
ARMATURE_COLUMNS, FRICTION_COLUMNS = 1, 2


def regressor_layout(P, A):
    """The regressor kernels' model: ``P`` with A (n, 3, 3) and the identity flags appended."""
    n = P.shape[0] - 1
    L = np.zeros((n + 1, WIDTH + 10))
    L[:, :WIDTH] = P
    for i in range(n):
        L[i, AR:AR + 9] = np.asarray(A[i], dtype=float).ravel()
        L[i, AID] = 1.0 if np.array_equal(A[i], np.eye(3)) else 0.0
    return L


@internal
def to_link(L, i, x, y, z):
    """A (x, y, z): a 3-vector of body i from its joint frame into its link frame."""
    if L[i, AID] == 1.0:
        return x, y, z
    return (L[i, AR] * x + L[i, AR + 1] * y + L[i, AR + 2] * z,
            L[i, AR + 3] * x + L[i, AR + 4] * y + L[i, AR + 5] * z,
            L[i, AR + 6] * x + L[i, AR + 7] * y + L[i, AR + 8] * z)


def regressor_core(L, sc, R, p, V, S, q, qd, qdd, flags, Y):
    """Y (n, p) of one state of a chain or a fixed-base tree (the parent array lambda(i):
    a chain is lambda(i) = i - 1). Scratch: V (n, 18), each body's omega, alpha, acc in its
    joint frame (0..8), then in its link frame (9..17); S (n, 7), joint j's motion axis
    s_{j,i} seen from each body i of j's subtree, then 1.0 for those bodies. Returns 0.0,
    or NaN if an input has a NaN/Inf entry."""
    n = L.shape[0] - 1
    chk = joint_transforms(L, sc, R, p, q, n)
    for i in range(n):              # outward: omega, alpha, acc (as rnea_core, tree_rnea_core)
        dq, ddq = qd[i], qdd[i]
        chk += finite(dq) + finite(ddq)
        l = int(L[i, PARENT])
        if l < 0:                   # the base at rest, gravity as its acceleration
            wx = wy = wz = ax = ay = az = 0.0
            lx, ly, lz = -L[n, G], -L[n, G + 1], -L[n, G + 2]
        else:
            wx, wy, wz, ax, ay, az, lx, ly, lz = (V[l, 0], V[l, 1], V[l, 2], V[l, 3], V[l, 4],
                                                  V[l, 5], V[l, 6], V[l, 7], V[l, 8])
        wx, wy, wz, ax, ay, az, lx, ly, lz = outward_step(L, R, p, i, wx, wy, wz, ax, ay, az,
                                                          lx, ly, lz, dq, ddq)
        V[i, 0], V[i, 1], V[i, 2], V[i, 3], V[i, 4], V[i, 5] = wx, wy, wz, ax, ay, az
        V[i, 6], V[i, 7], V[i, 8] = lx, ly, lz
        V[i, 9], V[i, 10], V[i, 11] = to_link(L, i, wx, wy, wz)
        V[i, 12], V[i, 13], V[i, 14] = to_link(L, i, ax, ay, az)
        V[i, 15], V[i, 16], V[i, 17] = to_link(L, i, lx, ly, lz)
    cols = Y.shape[1]
    for j in range(n):              # row j: s_{j,i} . A_i over j's subtree, zero elsewhere
        for c in range(10 * j):
            Y[j, c] = 0.0
        for c in range(10 * n, cols):
            Y[j, c] = 0.0
        kind = L[j, KIND]
        for i in range(j, n):
            c = 10 * i
            l = int(L[i, PARENT])
            if i == j:
                swx, swy, svx, svy = 0.0, 0.0, 0.0, 0.0
                swz, svz = add_rate(kind, 0.0, 0.0, 1.0)     # S_j: e_z angular or linear
            elif l >= j and S[l, 6] == 1.0:   # into body i: s_w' = R^T s_w, s_v' = R^T (s_v + s_w x p)
                px, py, pz = p[i, 0], p[i, 1], p[i, 2]
                swx, swy, swz = S[l, 0], S[l, 1], S[l, 2]
                svx, svy, svz = to_child(R, i, S[l, 3] + swy * pz - swz * py,
                                         S[l, 4] + swz * px - swx * pz, S[l, 5] + swx * py - swy * px)
                swx, swy, swz = to_child(R, i, swx, swy, swz)
            else:                   # not below joint j: no column of body i moves tau_j
                S[i, 6] = 0.0
                for k in range(10):
                    Y[j, c + k] = 0.0
                continue
            S[i, 0], S[i, 1], S[i, 2], S[i, 3], S[i, 4], S[i, 5] = swx, swy, swz, svx, svy, svz
            S[i, 6] = 1.0
            ex, ey, ez = to_link(L, i, swx, swy, swz)
            vx, vy, vz = to_link(L, i, svx, svy, svz)
            wx, wy, wz = V[i, 9], V[i, 10], V[i, 11]
            ax, ay, az = V[i, 12], V[i, 13], V[i, 14]
            lx, ly, lz = V[i, 15], V[i, 16], V[i, 17]
            Y[j, c] = vx * lx + vy * ly + vz * lz                                   # m
            sw = vx * wx + vy * wy + vz * wz
            ww = wx * wx + wy * wy + wz * wz
            Y[j, c + 1] = vy * az - vz * ay + sw * wx - ww * vx + ly * ez - lz * ey   # m c
            Y[j, c + 2] = vz * ax - vx * az + sw * wy - ww * vy + lz * ex - lx * ez
            Y[j, c + 3] = vx * ay - vy * ax + sw * wz - ww * vz + lx * ey - ly * ex
            ux, uy, uz = ey * wz - ez * wy, ez * wx - ex * wz, ex * wy - ey * wx     # s_w x omega
            Y[j, c + 4] = ex * ax + ux * wx                                         # Ixx
            Y[j, c + 5] = ex * ay + ey * ax + ux * wy + uy * wx                     # Ixy
            Y[j, c + 6] = ey * ay + uy * wy                                         # Iyy
            Y[j, c + 7] = ex * az + ez * ax + ux * wz + uz * wx                     # Ixz
            Y[j, c + 8] = ey * az + ez * ay + uy * wz + uz * wy                     # Iyz
            Y[j, c + 9] = ez * az + uz * wz                                         # Izz
    c = 10 * n
    if (flags & ARMATURE_COLUMNS) != 0:     # tau_j += I_a,j qdd_j
        for j in range(n):
            Y[j, c + j] = qdd[j]
        c += n
    if (flags & FRICTION_COLUMNS) != 0:     # fv qd + fc sign(qd) + fo
        for j in range(n):
            x = qd[j]
            Y[j, c + j] = x
            Y[j, c + n + j] = 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)
            Y[j, c + 2 * n + j] = 1.0
    return chk


regressor_core = internal(f8(Pm, D2, D3, D2, D2, D2, In1, In1, In1, i8, Out2))(regressor_core)


@njit(cache=True, inline="always")
def _columns(n, flags):
    return (10 * n + (n if (flags & ARMATURE_COLUMNS) != 0 else 0)
            + (3 * n if (flags & FRICTION_COLUMNS) != 0 else 0))


# ------------------------------------------------------------------ entry points
def regressor(L, q, qd, qdd, flags, out):
    """Y of one state into ``out`` (n, p). Returns OK, NOT_FINITE or BAD_LENGTH."""
    n = L.shape[0] - 1
    if (q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n
            or out.shape[1] != _columns(n, flags)):
        return BAD_LENGTH
    d = new_kin(n)
    return status(regressor_core(L, d.sc, d.R, d.p, stack_empty((n, 18)), stack_empty((n, 7)),
                                 q, qd, qdd, flags, out))


def regressor_batch(L, q, qd, qdd, flags, out):
    """Y of N states into ``out`` (N, n, p): q, qd, qdd (N, n) or (1, n) broadcast. Returns
    OK, NOT_FINITE (some input had a NaN/Inf) or BAD_LENGTH. Each state is ``regressor``'s
    computation, alone: the same bits in any batch."""
    n, N = L.shape[0] - 1, out.shape[0]
    for x in (q, qd, qdd):
        if x.shape[1] != n or (x.shape[0] != N and x.shape[0] != 1):
            return BAD_LENGTH
    if out.shape[1] != n or out.shape[2] != _columns(n, flags):
        return BAD_LENGTH
    d = new_kin(n)
    V, S = stack_empty((n, 18)), stack_empty((n, 7))
    bad = 0.0
    for k in range(N):
        bad += regressor_core(L, d.sc, d.R, d.p, V, S, q[k if q.shape[0] > 1 else 0],
                              qd[k if qd.shape[0] > 1 else 0], qdd[k if qdd.shape[0] > 1 else 0],
                              flags, out[k])
    return status(bad)


# ------------------------------------------------------------------ a floating base
# On the instantaneous chain or tree (core/floating.py; L = regressor_layout of its P): its
# q = [0, joints], its rates v, its accelerations a + p(v) with the base accelerating at -g_b
# (gravity in the base frame, as in floating_derivatives.py); its generalized forces are
# the floating base's. The columns of its five massless virtual bodies and the virtual
# joints' armature and friction columns are dropped: the base's ten (virtual body 5, in
# the base link frame), each body's ten, then the joints' armature and friction columns.
@njit(cache=True, inline="always")
def _floating_one(L, Yv, qv, w, qddv, d, V, S, q, v, a, gw, flags, out):
    nv = qv.shape[0]
    chk = rnea_inputs(q, v, a, gw, F.QD | F.QDD, qv, w, qddv)       # qdd = a + p(v)
    for i in range(3):
        qddv[i] += w[W_ACC + i]                                      # - g_b
    chk += regressor_core(L, d.sc, d.R, d.p, V, S, qv, v, qddv, flags, Yv)
    nb, n = 10 * (nv - 5), nv - 6
    for r in range(nv):
        for c in range(nb):
            out[r, c] = Yv[r, 50 + c]
        for b in range((Yv.shape[1] - 10 * nv) // nv):               # armature, friction
            for j in range(n):
                out[r, nb + b * n + j] = Yv[r, 10 * nv + b * nv + 6 + j]
    return chk


@njit(cache=True, inline="always")
def _floating_scratch(nv, flags):
    p = _columns(nv, flags)
    return (scratch((nv, p), nv * p), stack_empty((nv,)), stack_empty((W_ALL,)),
            stack_empty((nv,)), new_kin(nv), stack_empty((nv, 18)), stack_empty((nv, 7)))


@njit(cache=True, inline="always")
def _floating_columns(nv, flags):
    """p of a floating base: _columns of its n = nv - 6 joints, plus the base's ten."""
    return 10 + _columns(nv - 6, flags)


def floating_regressor(L, q, v, a, gw, flags, out):
    """Y (n+6, p) of one floating state into ``out``: q (n+7), v, a (n+6), gw as
    floating.py's (the wrench not read). Returns OK, NOT_FINITE or BAD_LENGTH."""
    nv = L.shape[0] - 1
    if (q.shape[0] != nv + 1 or v.shape[0] != nv or a.shape[0] != nv or gw.shape[0] != GW
            or out.shape[0] != nv or out.shape[1] != _floating_columns(nv, flags)):
        return BAD_LENGTH
    Yv, qv, w, qddv, d, V, S = _floating_scratch(nv, flags)
    return status(_floating_one(L, Yv, qv, w, qddv, d, V, S, q, v, a, gw, flags, out))


def floating_regressor_batch(L, q, v, a, gw, flags, out):
    """``floating_regressor`` of N states (rows broadcast) into ``out`` (N, n+6, p)."""
    nv, N = L.shape[0] - 1, out.shape[0]
    if (not rows_fit(N, nv + 1, (q,)) or not rows_fit(N, nv, (v, a))
            or not rows_fit(N, GW, (gw,)) or out.shape[1] != nv
            or out.shape[2] != _floating_columns(nv, flags)):
        return BAD_LENGTH
    Yv, qv, w, qddv, d, V, S = _floating_scratch(nv, flags)
    bad = 0.0
    for k in range(N):
        bad += _floating_one(L, Yv, qv, w, qddv, d, V, S, row(q, k), row(v, k), row(a, k),
                             row(gw, k), flags, out[k])
    return status(bad)


ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "regressor": (regressor, i8(Pm, Vec, Vec, Vec, i8, Mat), False, ("regressor_core",)),
    "regressor_batch": (regressor_batch, i8(Pm, In2, In2, In2, i8, Out3), True, ("regressor_core",)),
    "floating_regressor": (floating_regressor, i8(Pm, Vec, Vec, Vec, Vec, i8, Mat), False,
                           ("regressor_core",)),
    "floating_regressor_batch": (floating_regressor_batch, i8(Pm, In2, In2, In2, In2, i8, Out3),
                                 True, ("regressor_core",)),
}
