"""The yardstick of the batch rows (issue 29): what a plain scalar implementation does, how
many floating-point operations each algorithm takes, and what the core can do at most.

- ``scalar_inverse_dynamics``: a textbook recursive Newton-Euler (Luh, Walker and Paul
  1980, in the form of Siciliano et al., *Robotics*, 2009, Sec. 7.5), written here from
  the URDF's own fields (general joint axes by Rodrigues' formula, centers of mass, any
  parent array), compiled with numba, one state after the other. It shares nothing with
  the library's kernels; ``check`` holds it to the library before it is timed.
- ``flops``: the operations of each algorithm on a robot, counted by running plain
  versions of them (Newton-Euler; composite rigid bodies with 3-vectors; the Cholesky
  solve) in Python on numbers that count what is done to them (+, -, *, / and sqrt one
  each; a sine or cosine one each, which flatters no one: libm's cost tens);
  ``derivative_flops``: that Newton-Euler on dual numbers (``Dual``), the operations of
  forward-mode differentiation along the directions alive.
- ``peak``: the core's measured arithmetic rate, a dense matrix product (BLAS dgemm, one
  thread, pinned to the calling core) in a subprocess: 2 n^3 operations over its time.

A batch row then reads "x scalar" (its time over the scalar loop's, same run) and
"x limit" (its time over flops / peak): ratios that carry from machine to machine.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
from numba import njit


# ------------------------------------------------------------------ the algorithms, plain
def _make_rnea(sin, cos, zeros):
    """Newton-Euler over (N, n) states, one after the other; sin, cos and the scratch
    arrays' ``zeros`` given (counted or libm's and NumPy's). Body i's frame is its URDF
    link frame; R, p place it in its parent's."""
    def rnea(parent, R0, p0, axis, prism, m, c, I, arm, g, Q, QD, QDD, TAU):
        n = parent.shape[0]
        R, p = zeros((n, 3, 3)), zeros((n, 3))
        w, dw, a = zeros((n, 3)), zeros((n, 3)), zeros((n, 3))
        f, t = zeros((n, 3)), zeros((n, 3))
        E, ew, edw, ea, rf, rt = zeros((3, 3)), zeros(3), zeros(3), zeros(3), zeros(3), zeros(3)
        for k in range(Q.shape[0]):
            for i in range(n):                       # outward: kinematics and body wrenches
                ux, uy, uz = axis[i, 0], axis[i, 1], axis[i, 2]
                q, qd, qdd = Q[k, i], QD[k, i], QDD[k, i]
                for r in range(3):
                    p[i, r] = p0[i, r]
                if prism[i]:                         # E = (1, u q)
                    for r in range(3):
                        for s in range(3):
                            R[i, r, s] = R0[i, r, s]
                        p[i, r] = p[i, r] + (R0[i, r, 0] * ux + R0[i, r, 1] * uy + R0[i, r, 2] * uz) * q
                else:                                # E = Rot(u, q): c 1 + s [u]x + (1 - c) u u^T
                    sq, cq = sin(q), cos(q)
                    v = 1.0 - cq
                    E[0, 0], E[0, 1], E[0, 2] = cq + v * ux * ux, v * ux * uy - sq * uz, v * ux * uz + sq * uy
                    E[1, 0], E[1, 1], E[1, 2] = v * ux * uy + sq * uz, cq + v * uy * uy, v * uy * uz - sq * ux
                    E[2, 0], E[2, 1], E[2, 2] = v * ux * uz - sq * uy, v * uy * uz + sq * ux, cq + v * uz * uz
                    for r in range(3):
                        for s in range(3):
                            R[i, r, s] = R0[i, r, 0] * E[0, s] + R0[i, r, 1] * E[1, s] + R0[i, r, 2] * E[2, s]
                l = parent[i]
                # the parent's w, dw and origin acceleration a + dw x p + w x (w x p), in body i
                if l < 0:
                    pw, pdw, pa = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-g[0], -g[1], -g[2])
                else:
                    pw = (w[l, 0], w[l, 1], w[l, 2])
                    pdw = (dw[l, 0], dw[l, 1], dw[l, 2])
                    x, y, z = p[i, 0], p[i, 1], p[i, 2]
                    wpx, wpy, wpz = pw[1] * z - pw[2] * y, pw[2] * x - pw[0] * z, pw[0] * y - pw[1] * x
                    pa = (a[l, 0] + pdw[1] * z - pdw[2] * y + pw[1] * wpz - pw[2] * wpy,
                          a[l, 1] + pdw[2] * x - pdw[0] * z + pw[2] * wpx - pw[0] * wpz,
                          a[l, 2] + pdw[0] * y - pdw[1] * x + pw[0] * wpy - pw[1] * wpx)
                for r in range(3):
                    ew[r] = R[i, 0, r] * pw[0] + R[i, 1, r] * pw[1] + R[i, 2, r] * pw[2]
                    edw[r] = R[i, 0, r] * pdw[0] + R[i, 1, r] * pdw[1] + R[i, 2, r] * pdw[2]
                    ea[r] = R[i, 0, r] * pa[0] + R[i, 1, r] * pa[1] + R[i, 2, r] * pa[2]
                if prism[i]:     # w = R^T w_l; dw = R^T dw_l; a += 2 w x (u qd) + u qdd
                    for r in range(3):
                        w[i, r], dw[i, r] = ew[r], edw[r]
                    a[i, 0] = ea[0] + 2.0 * qd * (ew[1] * uz - ew[2] * uy) + qdd * ux
                    a[i, 1] = ea[1] + 2.0 * qd * (ew[2] * ux - ew[0] * uz) + qdd * uy
                    a[i, 2] = ea[2] + 2.0 * qd * (ew[0] * uy - ew[1] * ux) + qdd * uz
                else:            # w = R^T w_l + u qd; dw = R^T dw_l + R^T w_l x u qd + u qdd
                    w[i, 0], w[i, 1], w[i, 2] = ew[0] + ux * qd, ew[1] + uy * qd, ew[2] + uz * qd
                    dw[i, 0] = edw[0] + qd * (ew[1] * uz - ew[2] * uy) + qdd * ux
                    dw[i, 1] = edw[1] + qd * (ew[2] * ux - ew[0] * uz) + qdd * uy
                    dw[i, 2] = edw[2] + qd * (ew[0] * uy - ew[1] * ux) + qdd * uz
                    for r in range(3):
                        a[i, r] = ea[r]
                # the body's wrench about its origin: F = m (a + dw x c + w x (w x c)),
                # N = I_c dw + w x I_c w + c x F  (Newton and Euler at the center of mass)
                wx, wy, wz = w[i, 0], w[i, 1], w[i, 2]
                dx, dy, dz = dw[i, 0], dw[i, 1], dw[i, 2]
                cx, cy, cz = c[i, 0], c[i, 1], c[i, 2]
                wcx, wcy, wcz = wy * cz - wz * cy, wz * cx - wx * cz, wx * cy - wy * cx
                Fx = m[i] * (a[i, 0] + dy * cz - dz * cy + wy * wcz - wz * wcy)
                Fy = m[i] * (a[i, 1] + dz * cx - dx * cz + wz * wcx - wx * wcz)
                Fz = m[i] * (a[i, 2] + dx * cy - dy * cx + wx * wcy - wy * wcx)
                Lx = I[i, 0, 0] * wx + I[i, 0, 1] * wy + I[i, 0, 2] * wz
                Ly = I[i, 1, 0] * wx + I[i, 1, 1] * wy + I[i, 1, 2] * wz
                Lz = I[i, 2, 0] * wx + I[i, 2, 1] * wy + I[i, 2, 2] * wz
                f[i, 0], f[i, 1], f[i, 2] = Fx, Fy, Fz
                t[i, 0] = (I[i, 0, 0] * dx + I[i, 0, 1] * dy + I[i, 0, 2] * dz + wy * Lz - wz * Ly
                           + cy * Fz - cz * Fy)
                t[i, 1] = (I[i, 1, 0] * dx + I[i, 1, 1] * dy + I[i, 1, 2] * dz + wz * Lx - wx * Lz
                           + cz * Fx - cx * Fz)
                t[i, 2] = (I[i, 2, 0] * dx + I[i, 2, 1] * dy + I[i, 2, 2] * dz + wx * Ly - wy * Lx
                           + cx * Fy - cy * Fx)
            for i in range(n - 1, -1, -1):           # inward: f_l += R f_i, n_l += R n_i + p x R f_i
                ux, uy, uz = axis[i, 0], axis[i, 1], axis[i, 2]
                if prism[i]:
                    TAU[k, i] = f[i, 0] * ux + f[i, 1] * uy + f[i, 2] * uz + arm[i] * QDD[k, i]
                else:
                    TAU[k, i] = t[i, 0] * ux + t[i, 1] * uy + t[i, 2] * uz + arm[i] * QDD[k, i]
                l = parent[i]
                if l >= 0:
                    for r in range(3):
                        rf[r] = R[i, r, 0] * f[i, 0] + R[i, r, 1] * f[i, 1] + R[i, r, 2] * f[i, 2]
                        rt[r] = R[i, r, 0] * t[i, 0] + R[i, r, 1] * t[i, 1] + R[i, r, 2] * t[i, 2]
                    x, y, z = p[i, 0], p[i, 1], p[i, 2]
                    f[l, 0], f[l, 1], f[l, 2] = f[l, 0] + rf[0], f[l, 1] + rf[1], f[l, 2] + rf[2]
                    t[l, 0] = t[l, 0] + rt[0] + y * rf[2] - z * rf[1]
                    t[l, 1] = t[l, 1] + rt[1] + z * rf[0] - x * rf[2]
                    t[l, 2] = t[l, 2] + rt[2] + x * rf[1] - y * rf[0]
    return rnea


