"""Compiled kernels (numba): inverse dynamics, mass matrix, forward dynamics, fixed-step loop.

The algorithms are the same as the NumPy reference implementations in ``algorithms/``
(which stay the readable definition and the test oracle); here they are written as scalar
loops over 3-vectors so that a call costs a few hundred nanoseconds instead of hundreds of
NumPy calls. Equations:

- inverse dynamics: recursive Newton-Euler in body frames, gravity as a base acceleration
  (Luh, Walker & Paul, 1980; Featherstone, *Rigid Body Dynamics Algorithms*, 2008, Sec. 5.3);
- mass matrix: composite-rigid-body algorithm in body frames (Featherstone 2008, Sec. 6.2);
- forward dynamics: M qdd = tau - b by Cholesky (Featherstone 2008, Sec. 6.3), or the
  articulated-body algorithm, O(n) (Featherstone 2008, Sec. 7.3), chosen by chain length.

Packing (``pack``, once per model): every body frame is rotated by a constant ``A_i`` with
``A_i e_z = axis_i`` so that every joint moves about or along its local z (the joint
rotation is then ``Rz(q)``, and S = e_z). Joint torques do not depend on the frames in
which the recursion runs, so the results equal the reference's up to round-off. Per body
(one row of ``P``): parent-to-joint rotation ``Rp' = A_{i-1}^T Rp_i A_i`` (row-major), its
translation ``A_{i-1}^T p_i``, the joint kind, mass ``m``, first moment ``h = m c`` and the
rotational inertia about the body origin ``I_o = I_c + m ([c]x)^T [c]x`` (xx yy zz xy xz yz).
The last row holds gravity (base frame) and the tip point (last body's aligned frame).

Calling convention. A numba call costs ~100 ns plus ~35 ns per array argument, so the
single-state entry points take few arrays: ``PW`` is one array holding the packed model
(rows 0..n, ``P``) followed by the scratch memory of single calls (rows n+1.., ``W``);
``pack`` builds it once per Robot. Inputs are C-contiguous float64 arrays; results are
written into ``out`` and the return value is a status: 0 = ok, 1 = a NaN/Inf in an input
(the caller then raises the reference's ValueError naming it), 2 = wrong length. Flags:
bit 0 = use qd, bit 1 = use qdd, bit 2 = use the tip wrench (single calls: stored by the
caller in ``wrench_row(PW)``), bit 3 = forward dynamics by ABA instead of Cholesky, bit 4 =
forward dynamics with joint armature (row 2n+4 of the scratch; the fixed-step loop uses it
for implicit damping). Batch
kernels take (N, n) inputs, or (1, n) to broadcast one row over the batch, and their own
scratch memory (allocated once per call, outside the loop).

Entry points are compiled on first use with explicit signatures and ``cache=True``
(a compile takes seconds once; loading from the numba cache in ``__pycache__`` takes
milliseconds); ``warmup()`` loads all of them.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from .model import PRISMATIC

# ------------------------------------------------------------------ packed layout
RP, PP, KIND, MASS, H, IO = 0, 9, 12, 13, 14, 17      # per-body row of P
NPOS = 23                                             # P[0, NPOS] = n, P[1, NPOS] = B (lanes)
PWIDTH = 24                                           # columns used by P
G, TIPP = 0, 3                                        # last row of P
# workspace row of body i
WR, WP, WF, WN = 0, 9, 12, 15                         # joint rotation, translation; body force, moment
AV, AC, AIA, APA, AU, AD, AUU = 20, 26, 32, 68, 74, 80, 81   # ABA: v, c, IA (6x6), pA, U, D, u
WRENCH = 60                                           # W[2n+1, WRENCH:+6]: tip wrench
WW = 82

F_QD, F_QDD, F_W, F_ABA, F_ARM = 1, 2, 4, 8, 16

# Only fused multiply-add is allowed (about 4% faster); no other fast-math flag, so that NaN
# and Inf propagate and the input checks (x * 0.0 is NaN iff x is NaN or Inf) hold.
_FM = {"contract"}



@njit(cache=True, fastmath=_FM)
def _workspace(n):
    """Scratch memory of one evaluation: n body rows, an n x n matrix, a vector, a scratch
    row, sin q, cos q and joint armature."""
    return np.zeros((2 * n + 5, max(WW, n)))


@njit(cache=True, fastmath=_FM, inline="always")
def _split(PW):
    """n, P (the first n + 1 rows: PW itself) and the view W of the packed array."""
    n = int(PW[0, NPOS])
    return n, PW, PW[n + 1:]


def _frame_for_axis(a):
    """A rotation A with A e_z = a (identity when a is already e_z)."""
    a = np.asarray(a, dtype=float)
    if np.array_equal(a, [0.0, 0.0, 1.0]):
        return np.eye(3)
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    b1 = np.cross(helper, a)
    b1 /= np.linalg.norm(b1)
    return np.column_stack([b1, np.cross(a, b1), a])


def pack(model) -> np.ndarray:
    """``PW``: the model's data in the aligned body frames (rows 0..n) followed by the
    scratch memory of single calls (rows n+1 .. 3n+2). Never shared between threads
    (single-state kernels hold the GIL)."""
    n = model.dof
    PW = np.zeros((3 * n + 6, max(WW, n, PWIDTH)))
    P = PW[:n + 1]
    A_prev = np.eye(3)
    for i in range(n):
        A = _frame_for_axis(model.axis[i])
        Rp = A_prev.T @ model.R_parent[i] @ A
        c = A.T @ model.com[i]
        Ic = A.T @ model.inertia[i] @ A
        m = model.mass[i]
        Io = Ic + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))   # parallel axes
        P[i, RP:RP + 9] = Rp.ravel()
        P[i, PP:PP + 3] = A_prev.T @ model.p_parent[i]
        P[i, KIND] = 1.0 if model.kind[i] == PRISMATIC else 0.0
        P[i, MASS] = m
        P[i, H:H + 3] = m * c
        P[i, IO:IO + 6] = Io[0, 0], Io[1, 1], Io[2, 2], Io[0, 1], Io[0, 2], Io[1, 2]
        A_prev = A
    P[n, G:G + 3] = model.gravity
    P[n, TIPP:TIPP + 3] = A_prev.T @ model.tip_p
    P[0, NPOS] = n
    P[1, NPOS] = B
    return PW


def wrench_row(PW):
    """Where a single-state call reads the tip wrench (flag F_W) from."""
    n = int(PW[0, NPOS])
    return PW[n + 1 + 2 * n + 1, WRENCH:WRENCH + 6]


# ------------------------------------------------------------------ sine and cosine
def _pio2_parts():
    """pi/2 = C1 + C2 + C3 with C1, C2 of 26 significant bits, so that k*C1 and k*C2 are
    exact for |k| < 2^27 (Cody-Waite argument reduction)."""
    from decimal import Decimal, getcontext
    getcontext().prec = 60
    pio2 = Decimal("3.14159265358979323846264338327950288419716939937510582097494459") / 2

    def hi(x):                                  # x rounded down to 26 significant bits
        m, e = math.frexp(x)
        return math.ldexp(math.floor(math.ldexp(m, 26)), e - 26)

    c1 = hi(float(pio2))
    c2 = hi(float(pio2 - Decimal(c1)))
    return c1, c2, float(pio2 - Decimal(c1) - Decimal(c2)), float(1 / pio2)


_C1, _C2, _C3, _TWO_OVER_PI = _pio2_parts()
# Taylor coefficients (-1)^k / (2k+1)! (sine, r^3..r^17) and (-1)^k / (2k)! (cosine, r^4..r^18):
# on |r| <= pi/4 the first omitted terms are below 1e-19.
_S1, _S2, _S3, _S4, _S5, _S6, _S7, _S8 = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9)]
_K2, _K3, _K4, _K5, _K6, _K7, _K8, _K9 = [(-1.0) ** k / math.factorial(2 * k) for k in range(2, 10)]


@njit(cache=True, fastmath=_FM, inline="always")
def _sincos(x):
    """(sin x, cos x) together, to ~1 ulp, for |x| < 1e5: x = k pi/2 + r, |r| <= pi/4,
    Taylor series in r (Estrin's scheme: short dependency chains), quadrant k mod 4 by
    compares and selects (no branches). About half the cost of libm's sin and cos here."""
    k = math.floor(x * _TWO_OVER_PI + 0.5)
    r = ((x - k * _C1) - k * _C2) - k * _C3
    z = r * r
    z2 = z * z
    z4 = z2 * z2
    ps = ((_S1 + z * _S2) + z2 * (_S3 + z * _S4)) + z4 * ((_S5 + z * _S6) + z2 * (_S7 + z * _S8))
    pc = ((_K2 + z * _K3) + z2 * (_K4 + z * _K5)) + z4 * ((_K6 + z * _K7) + z2 * (_K8 + z * _K9))
    s = r + r * z * ps
    c = 1.0 - 0.5 * z + z2 * pc
    j = k - 4.0 * math.floor(0.25 * k)   # k mod 4, as a float
    odd = k - 2.0 * math.floor(0.5 * k) == 1.0
    ss = c if odd else s                 # sin(r + k pi/2): s, c, -s, -c for k = 0, 1, 2, 3
    cc = s if odd else c                 # cos(r + k pi/2): c, -s, -c, s
    return (-ss if j >= 2.0 else ss), (-cc if abs(j - 1.5) < 1.0 else cc)   # (one compare each)


@njit(cache=True, fastmath=_FM, inline="always")
def _trig(W, q, n):
    """sin q_i, cos q_i of every joint into rows SIN, COS of W. Returns 0.0, or NaN if
    some q_i is NaN or Inf (then x * 0.0 is NaN)."""
    small = True
    for i in range(n):
        small &= abs(q[i]) < 1e5
    sn, cs = W[2 * n + 2], W[2 * n + 3]
    if small:
        for i in range(n):
            sn[i], cs[i] = _sincos(q[i])
        return 0.0
    chk = 0.0                            # huge, NaN or Inf angles: libm's argument reduction
    for i in range(n):
        chk += q[i] * 0.0
        sn[i], cs[i] = math.sin(q[i]), math.cos(q[i])
    return chk


# ------------------------------------------------------------------ shared cores
@njit(cache=True, fastmath=_FM, inline="always")
def _joint(P, W, i, qi, n):
    """Body i's rotation R = Rp' Rz(q) (revolute) or Rp' (prismatic) and origin
    p = p' (+ q Rp' e_z) in the parent frame, stored in W[i]."""
    if P[i, KIND] == 0.0:
        s, c = W[2 * n + 2, i], W[2 * n + 3, i]
        for r in range(3):
            a, b = P[i, RP + 3 * r], P[i, RP + 3 * r + 1]
            W[i, WR + 3 * r] = c * a + s * b                 # column 0: c Rp'e_x + s Rp'e_y
            W[i, WR + 3 * r + 1] = c * b - s * a             # column 1: c Rp'e_y - s Rp'e_x
            W[i, WR + 3 * r + 2] = P[i, RP + 3 * r + 2]
            W[i, WP + r] = P[i, PP + r]
    else:
        for r in range(3):
            for k in range(3):
                W[i, WR + 3 * r + k] = P[i, RP + 3 * r + k]
            W[i, WP + r] = P[i, PP + r] + qi * P[i, RP + 3 * r + 2]


@njit(cache=True, fastmath=_FM, inline="always")
def _to_parent(W, j, fx, fy, fz, nx, ny, nz):
    """A force pair (f, n) about body j's origin, in its frame, carried into its parent's
    frame: f' = R_j f, n' = R_j n + p_j x f' (spatial force transform, Featherstone 2008)."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[j, WR], W[j, WR + 1], W[j, WR + 2],
                                          W[j, WR + 3], W[j, WR + 4], W[j, WR + 5],
                                          W[j, WR + 6], W[j, WR + 7], W[j, WR + 8])
    px, py, pz = W[j, WP], W[j, WP + 1], W[j, WP + 2]
    fx, fy, fz = r0 * fx + r1 * fy + r2 * fz, r3 * fx + r4 * fy + r5 * fz, r6 * fx + r7 * fy + r8 * fz
    nx, ny, nz = r0 * nx + r1 * ny + r2 * nz, r3 * nx + r4 * ny + r5 * nz, r6 * nx + r7 * ny + r8 * nz
    return fx, fy, fz, nx + py * fz - pz * fy, ny + pz * fx - px * fz, nz + px * fy - py * fx


@njit(cache=True, fastmath=_FM)
def _rnea_core(P, W, q, qd, qdd, flags, tau):
    """Recursive Newton-Euler (same equations as algorithms/rnea.py). Fills W's joint
    transforms on the way. Returns 0.0, or NaN if an input is NaN/Inf."""
    n = tau.shape[0]
    use_qd, use_qdd, use_w = (flags & F_QD) != 0, (flags & F_QDD) != 0, (flags & F_W) != 0
    chk = 0.0
    wx = wy = wz = 0.0                                  # angular velocity of the previous body
    ax = ay = az = 0.0                                  # its angular acceleration
    lx, ly, lz = -P[n, G], -P[n, G + 1], -P[n, G + 2]   # linear acc. of its origin; base: -g
    fx = fy = fz = mx = my = mz = 0.0                   # tip wrench, carried into each frame
    if use_w:
        w = W[2 * n + 1, WRENCH:WRENCH + 6]
        fx, fy, fz, mx, my, mz = w[0], w[1], w[2], w[3], w[4], w[5]
        chk += fx * 0.0 + fy * 0.0 + fz * 0.0 + mx * 0.0 + my * 0.0 + mz * 0.0
    chk += _trig(W, q, n)
    for i in range(n):
        qi = q[i]
        dq = qd[i] if use_qd else 0.0
        ddq = qdd[i] if use_qdd else 0.0
        chk += dq * 0.0 + ddq * 0.0                      # NaN iff an entry is NaN/Inf
        _joint(P, W, i, qi, n)
        px, py, pz = W[i, WP], W[i, WP + 1], W[i, WP + 2]
        # a + alpha x p + w x (w x p), in the parent frame
        ux, uy, uz = wy * pz - wz * py, wz * px - wx * pz, wx * py - wy * px
        tx = lx + ay * pz - az * py + wy * uz - wz * uy
        ty = ly + az * px - ax * pz + wz * ux - wx * uz
        tz = lz + ax * py - ay * px + wx * uy - wy * ux
        # into body i's frame: x_i = R^T x
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2], W[i, WR + 3],
                                              W[i, WR + 4], W[i, WR + 5], W[i, WR + 6],
                                              W[i, WR + 7], W[i, WR + 8])
        lx, ly, lz = (r0 * tx + r3 * ty + r6 * tz, r1 * tx + r4 * ty + r7 * tz,
                      r2 * tx + r5 * ty + r8 * tz)
        wx, wy, wz = (r0 * wx + r3 * wy + r6 * wz, r1 * wx + r4 * wy + r7 * wz,
                      r2 * wx + r5 * wy + r8 * wz)
        ax, ay, az = (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az,
                      r2 * ax + r5 * ay + r8 * az)
        if use_w:
            fx, fy, fz = (r0 * fx + r3 * fy + r6 * fz, r1 * fx + r4 * fy + r7 * fz,
                          r2 * fx + r5 * fy + r8 * fz)
            mx, my, mz = (r0 * mx + r3 * my + r6 * mz, r1 * mx + r4 * my + r7 * mz,
                          r2 * mx + r5 * my + r8 * mz)
        if P[i, KIND] == 0.0:       # relative spin about z: alpha += w x (qd e_z) + qdd e_z
            ax, ay, az = ax + wy * dq, ay - wx * dq, az + ddq
            wz = wz + dq
        else:                       # relative slide along z: a += 2 w x (qd e_z) + qdd e_z
            lx, ly, lz = lx + 2.0 * wy * dq, ly - 2.0 * wx * dq, lz + ddq
        # body wrench about its origin: f = m a + alpha x h + w x (w x h),
        #                                n = I_o alpha + w x (I_o w) + h x a
        m = P[i, MASS]
        hx, hy, hz = P[i, H], P[i, H + 1], P[i, H + 2]
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (P[i, IO], P[i, IO + 1], P[i, IO + 2], P[i, IO + 3],
                                        P[i, IO + 4], P[i, IO + 5])
        ux, uy, uz = wy * hz - wz * hy, wz * hx - wx * hz, wx * hy - wy * hx
        W[i, WF] = m * lx + ay * hz - az * hy + wy * uz - wz * uy
        W[i, WF + 1] = m * ly + az * hx - ax * hz + wz * ux - wx * uz
        W[i, WF + 2] = m * lz + ax * hy - ay * hx + wx * uy - wy * ux
        Lx = Ixx * wx + Ixy * wy + Ixz * wz
        Ly = Ixy * wx + Iyy * wy + Iyz * wz
        Lz = Ixz * wx + Iyz * wy + Izz * wz
        W[i, WN] = Ixx * ax + Ixy * ay + Ixz * az + wy * Lz - wz * Ly + hy * lz - hz * ly
        W[i, WN + 1] = Ixy * ax + Iyy * ay + Iyz * az + wz * Lx - wx * Lz + hz * lx - hx * lz
        W[i, WN + 2] = Ixz * ax + Iyz * ay + Izz * az + wx * Ly - wy * Lx + hx * ly - hy * lx
    # inward recursion; the tip load -w acts on the environment (as in algorithms/rnea.py)
    if use_w:
        tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
        fx, fy, fz, mx, my, mz = -fx, -fy, -fz, -mx, -my, -mz
        mx, my, mz = mx + tpy * fz - tpz * fy, my + tpz * fx - tpx * fz, mz + tpx * fy - tpy * fx
    for i in range(n - 1, -1, -1):
        if i < n - 1:               # the outboard joint's force into body i's frame
            fx, fy, fz, mx, my, mz = _to_parent(W, i + 1, fx, fy, fz, mx, my, mz)
        fx, fy, fz = fx + W[i, WF], fy + W[i, WF + 1], fz + W[i, WF + 2]
        mx, my, mz = mx + W[i, WN], my + W[i, WN + 1], mz + W[i, WN + 2]
        tau[i] = mz if P[i, KIND] == 0.0 else fz          # tau_i = e_z . (n | f)
    return chk


@njit(cache=True, fastmath=_FM)
def _crba_core(P, W, M):
    """Composite-rigid-body algorithm in body frames; W holds the joint transforms. In a
    chain, composite i-1 = body i-1 + composite i, so the composite (m, h, I_o) is carried
    in registers from the tip to the base."""
    n = M.shape[0]
    k = n - 1
    m, hx, hy, hz = P[k, MASS], P[k, H], P[k, H + 1], P[k, H + 2]
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (P[k, IO], P[k, IO + 1], P[k, IO + 2], P[k, IO + 3],
                                    P[k, IO + 4], P[k, IO + 5])
    for i in range(n - 1, -1, -1):
        # F = I^C S: momentum of composite body i.. moving with a unit joint rate
        if P[i, KIND] == 0.0:       # unit spin about z: f = e_z x h, n = I_o e_z
            fx, fy, fz, nx, ny, nz = -hy, hx, 0.0, Ixz, Iyz, Izz
            M[i, i] = nz
        else:                       # unit slide along z: f = m e_z, n = h x e_z
            fx, fy, fz, nx, ny, nz = 0.0, 0.0, m, hy, -hx, 0.0
            M[i, i] = fz
        j = i
        while j > 1:                # carry F into the parent frame
            fx, fy, fz, nx, ny, nz = _to_parent(W, j, fx, fy, fz, nx, ny, nz)
            j -= 1
            M[j, i] = nz if P[j, KIND] == 0.0 else fz     # M_ji = S_j . F
            M[i, j] = M[j, i]
        if i > 0:                   # last step, into body 0: only S_0 . F is needed
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[1, WR], W[1, WR + 1], W[1, WR + 2],
                                                  W[1, WR + 3], W[1, WR + 4], W[1, WR + 5],
                                                  W[1, WR + 6], W[1, WR + 7], W[1, WR + 8])
            if j == 1:
                if P[0, KIND] == 0.0:
                    gx, gy = r0 * fx + r1 * fy + r2 * fz, r3 * fx + r4 * fy + r5 * fz
                    M[0, i] = r6 * nx + r7 * ny + r8 * nz + W[1, WP] * gy - W[1, WP + 1] * gx
                else:
                    M[0, i] = r6 * fx + r7 * fy + r8 * fz
                M[i, 0] = M[0, i]
            # composite i-1 = body i-1 + composite i carried into frame i-1:
            # h_R = R h; I_R = R I R^T (T = R I, then T R^T)
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2],
                                                  W[i, WR + 3], W[i, WR + 4], W[i, WR + 5],
                                                  W[i, WR + 6], W[i, WR + 7], W[i, WR + 8])
            px, py, pz = W[i, WP], W[i, WP + 1], W[i, WP + 2]
            gx, gy, gz = r0 * hx + r1 * hy + r2 * hz, r3 * hx + r4 * hy + r5 * hz, r6 * hx + r7 * hy + r8 * hz
            if i == 1:              # of composite 0 only S_0 . I^C S_0 is needed
                if P[0, KIND] == 0.0:
                    t6, t7, t8 = r6 * Ixx + r7 * Ixy + r8 * Ixz, r6 * Ixy + r7 * Iyy + r8 * Iyz, r6 * Ixz + r7 * Iyz + r8 * Izz
                    d = 2.0 * (gx * px + gy * py) + m * (px * px + py * py)
                    M[0, 0] = P[0, IO + 2] + t6 * r6 + t7 * r7 + t8 * r8 + d
                else:
                    M[0, 0] = P[0, MASS] + m
                return
            t0, t1, t2 = r0 * Ixx + r1 * Ixy + r2 * Ixz, r0 * Ixy + r1 * Iyy + r2 * Iyz, r0 * Ixz + r1 * Iyz + r2 * Izz
            t3, t4, t5 = r3 * Ixx + r4 * Ixy + r5 * Ixz, r3 * Ixy + r4 * Iyy + r5 * Iyz, r3 * Ixz + r4 * Iyz + r5 * Izz
            t6, t7, t8 = r6 * Ixx + r7 * Ixy + r8 * Ixz, r6 * Ixy + r7 * Iyy + r8 * Iyz, r6 * Ixz + r7 * Iyz + r8 * Izz
            Jxx, Jyy, Jzz = t0 * r0 + t1 * r1 + t2 * r2, t3 * r3 + t4 * r4 + t5 * r5, t6 * r6 + t7 * r7 + t8 * r8
            Jxy, Jxz, Jyz = t0 * r3 + t1 * r4 + t2 * r5, t0 * r6 + t1 * r7 + t2 * r8, t3 * r6 + t4 * r7 + t5 * r8
            # parallel axes to the parent origin:
            # I' = I_R + (2 h_R.p + m p.p) 1 - (h_R p^T + p h_R^T + m p p^T),  h' = h_R + m p
            d = 2.0 * (gx * px + gy * py + gz * pz) + m * (px * px + py * py + pz * pz)
            k = i - 1
            Ixx = P[k, IO] + Jxx + d - 2.0 * gx * px - m * px * px
            Iyy = P[k, IO + 1] + Jyy + d - 2.0 * gy * py - m * py * py
            Izz = P[k, IO + 2] + Jzz + d - 2.0 * gz * pz - m * pz * pz
            Ixy = P[k, IO + 3] + Jxy - gx * py - px * gy - m * px * py
            Ixz = P[k, IO + 4] + Jxz - gx * pz - px * gz - m * px * pz
            Iyz = P[k, IO + 5] + Jyz - gy * pz - py * gz - m * py * pz
            hx = P[k, H] + gx + m * px
            hy = P[k, H + 1] + gy + m * py
            hz = P[k, H + 2] + gz + m * pz
            m = P[k, MASS] + m


@njit(cache=True, fastmath=_FM)
def _cholesky_solve(L, b, x):
    """Solve M x = b in place: L (n x n) holds M on entry, its Cholesky factor after."""
    n = b.shape[0]
    for j in range(n):                   # M = L L^T, column by column
        s = L[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = L[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    for i in range(n):                   # L y = b
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):       # L^T x = y
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True, fastmath=_FM)
def _fd_cholesky(P, W, q, qd, tau, flags, out):
    """qdd = M^-1 (tau - b): b by Newton-Euler at zero acceleration, M by the CRBA."""
    n = out.shape[0]
    b = W[2 * n, :n]
    chk = _rnea_core(P, W, q, qd, q, flags & (F_QD | F_W), b)
    for i in range(n):
        chk += tau[i] * 0.0
        b[i] = tau[i] - b[i]
    L = W[n:2 * n, :n]
    _crba_core(P, W, L)
    if (flags & F_ARM) != 0:             # joint armature: M + diag(arm)
        for i in range(n):
            L[i, i] += W[2 * n + 4, i]
    _cholesky_solve(L, b, out)
    return chk


@njit(cache=True, fastmath=_FM)
def _rot_block(Rm, X, a0, b0, Y):
    """Y = R X_blk R^T for the 3x3 block of the 6x6 X at rows a0.., columns b0.."""
    for a in range(3):
        for b in range(3):
            s = 0.0
            for k in range(3):
                t = 0.0
                for l in range(3):
                    t += X[a0 + k, b0 + l] * Rm[b, l]
                s += Rm[a, k] * t
            Y[a, b] = s


@njit(cache=True, fastmath=_FM)
def _fd_aba(P, W, q, qd, tau, flags, out):
    """Articulated-body algorithm (Featherstone 2008, Table 7.1), spatial vectors
    (angular; linear) in the aligned body frames, S = e_z (index 2 revolute, 5 prismatic).
    Gravity enters as the base acceleration -g."""
    n = out.shape[0]
    use_qd, use_w = (flags & F_QD) != 0, (flags & F_W) != 0
    chk = 0.0
    S = 2 * n + 1                        # scratch row
    Ia = W[S, 0:36].reshape((6, 6))
    Y = W[S, 36:45].reshape((3, 3))
    Rm = W[S, 45:54].reshape((3, 3))
    # --- pass 1, outward: velocities v, velocity-product accelerations c, bias forces pA
    vx = vy = vz = ux = uy = uz = 0.0    # (omega; v) of the previous body
    chk += _trig(W, q, n)
    for i in range(n):
        qi = q[i]
        dq = qd[i] if use_qd else 0.0
        chk += dq * 0.0 + tau[i] * 0.0
        _joint(P, W, i, qi, n)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2], W[i, WR + 3],
                                              W[i, WR + 4], W[i, WR + 5], W[i, WR + 6],
                                              W[i, WR + 7], W[i, WR + 8])
        px, py, pz = W[i, WP], W[i, WP + 1], W[i, WP + 2]
        # v_i = X v_{i-1}: omega = R^T omega, v = R^T (v - p x omega)
        sx, sy, sz = ux - (py * vz - pz * vy), uy - (pz * vx - px * vz), uz - (px * vy - py * vx)
        wx, wy, wz = r0 * vx + r3 * vy + r6 * vz, r1 * vx + r4 * vy + r7 * vz, r2 * vx + r5 * vy + r8 * vz
        ux, uy, uz = r0 * sx + r3 * sy + r6 * sz, r1 * sx + r4 * sy + r7 * sz, r2 * sx + r5 * sy + r8 * sz
        # c = v x (S qd) (motion cross product) and v += S qd
        if P[i, KIND] == 0.0:
            c0, c1, c2, c3, c4, c5 = wy * dq, -wx * dq, 0.0, uy * dq, -ux * dq, 0.0
            wz += dq
        else:
            c0, c1, c2, c3, c4, c5 = 0.0, 0.0, 0.0, wy * dq, -wx * dq, 0.0
            uz += dq
        vx, vy, vz = wx, wy, wz
        W[i, AV], W[i, AV + 1], W[i, AV + 2], W[i, AV + 3], W[i, AV + 4], W[i, AV + 5] = wx, wy, wz, ux, uy, uz
        W[i, AC], W[i, AC + 1], W[i, AC + 2], W[i, AC + 3], W[i, AC + 4], W[i, AC + 5] = c0, c1, c2, c3, c4, c5
        # IA = rigid-body inertia [[I_o, [h]x], [[h]x^T, m 1]]
        m = P[i, MASS]
        hx, hy, hz = P[i, H], P[i, H + 1], P[i, H + 2]
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (P[i, IO], P[i, IO + 1], P[i, IO + 2], P[i, IO + 3],
                                        P[i, IO + 4], P[i, IO + 5])
        IA = W[i, AIA:AIA + 36].reshape((6, 6))
        IA[0, 0], IA[0, 1], IA[0, 2] = Ixx, Ixy, Ixz
        IA[1, 0], IA[1, 1], IA[1, 2] = Ixy, Iyy, Iyz
        IA[2, 0], IA[2, 1], IA[2, 2] = Ixz, Iyz, Izz
        IA[0, 3], IA[0, 4], IA[0, 5] = 0.0, -hz, hy
        IA[1, 3], IA[1, 4], IA[1, 5] = hz, 0.0, -hx
        IA[2, 3], IA[2, 4], IA[2, 5] = -hy, hx, 0.0
        for a in range(3):
            for b in range(3):
                IA[3 + a, b] = IA[b, 3 + a]
                IA[3 + a, 3 + b] = m if a == b else 0.0
        # pA = v x* (I v): momentum L = I_o w + h x u, Pm = m u + w x h;
        # (w, u) x* (L, Pm) = (w x L + u x Pm, w x Pm)
        Lx = Ixx * wx + Ixy * wy + Ixz * wz + hy * uz - hz * uy
        Ly = Ixy * wx + Iyy * wy + Iyz * wz + hz * ux - hx * uz
        Lz = Ixz * wx + Iyz * wy + Izz * wz + hx * uy - hy * ux
        Px = m * ux + wy * hz - wz * hy
        Py = m * uy + wz * hx - wx * hz
        Pz = m * uz + wx * hy - wy * hx
        W[i, APA] = wy * Lz - wz * Ly + uy * Pz - uz * Py
        W[i, APA + 1] = wz * Lx - wx * Lz + uz * Px - ux * Pz
        W[i, APA + 2] = wx * Ly - wy * Lx + ux * Py - uy * Px
        W[i, APA + 3] = wy * Pz - wz * Py
        W[i, APA + 4] = wz * Px - wx * Pz
        W[i, APA + 5] = wx * Py - wy * Px
    if use_w:                            # pA_last -= wrench on the tip, in the last body's frame
        w = W[S, WRENCH:WRENCH + 6]
        fx, fy, fz, mx, my, mz = w[0], w[1], w[2], w[3], w[4], w[5]
        chk += fx * 0.0 + fy * 0.0 + fz * 0.0 + mx * 0.0 + my * 0.0 + mz * 0.0
        for i in range(n):               # base -> last body: x = R^T x
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2],
                                                  W[i, WR + 3], W[i, WR + 4], W[i, WR + 5],
                                                  W[i, WR + 6], W[i, WR + 7], W[i, WR + 8])
            fx, fy, fz = r0 * fx + r3 * fy + r6 * fz, r1 * fx + r4 * fy + r7 * fz, r2 * fx + r5 * fy + r8 * fz
            mx, my, mz = r0 * mx + r3 * my + r6 * mz, r1 * mx + r4 * my + r7 * mz, r2 * mx + r5 * my + r8 * mz
        tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
        k = n - 1
        W[k, APA] -= mx + tpy * fz - tpz * fy
        W[k, APA + 1] -= my + tpz * fx - tpx * fz
        W[k, APA + 2] -= mz + tpx * fy - tpy * fx
        W[k, APA + 3] -= fx
        W[k, APA + 4] -= fy
        W[k, APA + 5] -= fz
    # --- pass 2, inward: articulated inertias and bias forces
    for i in range(n - 1, -1, -1):
        IA = W[i, AIA:AIA + 36].reshape((6, 6))
        s = 2 if P[i, KIND] == 0.0 else 5
        D = IA[s, s]                                        # D = S^T IA S (+ armature)
        if (flags & F_ARM) != 0:
            D += W[2 * n + 4, i]
        u = tau[i] - W[i, APA + s]                          # u = tau - S^T pA
        for a in range(6):
            W[i, AU + a] = IA[a, s]                         # U = IA S
        W[i, AD], W[i, AUU] = D, u
        if i == 0:
            break
        # Ia = IA - U U^T / D ;  pa = pA + Ia c + U u / D
        pa0 = pa1 = pa2 = pa3 = pa4 = pa5 = 0.0
        for a in range(6):
            Ua = W[i, AU + a] / D
            acc = W[i, APA + a] + Ua * u
            for b in range(6):
                Ia[a, b] = IA[a, b] - Ua * W[i, AU + b]
                acc += Ia[a, b] * W[i, AC + b]
            if a == 0:
                pa0 = acc
            elif a == 1:
                pa1 = acc
            elif a == 2:
                pa2 = acc
            elif a == 3:
                pa3 = acc
            elif a == 4:
                pa4 = acc
            else:
                pa5 = acc
        # parent += X^T Ia X: rotate the blocks by R, then shift by p:
        # A' = A1 - B1 [p]x + [p]x B1^T - [p]x C1 [p]x,  B' = B1 + [p]x C1,  C' = C1
        for a in range(3):
            for b in range(3):
                Rm[a, b] = W[i, WR + 3 * a + b]
        px, py, pz = W[i, WP], W[i, WP + 1], W[i, WP + 2]
        k = i - 1
        PA = W[k, AIA:AIA + 36].reshape((6, 6))
        _rot_block(Rm, Ia, 3, 3, Y)                         # C1
        C00, C01, C02, C11, C12, C22 = Y[0, 0], Y[0, 1], Y[0, 2], Y[1, 1], Y[1, 2], Y[2, 2]
        # PC = [p]x C1
        q00, q01, q02 = py * Y[2, 0] - pz * Y[1, 0], py * Y[2, 1] - pz * Y[1, 1], py * Y[2, 2] - pz * Y[1, 2]
        q10, q11, q12 = pz * Y[0, 0] - px * Y[2, 0], pz * Y[0, 1] - px * Y[2, 1], pz * Y[0, 2] - px * Y[2, 2]
        q20, q21, q22 = px * Y[1, 0] - py * Y[0, 0], px * Y[1, 1] - py * Y[0, 1], px * Y[1, 2] - py * Y[0, 2]
        PA[3, 3] += C00
        PA[3, 4] += C01
        PA[3, 5] += C02
        PA[4, 3] += C01
        PA[4, 4] += C11
        PA[4, 5] += C12
        PA[5, 3] += C02
        PA[5, 4] += C12
        PA[5, 5] += C22
        _rot_block(Rm, Ia, 0, 3, Y)                         # B1
        B00, B01, B02, B10, B11, B12, B20, B21, B22 = (Y[0, 0], Y[0, 1], Y[0, 2], Y[1, 0], Y[1, 1],
                                                       Y[1, 2], Y[2, 0], Y[2, 1], Y[2, 2])
        # B' = B1 + PC, and its transpose in the lower-left block
        b00, b01, b02 = B00 + q00, B01 + q01, B02 + q02
        b10, b11, b12 = B10 + q10, B11 + q11, B12 + q12
        b20, b21, b22 = B20 + q20, B21 + q21, B22 + q22
        PA[0, 3] += b00
        PA[0, 4] += b01
        PA[0, 5] += b02
        PA[1, 3] += b10
        PA[1, 4] += b11
        PA[1, 5] += b12
        PA[2, 3] += b20
        PA[2, 4] += b21
        PA[2, 5] += b22
        PA[3, 0] += b00
        PA[4, 0] += b01
        PA[5, 0] += b02
        PA[3, 1] += b10
        PA[4, 1] += b11
        PA[5, 1] += b12
        PA[3, 2] += b20
        PA[4, 2] += b21
        PA[5, 2] += b22
        # Q = B1 [p]x  (column k of [p]x is e_k x ... : ([p]x)_{:,0} = (0, pz, -py), etc.)
        e00, e01, e02 = B01 * pz - B02 * py, B02 * px - B00 * pz, B00 * py - B01 * px
        e10, e11, e12 = B11 * pz - B12 * py, B12 * px - B10 * pz, B10 * py - B11 * px
        e20, e21, e22 = B21 * pz - B22 * py, B22 * px - B20 * pz, B20 * py - B21 * px
        # PCP = PC [p]x  (symmetric)
        f00, f01, f02 = q01 * pz - q02 * py, q02 * px - q00 * pz, q00 * py - q01 * px
        f11, f12 = q12 * px - q10 * pz, q10 * py - q11 * px
        f22 = q20 * py - q21 * px
        _rot_block(Rm, Ia, 0, 0, Y)                         # A1
        # A' = A1 - Q - Q^T - PCP
        PA[0, 0] += Y[0, 0] - 2.0 * e00 - f00
        PA[1, 1] += Y[1, 1] - 2.0 * e11 - f11
        PA[2, 2] += Y[2, 2] - 2.0 * e22 - f22
        t01 = Y[0, 1] - e01 - e10 - f01
        t02 = Y[0, 2] - e02 - e20 - f02
        t12 = Y[1, 2] - e12 - e21 - f12
        PA[0, 1] += t01
        PA[1, 0] += t01
        PA[0, 2] += t02
        PA[2, 0] += t02
        PA[1, 2] += t12
        PA[2, 1] += t12
        # pA_parent += X^T pa: f' = R f, n' = R n + p x f'
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2], W[i, WR + 3],
                                              W[i, WR + 4], W[i, WR + 5], W[i, WR + 6],
                                              W[i, WR + 7], W[i, WR + 8])
        fx, fy, fz = r0 * pa3 + r1 * pa4 + r2 * pa5, r3 * pa3 + r4 * pa4 + r5 * pa5, r6 * pa3 + r7 * pa4 + r8 * pa5
        nx, ny, nz = r0 * pa0 + r1 * pa1 + r2 * pa2, r3 * pa0 + r4 * pa1 + r5 * pa2, r6 * pa0 + r7 * pa1 + r8 * pa2
        W[k, APA] += nx + py * fz - pz * fy
        W[k, APA + 1] += ny + pz * fx - px * fz
        W[k, APA + 2] += nz + px * fy - py * fx
        W[k, APA + 3] += fx
        W[k, APA + 4] += fy
        W[k, APA + 5] += fz
    # --- pass 3, outward: accelerations; base acceleration -g
    ax = ay = az = 0.0
    lx, ly, lz = -P[n, G], -P[n, G + 1], -P[n, G + 2]
    for i in range(n):
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = (W[i, WR], W[i, WR + 1], W[i, WR + 2], W[i, WR + 3],
                                              W[i, WR + 4], W[i, WR + 5], W[i, WR + 6],
                                              W[i, WR + 7], W[i, WR + 8])
        px, py, pz = W[i, WP], W[i, WP + 1], W[i, WP + 2]
        # a' = X a + c
        sx, sy, sz = lx - (py * az - pz * ay), ly - (pz * ax - px * az), lz - (px * ay - py * ax)
        ax, ay, az = (r0 * ax + r3 * ay + r6 * az + W[i, AC], r1 * ax + r4 * ay + r7 * az + W[i, AC + 1],
                      r2 * ax + r5 * ay + r8 * az + W[i, AC + 2])
        lx, ly, lz = (r0 * sx + r3 * sy + r6 * sz + W[i, AC + 3], r1 * sx + r4 * sy + r7 * sz + W[i, AC + 4],
                      r2 * sx + r5 * sy + r8 * sz + W[i, AC + 5])
        # qdd = (u - U^T a') / D ;  a = a' + S qdd
        Ua = (W[i, AU] * ax + W[i, AU + 1] * ay + W[i, AU + 2] * az + W[i, AU + 3] * lx
              + W[i, AU + 4] * ly + W[i, AU + 5] * lz)
        qdd = (W[i, AUU] - Ua) / W[i, AD]
        out[i] = qdd
        if P[i, KIND] == 0.0:
            az += qdd
        else:
            lz += qdd
    return chk


@njit(cache=True, fastmath=_FM)
def _fd(P, W, q, qd, tau, flags, out):
    if (flags & F_ABA) != 0:
        return _fd_aba(P, W, q, qd, tau, flags, out)
    return _fd_cholesky(P, W, q, qd, tau, flags, out)


@njit(cache=True, fastmath=_FM)
def _set_wrench(W, n, w):
    for k in range(6):
        W[2 * n + 1, WRENCH + k] = w[k]


@njit(cache=True, fastmath=_FM)
def _status(chk):
    return 0 if chk == 0.0 else 1


# ------------------------------------------------------------------ blocks of samples (SIMD)
# A batch shares one kinematic structure, so B samples can run in lock step: every
# quantity is stored with the sample index (lane) last, shape (rows, B), and each step is a
# loop over the lanes that the compiler turns into vector instructions (AVX: 4 or 8 lanes).
# The lane count is read at run time (from PW): LLVM vectorizes such loops with run-time
# overlap checks between the arrays, which it cannot do once it has unrolled a loop of
# known length. Same equations as _rnea_core.
B = 32


@njit(cache=True, fastmath=_FM)
def _rnea_block(P, n, flags, QV, WB, RB, PB, FB, ST, TB):
    """Inverse dynamics of nl samples (lanes) in lock step: QV (3n, nl) rows q, qd, qdd;
    WB (6, nl) tip wrenches (base frame); scratch RB (9n, nl) rotations, PB (3n, nl)
    translations, FB (6n, nl) body wrenches, ST (15, nl) state (omega, alpha, a, then the
    wrench force and moment); torques into TB (n, nl). Every lane loop is innermost and
    branch-free (joint kinds enter as 0/1 factors), so that it vectorizes."""
    nl = QV.shape[1]                     # a run-time count (see above)
    use_w = (flags & F_W) != 0
    for k in range(15):
        v = -P[n, G + k - 6] if 6 <= k < 9 else 0.0      # omega = alpha = 0, a = -g
        for b in range(nl):
            ST[k, b] = WB[k - 9, b] if k >= 9 and use_w else v
    for i in range(n):
        rp0, rp1, rp2, rp3, rp4, rp5, rp6, rp7, rp8 = (P[i, RP], P[i, RP + 1], P[i, RP + 2],
                                                       P[i, RP + 3], P[i, RP + 4], P[i, RP + 5],
                                                       P[i, RP + 6], P[i, RP + 7], P[i, RP + 8])
        pp0, pp1, pp2 = P[i, PP], P[i, PP + 1], P[i, PP + 2]
        ri, pi, fi = 9 * i, 3 * i, 6 * i
        kp = P[i, KIND]                  # 1 prismatic, 0 revolute
        kr = 1.0 - kp
        # joint transform R = Rp' Rz(q) | Rp',  p = p' | p' + q Rp' e_z
        if kp == 0.0:
            for b in range(nl):
                s, c = _sincos(QV[i, b])
                RB[ri, b], RB[ri + 1, b], RB[ri + 2, b] = c * rp0 + s * rp1, c * rp1 - s * rp0, rp2
                RB[ri + 3, b], RB[ri + 4, b], RB[ri + 5, b] = c * rp3 + s * rp4, c * rp4 - s * rp3, rp5
                RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b] = c * rp6 + s * rp7, c * rp7 - s * rp6, rp8
                PB[pi, b], PB[pi + 1, b], PB[pi + 2, b] = pp0, pp1, pp2
        else:
            for b in range(nl):
                qi = QV[i, b]
                RB[ri, b], RB[ri + 1, b], RB[ri + 2, b] = rp0, rp1, rp2
                RB[ri + 3, b], RB[ri + 4, b], RB[ri + 5, b] = rp3, rp4, rp5
                RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b] = rp6, rp7, rp8
                PB[pi, b], PB[pi + 1, b], PB[pi + 2, b] = pp0 + qi * rp2, pp1 + qi * rp5, pp2 + qi * rp8
        # carry omega, alpha, a into body i, add the joint rates
        for b in range(nl):
            r0, r1, r2 = RB[ri, b], RB[ri + 1, b], RB[ri + 2, b]
            r3, r4, r5 = RB[ri + 3, b], RB[ri + 4, b], RB[ri + 5, b]
            r6, r7, r8 = RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b]
            px, py, pz = PB[pi, b], PB[pi + 1, b], PB[pi + 2, b]
            wx, wy, wz = ST[0, b], ST[1, b], ST[2, b]
            ax, ay, az = ST[3, b], ST[4, b], ST[5, b]
            # a + alpha x p + w x (w x p), then into body i: x_i = R^T x
            ux, uy, uz = wy * pz - wz * py, wz * px - wx * pz, wx * py - wy * px
            tx = ST[6, b] + ay * pz - az * py + wy * uz - wz * uy
            ty = ST[7, b] + az * px - ax * pz + wz * ux - wx * uz
            tz = ST[8, b] + ax * py - ay * px + wx * uy - wy * ux
            lx, ly, lz = r0 * tx + r3 * ty + r6 * tz, r1 * tx + r4 * ty + r7 * tz, r2 * tx + r5 * ty + r8 * tz
            wx, wy, wz = r0 * wx + r3 * wy + r6 * wz, r1 * wx + r4 * wy + r7 * wz, r2 * wx + r5 * wy + r8 * wz
            ax, ay, az = r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az
            # spin: alpha += w x (qd e_z) + qdd e_z, w += qd e_z; slide: a += 2 w x (qd e_z) + qdd e_z
            dq, ddq = QV[n + i, b], QV[2 * n + i, b]
            dr, dp = kr * dq, 2.0 * kp * dq
            ST[3, b], ST[4, b], ST[5, b] = ax + wy * dr, ay - wx * dr, az + kr * ddq
            ST[6, b], ST[7, b], ST[8, b] = lx + wy * dp, ly - wx * dp, lz + kp * ddq
            ST[0, b], ST[1, b], ST[2, b] = wx, wy, wz + dr
        # body wrench about its origin: f = m a + alpha x h + w x (w x h),
        #                                n = I_o alpha + w x (I_o w) + h x a
        m = P[i, MASS]
        hx, hy, hz = P[i, H], P[i, H + 1], P[i, H + 2]
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (P[i, IO], P[i, IO + 1], P[i, IO + 2], P[i, IO + 3],
                                        P[i, IO + 4], P[i, IO + 5])
        for b in range(nl):
            wx, wy, wz = ST[0, b], ST[1, b], ST[2, b]
            ax, ay, az = ST[3, b], ST[4, b], ST[5, b]
            lx, ly, lz = ST[6, b], ST[7, b], ST[8, b]
            ux, uy, uz = wy * hz - wz * hy, wz * hx - wx * hz, wx * hy - wy * hx
            FB[fi, b] = m * lx + ay * hz - az * hy + wy * uz - wz * uy
            FB[fi + 1, b] = m * ly + az * hx - ax * hz + wz * ux - wx * uz
            FB[fi + 2, b] = m * lz + ax * hy - ay * hx + wx * uy - wy * ux
            Lx = Ixx * wx + Ixy * wy + Ixz * wz
            Ly = Ixy * wx + Iyy * wy + Iyz * wz
            Lz = Ixz * wx + Iyz * wy + Izz * wz
            FB[fi + 3, b] = Ixx * ax + Ixy * ay + Ixz * az + wy * Lz - wz * Ly + hy * lz - hz * ly
            FB[fi + 4, b] = Ixy * ax + Iyy * ay + Iyz * az + wz * Lx - wx * Lz + hz * lx - hx * lz
            FB[fi + 5, b] = Ixz * ax + Iyz * ay + Izz * az + wx * Ly - wy * Lx + hx * ly - hy * lx
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
    kp = P[n - 1, KIND]
    for b in range(nl):
        fx, fy, fz = FB[fi, b] - ST[9, b], FB[fi + 1, b] - ST[10, b], FB[fi + 2, b] - ST[11, b]
        mx = FB[fi + 3, b] - ST[12, b] - tpy * ST[11, b] + tpz * ST[10, b]
        my = FB[fi + 4, b] - ST[13, b] - tpz * ST[9, b] + tpx * ST[11, b]
        mz = FB[fi + 5, b] - ST[14, b] - tpx * ST[10, b] + tpy * ST[9, b]
        ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = fx, fy, fz, mx, my, mz
        TB[n - 1, b] = (1.0 - kp) * mz + kp * fz           # tau_i = e_z . (n | f)
    for i in range(n - 2, -1, -1):
        fi, rj, pj = 6 * i, 9 * (i + 1), 3 * (i + 1)
        kp = P[i, KIND]
        kr = 1.0 - kp
        for b in range(nl):              # outboard force into body i: f = R f, m = R m + p x f
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
            ST[0, b], ST[1, b], ST[2, b], ST[3, b], ST[4, b], ST[5, b] = fx, fy, fz, mx, my, mz
            TB[i, b] = kr * mz + kp * fz


@njit(cache=True, fastmath=_FM)
def _rnea_batch_blocks(PW, q, qd, qdd, w, flags, out):
    """rnea_batch by blocks of B samples; a block with a NaN/Inf or a huge angle, and a
    tail of fewer than B/4 samples, go through the one-sample kernel (which checks, and
    reduces huge angles exactly)."""
    N = out.shape[0]
    n, P, _ = _split(PW)
    W = _workspace(n)
    L = int(PW[1, NPOS])                 # lanes (= B), read at run time on purpose
    QV, WB, TB, ST = np.zeros((3 * n, L)), np.zeros((6, L)), np.zeros((n, L)), np.zeros((15, L))
    RB, PB, FB = np.zeros((9 * n, L)), np.zeros((3 * n, L)), np.zeros((6 * n, L))
    nq, nv, na, nw = q.shape[0] > 1, qd.shape[0] > 1, qdd.shape[0] > 1, w.shape[0] > 1
    use_qd, use_qdd, use_w = (flags & F_QD) != 0, (flags & F_QDD) != 0, (flags & F_W) != 0
    bad = 0
    for k0 in range(0, N, L):
        ok = N - k0 >= L // 4                # a short tail: one sample at a time
        for b in range(L if ok else 0):      # gather the block (the last one padded)
            k = min(k0 + b, N - 1)
            for i in range(n):
                x = q[k if nq else 0, i]
                y = qd[k if nv else 0, i] if use_qd else 0.0
                z = qdd[k if na else 0, i] if use_qdd else 0.0
                QV[i, b], QV[n + i, b], QV[2 * n + i, b] = x, y, z
                ok &= abs(x) < 1e5 and y * 0.0 == 0.0 and z * 0.0 == 0.0
            if use_w:
                for j in range(6):
                    x = w[k if nw else 0, j]
                    WB[j, b] = x
                    ok &= x * 0.0 == 0.0
        if ok:
            _rnea_block(P, n, flags, QV, WB, RB, PB, FB, ST, TB)
            for b in range(min(L, N - k0)):
                for i in range(n):
                    out[k0 + b, i] = TB[i, b]
        else:
            for k in range(k0, min(k0 + L, N)):
                if use_w:
                    _set_wrench(W, n, w[k if nw else 0])
                chk = _rnea_core(P, W, q[k if nq else 0], qd[k if nv else 0],
                                 qdd[k if na else 0], flags, out[k])
                if chk != 0.0:
                    bad = 1
    return bad


# ------------------------------------------------------------------ entry points
def rnea(PW, q, qd, qdd, flags, out):
    """Inverse dynamics of one state into ``out`` (n,); see the module docstring."""
    n, P, W = _split(PW)
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n:
        return 2
    return _status(_rnea_core(P, W, q, qd, qdd, flags, out))


def crba(PW, q, out):
    """Mass matrix of one configuration into ``out`` (n, n)."""
    n, P, W = _split(PW)
    if q.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return 2
    chk = _trig(W, q, n)
    for i in range(n):
        _joint(P, W, i, q[i], n)
    _crba_core(P, W, out)
    return _status(chk)


def fd(PW, q, qd, tau, flags, out):
    """Forward dynamics of one state into ``out`` (n,): Cholesky, or ABA with F_ABA."""
    n, P, W = _split(PW)
    if q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or out.shape[0] != n:
        return 2
    return _status(_fd(P, W, q, qd, tau, flags, out))


def rnea_batch(PW, q, qd, qdd, w, flags, out):
    """Inverse dynamics of N states: q, qd, qdd (N, n) or (1, n); w (N, 6) or (1, 6).
    Runs B samples at a time in SIMD lanes (_rnea_block)."""
    return _rnea_batch_blocks(PW, q, qd, qdd, w, flags, out)


def crba_batch(PW, q, out):
    """Mass matrices (N, n, n) of N configurations."""
    N = q.shape[0]
    n, P, _ = _split(PW)
    W = _workspace(n)
    bad = 0
    for k in range(N):
        qk = q[k]
        chk = _trig(W, qk, n)
        for i in range(n):
            _joint(P, W, i, qk[i], n)
        _crba_core(P, W, out[k])
        if chk != 0.0:
            bad = 1
    return bad


def fd_batch(PW, q, qd, tau, w, flags, out):
    """Forward dynamics of N states (rows broadcast as in rnea_batch)."""
    N = out.shape[0]
    n, P, _ = _split(PW)
    W = _workspace(n)
    nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
    use_w = (flags & F_W) != 0
    bad = 0
    for k in range(N):
        if use_w:
            _set_wrench(W, n, w[k if nw else 0])
        chk = _fd(P, W, q[k if nq else 0], qd[k if nv else 0], tau[k if nt else 0], flags, out[k])
        if chk != 0.0:
            bad = 1
    return bad


def simulate_semi_implicit_euler(PW, q0, qd0, tau, dt, nsteps, viscous, w, flags):
    """Fixed-step loop of semi-implicit Euler: qd += dt qdd; q += dt qd, with
    qdd = FD(q, qd, tau_k - viscous * qd [, w_k]). ``tau`` (nsteps, n) or (1, n) held
    constant; ``w`` (nsteps, 6), (1, 6) or (0, 6) for no wrench. ``flags``: F_ABA for the
    articulated-body method (else Cholesky); F_ARM to integrate the viscous damping
    implicitly, as MuJoCo's Euler does: (M + dt diag(viscous)) qdd = tau - viscous qd - b,
    i.e. the damping acts on the new velocity, which keeps it stable for any
    dt viscous / M (explicit damping needs dt viscous / M_ii < 2). Returns (q, qd), each
    (nsteps + 1, n) with the initial state first; from the first step whose state is not
    finite on, rows are NaN."""
    n, P, _ = _split(PW)
    qs = np.full((nsteps + 1, n), np.nan)
    qds = np.full((nsteps + 1, n), np.nan)
    W = _workspace(n)
    t = np.empty(n)
    qdd = np.empty(n)
    q = q0.copy()
    qd = qd0.copy()
    qs[0] = q
    qds[0] = qd
    flags = F_QD | (flags & (F_ABA | F_ARM)) | (F_W if w.shape[0] > 0 else 0)
    for i in range(n):
        W[2 * n + 4, i] = dt * viscous[i]
    ntau, nw = tau.shape[0] > 1, w.shape[0] > 1
    if w.shape[0] > 0:
        _set_wrench(W, n, w[0])
    for k in range(nsteps):
        tk = tau[k if ntau else 0]
        for i in range(n):
            t[i] = tk[i] - viscous[i] * qd[i]
        if nw:
            _set_wrench(W, n, w[k])
        chk = _fd(P, W, q, qd, t, flags, qdd)
        ok = chk == 0.0
        for i in range(n):
            qd[i] += dt * qdd[i]
            q[i] += dt * qd[i]
            ok = ok and q[i] - q[i] == 0.0 and qd[i] - qd[i] == 0.0
        if not ok:
            break
        qs[k + 1] = q
        qds[k + 1] = qd
    return qs, qds


# ------------------------------------------------------------------ Python-level helpers
def simulate_fixed_step(robot, q0, qd0, tau, dt, nsteps, viscous=None, wrench=None,
                        method="auto", implicit_damping=True):
    """Semi-implicit Euler over ``nsteps`` steps of ``dt`` in one compiled loop:
    qdd = FD(q, qd, tau_k - viscous * qd, wrench_k); qd += dt qdd; q += dt qd.

    ``tau``: (n,) held constant or (nsteps, n) per step; ``viscous``: (n,) N m s/rad (default
    none); ``wrench``: None, (6,) or (nsteps, 6) on the tip (base coordinates);
    ``method``: "auto", "cholesky" or "aba"; ``implicit_damping``: the damping acts on the
    new velocity, (M + dt diag(viscous)) qdd = tau - viscous qd - b (as MuJoCo's Euler;
    stable for any step), else explicitly (stable only while dt viscous / M_ii < 2).
    Returns (q, qd), each (nsteps + 1, n), the initial state first; from a step whose
    state is not finite on, the rows are NaN.
    """
    n = robot.dof
    vec = lambda x, name: _checked(np.ascontiguousarray(x, dtype=float), (n,), name)  # noqa: E731
    q0, qd0 = vec(q0, "q0"), vec(qd0, "qd0")
    viscous = np.zeros(n) if viscous is None else vec(viscous, "viscous")
    tau = np.ascontiguousarray(np.atleast_2d(np.asarray(tau, dtype=float)))
    _checked(tau, ((1, n), (nsteps, n)), "tau")
    w = np.zeros((0, 6)) if wrench is None else np.ascontiguousarray(np.atleast_2d(np.asarray(wrench, dtype=float)))
    _checked(w, ((0, 6), (1, 6), (nsteps, 6)), "wrench")
    if method == "auto":
        from .algorithms.aba import CROSSOVER
        method = "aba" if n >= CROSSOVER else "cholesky"
    if method not in ("cholesky", "aba"):
        raise ValueError(f"method {method!r} unknown; use 'auto', 'cholesky' or 'aba'")
    if not dt > 0 or int(nsteps) != nsteps or nsteps < 0:
        raise ValueError(f"dt = {dt}, nsteps = {nsteps}: need dt > 0 and an integer nsteps >= 0")
    PW = robot._PW if getattr(robot, "_PW", None) is not None else pack(robot.model)
    flags = (F_ABA if method == "aba" else 0) | (F_ARM if implicit_damping else 0)
    return K.simulate_semi_implicit_euler(PW, q0, qd0, tau, float(dt), int(nsteps), viscous, w, flags)


def _checked(a, shapes, name):
    shapes = shapes if isinstance(shapes[0], tuple) else (shapes,)
    if a.shape not in shapes:
        raise ValueError(f"{name} has shape {a.shape}; expected one of {list(shapes)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has a NaN or Inf entry; give finite numbers")
    return a


# ------------------------------------------------------------------ signatures, lazy compile
_f8 = types.float64
_i8 = types.int64
_ro1 = types.Array(_f8, 1, "C", readonly=True)
_ro2 = types.Array(_f8, 2, "C", readonly=True)
_rw1 = types.Array(_f8, 1, "C")
_rw2 = types.Array(_f8, 2, "C")
_rw3 = types.Array(_f8, 3, "C")

SIGNATURES = {
    "rnea": _i8(_rw2, _ro1, _ro1, _ro1, _i8, _rw1),
    "crba": _i8(_rw2, _ro1, _rw2),
    "fd": _i8(_rw2, _ro1, _ro1, _ro1, _i8, _rw1),
    "rnea_batch": _i8(_rw2, _ro2, _ro2, _ro2, _ro2, _i8, _rw2),
    "crba_batch": _i8(_rw2, _ro2, _rw3),
    "fd_batch": _i8(_rw2, _ro2, _ro2, _ro2, _ro2, _i8, _rw2),
    "simulate_semi_implicit_euler": types.Tuple((_rw2, _rw2))(
        _rw2, _ro1, _ro1, _ro2, _f8, _i8, _ro1, _ro2, _i8),
}


class _Kernels:
    """Compiled entry points, built (compiled or loaded from the cache) on first access.
    Each accepts only its signature; anything else raises TypeError."""

    def __getattr__(self, name):
        if name not in SIGNATURES:
            raise AttributeError(name)
        disp = njit([SIGNATURES[name]], cache=True, fastmath=_FM)(globals()[name])
        setattr(self, name, disp)
        return disp

    def load_all(self, names=None):
        """Compile or load ``names`` (default: every entry point)."""
        for name in SIGNATURES if names is None else names:
            getattr(self, name)
        return self


# What Robot.warmup() loads: the Robot methods' kernels. The whole-loop simulation kernel
# (7.5 s of a cold compile: it re-specializes the forward-dynamics tree for its writable
# arrays) is left to its first use by sd.simulate; the nodes never call it.
ROBOT_KERNELS = ("rnea", "crba", "fd", "rnea_batch", "crba_batch", "fd_batch")


K = _Kernels()


if __name__ == "__main__":      # python -m serial_dynamics.kernels: fill the numba cache once
    import time

    from serial_dynamics import kernels     # the package module (its cache), not __main__'s copy
    t0 = time.perf_counter()
    kernels.K.load_all()
    print(f"compiled or loaded {len(SIGNATURES)} kernels in {time.perf_counter() - t0:.1f} s")
