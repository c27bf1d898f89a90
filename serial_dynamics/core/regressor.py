"""The torque regressor, compiled: Y(q, qd, qdd) with tau = Y phi, one state at a time.

The same quantities as ``algorithms/regressor.py`` (the reference), computed by projection
instead of by carrying 6x10 blocks inward: with s_{j,i} = X_{i<-j} S_j, joint j's motion
axis seen from body i (a motion vector, carried outward like a velocity:
s_w' = R^T s_w, s_v' = R^T (s_v + s_w x p); Featherstone 2008, Sec. 2.8),

    tau_j = sum_{i >= j} S_j^T X_{j<-i}^* (n_i; f_i) = sum_{i >= j} s_{j,i} . (n_i; f_i)

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

from .data import new_kin, stack_empty
from .layout import G, KIND, WIDTH
from .rnea import outward_step
from .status import BAD_LENGTH, status
from .signatures import D2, D3, In1, In2, Mat, Out2, Out3, Pm, Vec, f8, i8, internal
from .spatial import finite, joint_transforms, to_child

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


def regressor_core(L, sc, R, p, V, q, qd, qdd, flags, Y):
    """Y (n, p) of one state; V (n, 9) scratch: omega, alpha, acc of each body, link frame.
    Returns 0.0, or NaN if an input has a NaN/Inf entry."""
    n = L.shape[0] - 1
    chk = joint_transforms(L, sc, R, p, q, n)
    wx = wy = wz = ax = ay = az = 0.0
    lx, ly, lz = -L[n, G], -L[n, G + 1], -L[n, G + 2]       # gravity as a base acceleration
    for i in range(n):              # outward: omega, alpha, acc (as rnea_core)
        dq, ddq = qd[i], qdd[i]
        chk += finite(dq) + finite(ddq)
        wx, wy, wz, ax, ay, az, lx, ly, lz = outward_step(L, R, p, i, wx, wy, wz, ax, ay, az,
                                                          lx, ly, lz, dq, ddq)
        V[i, 0], V[i, 1], V[i, 2] = to_link(L, i, wx, wy, wz)
        V[i, 3], V[i, 4], V[i, 5] = to_link(L, i, ax, ay, az)
        V[i, 6], V[i, 7], V[i, 8] = to_link(L, i, lx, ly, lz)
    cols = Y.shape[1]
    for j in range(n):              # row j: zeros left of body j, then s_{j,i} . A_i
        for c in range(10 * j):
            Y[j, c] = 0.0
        for c in range(10 * n, cols):
            Y[j, c] = 0.0
        rev = L[j, KIND] == 0.0     # S_j = e_z angular (revolute) or linear (prismatic)
        swx, swy, swz = 0.0, 0.0, (1.0 if rev else 0.0)
        svx, svy, svz = 0.0, 0.0, (0.0 if rev else 1.0)
        for i in range(j, n):
            if i > j:               # into body i: s_w' = R^T s_w, s_v' = R^T (s_v + s_w x p)
                px, py, pz = p[i, 0], p[i, 1], p[i, 2]
                svx, svy, svz = to_child(R, i, svx + swy * pz - swz * py,
                                         svy + swz * px - swx * pz, svz + swx * py - swy * px)
                swx, swy, swz = to_child(R, i, swx, swy, swz)
            ex, ey, ez = to_link(L, i, swx, swy, swz)
            vx, vy, vz = to_link(L, i, svx, svy, svz)
            wx, wy, wz = V[i, 0], V[i, 1], V[i, 2]
            ax, ay, az = V[i, 3], V[i, 4], V[i, 5]
            lx, ly, lz = V[i, 6], V[i, 7], V[i, 8]
            c = 10 * i
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


regressor_core = internal(f8(Pm, D2, D3, D2, D2, In1, In1, In1, i8, Out2))(regressor_core)


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
    return status(regressor_core(L, d.sc, d.R, d.p, stack_empty((n, 9)), q, qd, qdd, flags, out))


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
    V = stack_empty((n, 9))
    bad = 0.0
    for k in range(N):
        bad += regressor_core(L, d.sc, d.R, d.p, V, q[k if q.shape[0] > 1 else 0],
                              qd[k if qd.shape[0] > 1 else 0], qdd[k if qdd.shape[0] > 1 else 0],
                              flags, out[k])
    return status(bad)


ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "regressor": (regressor, i8(Pm, Vec, Vec, Vec, i8, Mat), False, ("regressor_core",)),
    "regressor_batch": (regressor_batch, i8(Pm, In2, In2, In2, i8, Out3), True, ("regressor_core",)),
}