def _dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _minus(a, xs):
    """a - (x0 + x1 + ...), no operation for an empty sum."""
    xs = list(xs)
    if not xs:
        return a
    total = xs[0]
    for x in xs[1:]:
        total = total + x
    return a - total


def _joint_transforms(R0, p0, axis, prism, q, sin, cos):
    """Each joint's R (child axes in the parent's) and p (the child's origin): R0 Rot(u, q)
    and p0 for a revolute joint about u, R0 and p0 + q R0 u for a prismatic one."""
    n = len(q)
    R, p = [None] * n, [None] * n
    for i in range(n):
        u = axis[i]
        if prism[i]:
            R[i] = [[R0[i][r][s] for s in range(3)] for r in range(3)]
            p[i] = [p0[i][r] + _dot3(R0[i][r], u) * q[i] for r in range(3)]
        else:
            sq, cq = sin(q[i]), cos(q[i])
            v = 1.0 - cq
            E = [[cq + v * u[0] * u[0], v * u[0] * u[1] - sq * u[2], v * u[0] * u[2] + sq * u[1]],
                 [v * u[0] * u[1] + sq * u[2], cq + v * u[1] * u[1], v * u[1] * u[2] - sq * u[0]],
                 [v * u[0] * u[2] - sq * u[1], v * u[1] * u[2] + sq * u[0], cq + v * u[2] * u[2]]]
            R[i] = [[_dot3(R0[i][r], [E[k][s] for k in range(3)]) for s in range(3)] for r in range(3)]
            p[i] = [p0[i][r] for r in range(3)]
    return R, p


