"""Planar fast path: dynamics of a chain that moves in one plane, in planar 3-vectors.

A serial chain is *planar* when every revolute joint axis is parallel (either sense) to
one unit normal n and every prismatic axis is perpendicular to it. Then every body turns
about n and slides in the plane: its twist has three non-zero components (omega_z; v_x,
v_y) and the joint torques need only three components of each wrench (n_z; f_x, f_y)
(Angeles, *Fundamentals of Robotic Mechanical Systems*, Sec. 7.6.1; Featherstone, *Rigid
Body Dynamics Algorithms* (2008), Sec. 2.16, planar vectors). This module detects such a
chain (``planar_pack``), packs it as one array ``Q``, and is the readable reference of the
planar recursions (``inverse_dynamics``, ``mass_matrix``); ``core/planar.py`` compiles the
same equations, with the same symbols, line for line.

Why the dropped components do not change a joint torque
--------------------------------------------------------
With omega = omega_z n, alpha = alpha_z n and every origin acceleration in the plane (up to
the gravity component along n, below), the joint torques are tau_i = n . n_i (revolute,
times the axis sense) and tau_i = d_i . f_i (prismatic, d_i in the plane). What enters them:

- **Products of inertia** I_xn, I_yn (n the normal): the moment about the body origin is
  I_O alpha + omega x (I_O omega) + h x a. Its n component is I_nn alpha_z (alpha is along
  n) plus n . (omega x I_O omega) = omega_z^2 n . (n x I_O n) = 0, plus (h x a) . n. So
  only I_nn, the moment of inertia about the normal through the body origin, enters;
  I_xn, I_yn produce moments in the plane, which the joint structure carries.
- **Gravity along n** adds the force m g_n n to every body: no in-plane force, and a
  moment r x (m g_n n) perpendicular to n for every lever r. The same holds for the
  force and moment parts of a tip wrench along n and in the plane: only (f_x, f_y, m_n)
  of it enter.
- **Offsets along n** (of joint origins, centres of mass, the tip point) change a moment
  r x f with f in the plane only by (r_n n) x f, which is in the plane: n . (r x f) =
  r_x f_y - r_y f_x. And I_nn = I_c,nn + m (c_x^2 + c_y^2) does not depend on c_n.

So each body is described by its mass m, its in-plane first moment h = m (c_x, c_y) and
I_nn, all about the body's *planar origin* (its joint frame origin, projected on the plane,
which changes nothing by the last point).

The layout ``Q`` (planar frames, columns) and its packing ``planar_pack`` are
``core/planar_layout.py``'s.
"""
from __future__ import annotations

import numpy as np

from ..core.planar_layout import (ANG, ARM, DX, DY, E1, E2, GX, GY, HX, HY, IZ, KIND,  # noqa: F401
                                  MASS, NRM, RX, RY, SGN, TX, TY, WIDTH, planar_pack)

# ------------------------------------------------------------------ planar algebra
def _rot(c, s, x, y):
    """Rot(theta) (x, y): a planar vector of body i into body i-1's axes."""
    return c * x - s * y, s * x + c * y


def _rot_t(c, s, x, y):
    """Rot(theta)^T (x, y): a planar vector of body i-1 into body i's axes."""
    return c * x + s * y, -s * x + c * y


def _cross(ax, ay, bx, by):
    """n . (a x b) of two in-plane vectors."""
    return ax * by - ay * bx


def _states(Q, *xs):
    """(single, N, arrays (N, n) or None): rows of length 1 broadcast."""
    n = Q.shape[0] - 1
    arrs = [None if x is None else np.asarray(x, dtype=float) for x in xs]
    single = all(a is None or a.ndim == 1 for a in arrs)
    arrs = [None if a is None else np.atleast_2d(a) for a in arrs]
    for a in arrs:
        if a is not None and (a.ndim != 2 or a.shape[1] != n):
            raise ValueError(f"a state has shape {a.shape}; expected ({n},) or (N, {n})")
    N = max(a.shape[0] for a in arrs if a is not None)
    return single, N, [None if a is None else np.broadcast_to(a, (N, n)) for a in arrs]