def _origin_inertias(m, c, I):
    """Each body's first moment h = m c and rotational inertia about its origin
    J = I_c - m [c]x [c]x."""
    h, J = [], []
    for i in range(len(m)):
        h.append([m[i] * c[i][r] for r in range(3)])
        cc = _dot3(c[i], c[i])
        J.append([[I[i][r][s] + m[i] * ((cc - c[i][r] * c[i][s]) if r == s else -(c[i][r] * c[i][s]))
                   for s in range(3)] for r in range(3)])
    return h, J


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _aba(parent, R0, p0, axis, prism, m, c, I, arm, g, q, qd, tau, sin, cos):
    """Forward dynamics by articulated bodies (Featherstone 2008, Table 7.1) in joint frames,
    spatial vectors as (angular; linear) 3-vector pairs, articulated inertias as 3 x 3 blocks
    [[A, B], [B^T, C]] handed to the parent by rotating the blocks and shifting them by p
    (eq. 7.23 with Xup = rot(R^T) xlt(p)); S = (u; 0) or (0; u). For counting only (Python)."""
    n = len(parent)
    R, p = _joint_transforms(R0, p0, axis, prism, q, sin, cos)
    h, J = _origin_inertias(m, c, I)
    Rt = lambda i, x: [R[i][0][r] * x[0] + R[i][1][r] * x[1] + R[i][2][r] * x[2] for r in range(3)]  # noqa: E731
    Rx = lambda i, x: [_dot3(R[i][r], x) for r in range(3)]                                          # noqa: E731
    hx = lambda x: [[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]]                      # noqa: E731
    v, cv, A, B, C, pA = [None] * n, [None] * n, [None] * n, [None] * n, [None] * n, [None] * n
    for i in range(n):                   # pass 1: v_i = Xup v_l + S qd, c_i = v_i x S qd, pA
        l, u = parent[i], axis[i]
        w0, v0 = ([0.0] * 3, [0.0] * 3) if l < 0 else v[l]
        w, vo = Rt(i, w0), Rt(i, [v0[r] + x for r, x in enumerate(_cross(w0, p[i]))])
        su = [x * qd[i] for x in u]
        cv[i] = ([0.0] * 3, _cross(w, su)) if prism[i] else (_cross(w, su), _cross(vo, su))
        v[i] = (w, [vo[r] + su[r] for r in range(3)]) if prism[i] else ([w[r] + su[r] for r in range(3)], vo)
        w, vo = v[i]
        A[i], B[i] = [row[:] for row in J[i]], hx(h[i])
        C[i] = [[m[i] if r == s else 0.0 for s in range(3)] for r in range(3)]
        L = [a + b for a, b in zip([_dot3(J[i][r], w) for r in range(3)], _cross(h[i], vo))]
        Pm = [m[i] * vo[r] + x for r, x in enumerate(_cross(w, h[i]))]
        pA[i] = ([a + b for a, b in zip(_cross(w, L), _cross(vo, Pm))], _cross(w, Pm))
    U, D, uu = [None] * n, [None] * n, [None] * n
    for i in range(n - 1, -1, -1):       # pass 2: U = IA S, D = S^T U, u = tau - S^T pA
        u, l = axis[i], parent[i]
        if prism[i]:
            U[i] = ([_dot3(B[i][r], u) for r in range(3)], [_dot3(C[i][r], u) for r in range(3)])
        else:
            U[i] = ([_dot3(A[i][r], u) for r in range(3)], [_dot3([B[i][k][r] for k in range(3)], u) for r in range(3)])
        Us = U[i][1] if prism[i] else U[i][0]
        D[i] = _dot3(u, Us) + arm[i]
        uu[i] = tau[i] - _dot3(u, pA[i][1] if prism[i] else pA[i][0])
        if l < 0:
            continue
        Ua, Ub = [x / D[i] for x in U[i][0]], [x / D[i] for x in U[i][1]]
        Ia = [[A[i][r][s] - Ua[r] * U[i][0][s] for s in range(3)] for r in range(3)]
        Ib = [[B[i][r][s] - Ua[r] * U[i][1][s] for s in range(3)] for r in range(3)]
        Ic = [[C[i][r][s] - Ub[r] * U[i][1][s] for s in range(3)] for r in range(3)]
        cw, cl = cv[i]                   # pa = pA + Ia c + U u / D
        pa = ([pA[i][0][r] + _dot3(Ia[r], cw) + _dot3(Ib[r], cl) + Ua[r] * uu[i] for r in range(3)],
              [pA[i][1][r] + _dot3([Ib[k][r] for k in range(3)], cw) + _dot3(Ic[r], cl) + Ub[r] * uu[i]
               for r in range(3)])
        # rotate the blocks: R X R^T; then shift by p: C' = C1, B' = B1 + [p]x C1,
        # A' = A1 - B1 [p]x + [p]x B1^T - [p]x C1 [p]x  (written as B' and A1 - B1[p]x + [p]x B'^T)
        rot = lambda X: [[_dot3(R[i][r], [_dot3(X[a], R[i][s]) for a in range(3)]) for s in range(3)] for r in range(3)]  # noqa: E731
        A1, B1, C1 = rot(Ia), rot(Ib), rot(Ic)
        P = hx(p[i])
        PC = [[_dot3(P[r], [C1[k][s] for k in range(3)]) for s in range(3)] for r in range(3)]
        Bp = [[B1[r][s] + PC[r][s] for s in range(3)] for r in range(3)]
        BP = [[_dot3(B1[r], [P[k][s] for k in range(3)]) for s in range(3)] for r in range(3)]
        PB = [[_dot3(P[r], [Bp[s][k] for k in range(3)]) for s in range(3)] for r in range(3)]
        for r in range(3):
            for s in range(3):
                A[l][r][s] = A[l][r][s] + (A1[r][s] - BP[r][s] + PB[r][s])
                B[l][r][s] = B[l][r][s] + Bp[r][s]
                C[l][r][s] = C[l][r][s] + C1[r][s]
        fn, ff = Rx(i, pa[0]), Rx(i, pa[1])          # pA_l += Xup^T pa
        fn = [a + b for a, b in zip(fn, _cross(p[i], ff))]
        pA[l] = ([pA[l][0][r] + fn[r] for r in range(3)], [pA[l][1][r] + ff[r] for r in range(3)])
    acc, qdd = [None] * n, [0.0] * n
    for i in range(n):                   # pass 3: a' = Xup a_l + c, qdd = (u - U^T a') / D
        l, u = parent[i], axis[i]
        a0, l0 = ([0.0] * 3, [-x for x in g]) if l < 0 else acc[l]
        aw = Rt(i, a0)
        al = Rt(i, [l0[r] + x for r, x in enumerate(_cross(a0, p[i]))])
        aw = [aw[r] + cv[i][0][r] for r in range(3)]
        al = [al[r] + cv[i][1][r] for r in range(3)]
        qdd[i] = (uu[i] - (_dot3(U[i][0], aw) + _dot3(U[i][1], al))) / D[i]
        su = [x * qdd[i] for x in u]
        acc[i] = (aw, [al[r] + su[r] for r in range(3)]) if prism[i] else ([aw[r] + su[r] for r in range(3)], al)
    return qdd


def _crba(parent, R0, p0, axis, prism, m, c, I, arm, q, sin, cos):
    """The mass matrix by composite rigid bodies (Walker and Orin 1982; Featherstone 2008,
    Sec. 6.2) with 3-vectors: composite mass, first moment h and rotational inertia J
    about each body's origin; then the unit-acceleration wrench of composite i carried
    inward. For counting only (Python)."""
    n = parent.shape[0]
    R, p = _joint_transforms(R0, p0, axis, prism, q, sin, cos)
    mc = [m[i] for i in range(n)]
    h, J = _origin_inertias(m, c, I)
    for i in range(n - 1, -1, -1):            # composite i into its parent
        l = parent[i]
        if l < 0:
            continue
        Rh = [_dot3(R[i][r], h[i]) for r in range(3)]
        RJ = [[_dot3(R[i][r], [J[i][k][s] for k in range(3)]) for s in range(3)] for r in range(3)]
        RJR = [[_dot3(RJ[r], R[i][s]) for s in range(3)] for r in range(3)]
        x = p[i]
        # J' = R J R^T - m [p]x[p]x - [p]x[Rh]x - [Rh]x[p]x; h' = R h + m p
        xx, xh = _dot3(x, x), _dot3(x, Rh)
        for r in range(3):
            for s in range(3):
                extra = mc[i] * (xx - x[r] * x[s]) + 2.0 * xh if r == s else -(mc[i] * x[r] * x[s])
                J[l][r][s] = J[l][r][s] + RJR[r][s] + extra - x[r] * Rh[s] - Rh[r] * x[s]
        for r in range(3):
            h[l][r] = h[l][r] + Rh[r] + mc[i] * x[r]
        mc[l] = mc[l] + mc[i]
    M = [[0.0] * n for _ in range(n)]
    for i in range(n):
        u = axis[i]
        if prism[i]:    # n = h x u, f = m u
            f = [mc[i] * u[r] for r in range(3)]
            t = [h[i][1] * u[2] - h[i][2] * u[1], h[i][2] * u[0] - h[i][0] * u[2],
                 h[i][0] * u[1] - h[i][1] * u[0]]
        else:           # n = J u, f = u x h
            f = [u[1] * h[i][2] - u[2] * h[i][1], u[2] * h[i][0] - u[0] * h[i][2],
                 u[0] * h[i][1] - u[1] * h[i][0]]
            t = [_dot3(J[i][r], u) for r in range(3)]
        M[i][i] = _dot3(f if prism[i] else t, u) + arm[i]
        j = i
        while parent[j] >= 0:                   # carried to each ancestor
            Rf = [_dot3(R[j][r], f) for r in range(3)]
            Rt = [_dot3(R[j][r], t) for r in range(3)]
            x = p[j]
            t = [Rt[0] + x[1] * Rf[2] - x[2] * Rf[1], Rt[1] + x[2] * Rf[0] - x[0] * Rf[2],
                 Rt[2] + x[0] * Rf[1] - x[1] * Rf[0]]
            f = Rf
            j = parent[j]
            uj = axis[j]
            M[i][j] = M[j][i] = _dot3(f if prism[j] else t, uj)
    return M