def joint_transforms(Q, q):
    """Body i in body i-1 (planar): cos, sin of theta_i and the origin p_i, each (N, n)."""
    th = Q[:-1, ANG] + Q[:-1, SGN] * q                         # theta = ANG + SGN q
    c, s = np.cos(th), np.sin(th)
    dx, dy = _rot(c, s, Q[:-1, DX], Q[:-1, DY])                  # d_i in body i-1's axes
    px = Q[:-1, RX] + q * Q[:-1, KIND] * dx                      # p = r + q Rot(theta) d
    py = Q[:-1, RY] + q * Q[:-1, KIND] * dy
    return c, s, px, py


# ------------------------------------------------------------------ inverse dynamics
def inverse_dynamics(Q, q, qd, qdd, wrench=None):
    """tau = M(q) qdd + b(q, qd) - J^T w of a planar chain, (n,) or (N, n); ``qd``, ``qdd``
    None for zeros. ``wrench`` [fx, fy, fz, mx, my, mz] (6,) or (N, 6), base coordinates,
    exerted by the environment on the tip frame origin: only (E1 . f, E2 . f, N . m) of it
    enter. Newton-Euler as ``algorithms/rnea.py`` (Featherstone 2008, Table 5.1, classical
    origin accelerations), with omega, alpha scalars along N and acc, f in-plane."""
    single, N, (q, qd, qdd) = _states(Q, q, qd, qdd)
    n = q.shape[1]
    qd = np.zeros((N, n)) if qd is None else qd
    qdd = np.zeros((N, n)) if qdd is None else qdd
    c, s, px, py = joint_transforms(Q, q)
    last = Q[n]                                           # the chain's constants
    omega = np.zeros(N)                                   # angular velocity of body i-1 (along N)
    alpha = np.zeros(N)                                   # its angular acceleration
    acc_x, acc_y = np.full(N, -last[GX]), np.full(N, -last[GY])   # acc of its origin; base: -g
    fB = np.empty((N, n, 2))                              # rate of change of momentum: force
    nB = np.empty((N, n))                                 # and moment about the origin (along N)
    for i in range(n):          # outward (Featherstone 2008, Table 5.1; Luh, Walker & Paul 1980)
        # body i-1's motion at body i's origin: acc + alpha x p + omega x (omega x p)
        acc_x = acc_x - alpha * py[:, i] - omega**2 * px[:, i]
        acc_y = acc_y + alpha * px[:, i] - omega**2 * py[:, i]
        acc_x, acc_y = _rot_t(c[:, i], s[:, i], acc_x, acc_y)     # into body i
        if Q[i, KIND] == 1.0:   # slide along d: acc += 2 omega x (qd d) + qdd d
            dx, dy = Q[i, DX], Q[i, DY]
            acc_x = acc_x - 2.0 * omega * qd[:, i] * dy + qdd[:, i] * dx
            acc_y = acc_y + 2.0 * omega * qd[:, i] * dx + qdd[:, i] * dy
        else:                   # spin about SGN N: alpha += SGN qdd, omega += SGN qd
            alpha = alpha + Q[i, SGN] * qdd[:, i]
            omega = omega + Q[i, SGN] * qd[:, i]
        # Newton-Euler about the origin: f = m acc + alpha x h + omega x (omega x h),
        # n = I_nn alpha + h x acc  (the N component of omega x I_O omega is 0)
        m, hx, hy, Izz = Q[i, MASS], Q[i, HX], Q[i, HY], Q[i, IZ]
        fB[:, i, 0] = m * acc_x - alpha * hy - omega**2 * hx
        fB[:, i, 1] = m * acc_y + alpha * hx - omega**2 * hy
        nB[:, i] = Izz * alpha + _cross(hx, hy, acc_x, acc_y)
    # inward (Table 5.1): joint forces; the tip load -w acts on the environment
    fx, fy, nm = np.zeros(N), np.zeros(N), np.zeros(N)
    if wrench is not None:
        w = np.broadcast_to(np.asarray(wrench, dtype=float), (N, 6))
        wx, wy = w[:, :3] @ last[E1:E1 + 3], w[:, :3] @ last[E2:E2 + 3]     # projected on
        wn = w[:, 3:] @ last[NRM:NRM + 3]                                   # the plane
        th = np.sum(Q[:-1, ANG] + Q[:-1, SGN] * q, axis=1)          # base -> body n-1
        wx, wy = _rot_t(np.cos(th), np.sin(th), wx, wy)             # -w in body n-1, moment
        fx, fy = -wx, -wy                                           # about its origin:
        nm = -wn + _cross(last[TX], last[TY], fx, fy)               # -m + t x (-f)
    tau = np.empty((N, n))
    for i in range(n - 1, -1, -1):
        if i < n - 1:           # child's load into body i: f' = Rot f, n' = n + p x f'
            fx, fy = _rot(c[:, i + 1], s[:, i + 1], fx, fy)
            nm = nm + _cross(px[:, i + 1], py[:, i + 1], fx, fy)
        fx, fy, nm = fx + fB[:, i, 0], fy + fB[:, i, 1], nm + nB[:, i]
        # tau_i = S_i^T (n; f) + armature qdd_i
        t = Q[i, DX] * fx + Q[i, DY] * fy if Q[i, KIND] == 1.0 else Q[i, SGN] * nm
        tau[:, i] = t + Q[i, ARM] * qdd[:, i]
    return tau[0] if single else tau