def _cholesky_solve(M, b):
    """M x = b by Cholesky (L L^T), the textbook loops; for counting only."""
    n = len(b)
    L = [[0.0] * n for _ in range(n)]
    for j in range(n):
        d = _minus(M[j][j], (L[j][k] * L[j][k] for k in range(j)))
        L[j][j] = d.sqrt() if hasattr(d, "sqrt") else math.sqrt(d)
        for i in range(j + 1, n):
            L[i][j] = _minus(M[i][j], (L[i][k] * L[j][k] for k in range(j))) / L[j][j]
    y = [0.0] * n
    for i in range(n):
        y[i] = _minus(b[i], (L[i][k] * y[k] for k in range(i))) / L[i][i]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        x[i] = _minus(y[i], (L[k][i] * x[k] for k in range(i + 1, n))) / L[i][i]
    return x


# ------------------------------------------------------------------ counting
class Flop:
    """A number that counts the floating-point operations done on it (one shared tally)."""
    count = 0
    __slots__ = ("x",)

    def __init__(self, x):
        self.x = float(x)

    @staticmethod
    def _v(y):
        return y.x if isinstance(y, Flop) else float(y)

    def _op(self, y, f):
        Flop.count += 1
        return Flop(f(self.x, Flop._v(y)))

    def __add__(self, y): return self._op(y, lambda a, b: a + b)
    def __radd__(self, y): return self._op(y, lambda a, b: b + a)
    def __sub__(self, y): return self._op(y, lambda a, b: a - b)
    def __rsub__(self, y): return self._op(y, lambda a, b: b - a)
    def __mul__(self, y): return self._op(y, lambda a, b: a * b)
    def __rmul__(self, y): return self._op(y, lambda a, b: b * a)
    def __truediv__(self, y): return self._op(y, lambda a, b: a / b)
    def __rtruediv__(self, y): return self._op(y, lambda a, b: b / a)
    def __neg__(self): return self._op(0.0, lambda a, b: -a)
    def __float__(self): return self.x

    def sqrt(self):
        return self._op(0.0, lambda a, b: math.sqrt(a))

    @staticmethod
    def sin(y):
        Flop.count += 1
        return Flop(math.sin(Flop._v(y)))

    @staticmethod
    def cos(y):
        Flop.count += 1
        return Flop(math.cos(Flop._v(y)))


class Dual:
    """A number with its tangents along the directions it depends on (a dict: direction ->
    tangent), counting the operations that forward-mode differentiation does: one for the
    value as ``Flop``, and on each live direction those of the rule (a sum: one where both
    terms have the direction; a product: a v' + b u' three, one where one factor has it; a
    quotient (u' - r v') / b three, one or two; sin, cos: the other one for the derivative,
    then one a direction). Directions never touched cost nothing: the count is that of the
    sparse forward mode the library runs (``core/derivatives.py``: at body k only the
    directions of joints 0..k are alive)."""
    count = 0
    __slots__ = ("x", "t")

    def __init__(self, x, t=None):
        self.x, self.t = float(x), ({} if t is None else t)

    @staticmethod
    def of(y):
        return y if isinstance(y, Dual) else Dual(y)

    def __add__(self, y):
        y = Dual.of(y)
        t = dict(self.t)
        for d, v in y.t.items():
            if d in t:
                t[d] += v
                Dual.count += 1
            else:
                t[d] = v
        Dual.count += 1
        return Dual(self.x + y.x, t)

    __radd__ = __add__

    def __neg__(self):
        Dual.count += 1 + len(self.t)
        return Dual(-self.x, {d: -v for d, v in self.t.items()})

    def __sub__(self, y):
        y = Dual.of(y)
        t = dict(self.t)
        for d, v in y.t.items():
            t[d] = t[d] - v if d in t else -v
            Dual.count += 1
        Dual.count += 1
        return Dual(self.x - y.x, t)

    def __rsub__(self, y):
        return Dual.of(y) - self

    def __mul__(self, y):
        y = Dual.of(y)
        t = {}
        for d in self.t.keys() | y.t.keys():
            u, v = self.t.get(d), y.t.get(d)
            if u is not None and v is not None:
                t[d] = self.x * v + y.x * u
                Dual.count += 3
            else:
                t[d] = y.x * u if v is None else self.x * v
                Dual.count += 1
        Dual.count += 1
        return Dual(self.x * y.x, t)

    __rmul__ = __mul__

    def __truediv__(self, y):
        y = Dual.of(y)
        r = self.x / y.x
        t = {}
        for d in self.t.keys() | y.t.keys():
            u, v = self.t.get(d, 0.0), y.t.get(d)
            t[d] = (u - r * v) / y.x if v is not None else u / y.x
            Dual.count += (3 if d in self.t else 2) if v is not None else 1
        Dual.count += 1
        return Dual(r, t)

    def __rtruediv__(self, y):
        return Dual.of(y) / self

    @staticmethod
    def sin(y):
        y = Dual.of(y)
        c = math.cos(y.x)
        Dual.count += 2 + len(y.t)
        return Dual(math.sin(y.x), {d: c * v for d, v in y.t.items()})

    @staticmethod
    def cos(y):
        y = Dual.of(y)
        s = math.sin(y.x)
        Dual.count += 2 + len(y.t)
        return Dual(math.cos(y.x), {d: -s * v for d, v in y.t.items()})