def bias_torques(Q, q, qd, wrench=None):
    """b(q, qd) - J^T w = inverse_dynamics(q, qd, 0, wrench)."""
    return inverse_dynamics(Q, q, qd, None, wrench)


def gravity_torques(Q, q):
    """Torques that hold the chain still: inverse_dynamics(q, 0, 0)."""
    return inverse_dynamics(Q, q, None, None)


# ------------------------------------------------------------------ mass matrix
def mass_matrix(Q, q):
    """M(q) of a planar chain, (n, n) or (N, n, n): composite rigid bodies as
    ``algorithms/crba.py`` (Featherstone 2008, Table 6.2), the composite of bodies i..n-1
    carried as (m, h, I_nn) about body i's planar origin."""
    single, N, (q,) = _states(Q, q)
    n = q.shape[1]
    c, s, px, py = joint_transforms(Q, q)
    M = np.empty((N, n, n))
    k = n - 1
    m = np.full(N, Q[k, MASS])                            # composite k..n-1: IC_k = I_k
    hx, hy, Izz = np.full(N, Q[k, HX]), np.full(N, Q[k, HY]), np.full(N, Q[k, IZ])
    for i in range(n - 1, -1, -1):
        # F = IC_i S_i: revolute (SGN I_nn; SGN N x h), prismatic (h x d; m d)
        if Q[i, KIND] == 1.0:
            dx, dy = Q[i, DX], Q[i, DY]
            nm, fx, fy = _cross(hx, hy, dx, dy), m * dx, m * dy
        else:
            sg = Q[i, SGN]
            nm, fx, fy = sg * Izz, -sg * hy, sg * hx
        M[:, i, i] = _subspace(Q, i, nm, fx, fy) + Q[i, ARM]      # M_ii = S_i^T F + armature
        for j in range(i - 1, -1, -1):
            fx, fy = _rot(c[:, j + 1], s[:, j + 1], fx, fy)     # F = Xup_{j+1}^T F
            nm = nm + _cross(px[:, j + 1], py[:, j + 1], fx, fy)
            M[:, i, j] = M[:, j, i] = _subspace(Q, j, nm, fx, fy)   # M_ij = S_j^T F
        if i > 0:   # IC_{i-1} = I_{i-1} + IC_i carried into body i-1 (parallel axes, eq. 2.63)
            gx, gy = _rot(c[:, i], s[:, i], hx, hy)              # h_R = Rot h
            p_x, p_y = px[:, i], py[:, i]                        # I' = I + 2 p.h_R + m p.p
            Izz = Q[i - 1, IZ] + Izz + 2.0 * (p_x * gx + p_y * gy) + m * (p_x**2 + p_y**2)
            hx, hy = Q[i - 1, HX] + gx + m * p_x, Q[i - 1, HY] + gy + m * p_y   # h' = h_R + m p
            m = Q[i - 1, MASS] + m
    return M[0] if single else M


def _subspace(Q, j, nm, fx, fy):
    """S_j^T (n; f): SGN n (revolute) or d . f (prismatic)."""
    return Q[j, DX] * fx + Q[j, DY] * fy if Q[j, KIND] == 1.0 else Q[j, SGN] * nm