def derivative_flops(robot, seed=0):
    """Operations of one state of the derivatives of inverse dynamics: the plain Newton-Euler
    on ``Dual`` numbers seeded along q_j and qd_j (2n directions), checked against the
    library's d tau/d q and d tau/d qd first."""
    parent, R0, p0, axis, prism, m, c, I, arm, g = model_arrays(robot)
    n = len(parent)
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-1, 1, (1, n)) for _ in range(3))
    seeded = lambda x, k: np.array([[Dual(x[0, j], {k * n + j: 1.0}) for j in range(n)]],   # noqa: E731
                                   dtype=object)
    const = lambda x: np.array([Dual(v) for v in np.ravel(x)], dtype=object).reshape(np.shape(x))  # noqa: E731,E501
    rnea = _make_rnea(Dual.sin, Dual.cos, lambda shape: np.zeros(shape, dtype=object))
    tau = np.empty((1, n), dtype=object)
    Dual.count = 0
    rnea(parent, *map(const, (R0, p0, axis)), prism, *map(const, (m, c, I, arm, g)),
         seeded(q, 0), seeded(qd, 1), const(qdd), tau)
    ops = Dual.count
    D = np.array([[tau[0, i].t.get(d, 0.0) for d in range(2 * n)] for i in range(n)])
    dq, dqd = robot.inverse_dynamics_derivatives(q[0], qd[0], qdd[0])
    check("the counted derivatives", D, np.hstack([dq, dqd]))
    return ops


def model_arrays(robot):
    """The URDF-frame fields the plain algorithms read: parent, R, p, axis, prismatic,
    mass, com, inertia about the com, armature, gravity."""
    m = robot.model
    if m.floating or m.has_mimic_joints:
        raise ValueError("the yardstick is written for a fixed base without mimic joints")
    arm = np.zeros(m.dof) if m.armature is None else np.asarray(m.armature, float)
    parent = np.asarray(m.parent if m.parent is not None else np.arange(m.dof) - 1, np.int64)
    return (parent, np.asarray(m.R_parent, float), np.asarray(m.p_parent, float),
            np.asarray(m.axis, float), np.array([t == "prismatic" for t in m.joint_types]),
            np.asarray(m.mass, float), np.asarray(m.com, float), np.asarray(m.inertia, float),
            arm, np.asarray(m.gravity, float))


def _counted(x):
    return np.array([Flop(v) for v in np.ravel(x)], dtype=object).reshape(np.shape(x))


def flops(robot, seed=0):
    """Operations of one state, by algorithm: inverse dynamics (Newton-Euler), the mass
    matrix (composite rigid bodies), forward dynamics (mass matrix, Newton-Euler at qdd = 0
    for the bias, Cholesky solve) and forward dynamics by articulated bodies."""
    parent, R0, p0, axis, prism, m, c, I, arm, g = model_arrays(robot)
    n = len(parent)
    rng = np.random.default_rng(seed)
    q, qd, qdd = (rng.uniform(-1, 1, (1, n)) for _ in range(3))
    model = (parent, *map(_counted, (R0, p0, axis)), prism, *map(_counted, (m, c, I, arm, g)))
    rnea = _make_rnea(Flop.sin, Flop.cos, lambda shape: np.zeros(shape, dtype=object))
    tau = np.empty((1, n), dtype=object)
    Flop.count = 0
    rnea(*model, _counted(q), _counted(qd), _counted(qdd), tau)
    id_ops = Flop.count
    Flop.count = 0
    M = _crba(*model[:-1], list(_counted(q[0])), Flop.sin, Flop.cos)
    m_ops = Flop.count
    Flop.count = 0
    rnea(*model, _counted(q), _counted(qd), _counted(np.zeros((1, n))), tau)
    bias_ops = Flop.count
    Flop.count = 0
    _cholesky_solve(M, list(_counted(np.ones(n))))
    solve_ops = Flop.count
    Flop.count = 0
    _aba(*model, list(_counted(q[0])), list(_counted(qd[0])), list(_counted(qdd[0])), Flop.sin, Flop.cos)
    aba_ops = Flop.count
    # the counted algorithms give the library's answers (checked on plain floats)
    tau_f = np.empty((1, n))
    _make_rnea(math.sin, math.cos, np.zeros)(parent, R0, p0, axis, prism, m, c, I, arm, g, q, qd, qdd, tau_f)
    M_f = np.array(_crba(parent, R0, p0, axis, prism, m, c, I, arm, list(q[0]), math.sin, math.cos))
    check("the counted Newton-Euler", tau_f[0], robot.inverse_dynamics(q[0], qd[0], qdd[0]))
    check("the counted composite rigid bodies", M_f, robot.mass_matrix(q[0]))
    a_f = _aba(parent, R0, p0, axis, prism, m, c, I, arm, g, list(q[0]), list(qd[0]), list(qdd[0]),
               math.sin, math.cos)
    check("the counted articulated bodies", np.array(a_f),
          robot.forward_dynamics(q[0], qd[0], qdd[0], method="aba"))
    return {"inverse dynamics": id_ops, "mass matrix": m_ops,
            "forward dynamics": m_ops + bias_ops + solve_ops,
            "forward dynamics (articulated bodies)": aba_ops}


# ------------------------------------------------------------------ timing the plain loop
scalar_rnea = njit(cache=True)(_make_rnea(math.sin, math.cos, np.zeros))


def scalar_inverse_dynamics(robot, Q, QD, QDD):
    """The plain scalar Newton-Euler of N states (N, n), compiled, one after the other."""
    tau = np.empty(Q.shape)
    scalar_rnea(*model_arrays(robot), np.ascontiguousarray(Q), np.ascontiguousarray(QD),
                np.ascontiguousarray(QDD), tau)
    return tau


def check(what, ours, library, tol=1e-10):
    err = np.max(np.abs(np.asarray(ours, float) - library)) / max(1.0, np.max(np.abs(library)))
    if not err <= tol:
        raise AssertionError(f"{what} differs from the library by {err:.2e} (relative)")
    return err


# ------------------------------------------------------------------ the core's peak
_PEAK = """
import os, time, numpy as np
os.sched_setaffinity(0, {{{cpu}}})
n = 1024
a, b = np.random.default_rng(0).random((2, n, n))
c = a @ b
best = min((lambda t0: (a @ b, time.perf_counter() - t0)[1])(time.perf_counter()) for _ in range(8))
print(2.0 * n ** 3 / best)
"""


def peak(cpu=None):
    """Floating-point operations a second of a dense matrix product (BLAS dgemm, n = 1024,
    best of 8) on one thread pinned to ``cpu`` (default: the first this process may use)."""
    cpu = sorted(os.sched_getaffinity(0))[0] if cpu is None else cpu
    env = {**os.environ, **{k: "1" for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                              "MKL_NUM_THREADS", "BLIS_NUM_THREADS")}}
    out = subprocess.run([sys.executable, "-c", _PEAK.format(cpu=cpu)], env=env, check=True,
                         capture_output=True, text=True)
    return float(out.stdout.split()[-1])


# ------------------------------------------------------------------ packed instructions
_ASM = """
import collections, json, re, sys
from serial_dynamics.core import (aba_lanes, crba_lanes, derivatives_lanes, forward_lanes, rnea_lanes,
                                  tree_derivatives_lanes, tree_lanes)
from serial_dynamics.core.signatures import compile_internal
out = {}
for mod, name in [(rnea_lanes, "rnea_block"), (crba_lanes, "crba_block"), (forward_lanes, "fd_block"),
                  (aba_lanes, "aba_block"),
                  (derivatives_lanes, "derivatives_block"), (tree_lanes, "tree_rnea_block"),
                  (tree_lanes, "tree_crba_block"), (tree_lanes, "tree_fd_block"),
                  (tree_derivatives_lanes, "tree_derivatives_block")]:
    compile_internal([name])
    f = getattr(mod, name)
    asm = f.inspect_asm(f.signatures[0])
    ops = re.findall(r"\\b(v(?:mul|add|sub|div|sqrt|fn?m(?:add|sub)\\d+)(pd|sd))\\s+%?([xyz]mm)", asm)
    c = collections.Counter((o[1], o[2]) for o in ops)
    out[name] = {"packed ymm/zmm": c[("pd", "ymm")] + c[("pd", "zmm")], "packed xmm": c[("pd", "xmm")],
                 "scalar": sum(v for (k, r), v in c.items() if k == "sd")}
print(json.dumps(out))
"""


def packed_instructions():
    """The arithmetic instructions in the machine code of each SIMD-lane block kernel,
    compiled afresh in a subprocess (numba shows no assembly for cached code): packed on
    4 or 8 doubles (ymm, zmm registers), packed on 2 (xmm), scalar. The scalar ones are
    the loops' remainders and the fallbacks LLVM keeps for lanes whose arrays overlap,
    which a batch never takes: a count of instructions, not of time."""
    import json
    import tempfile
    with tempfile.TemporaryDirectory() as cache:
        out = subprocess.run([sys.executable, "-c", _ASM], env={**os.environ, "NUMBA_CACHE_DIR": cache},
                             check=True, capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])
