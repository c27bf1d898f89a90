"""Derivatives of inverse and forward dynamics, compiled: forward-mode differentiation of
the Newton-Euler recursion (``rnea.py``), all 2n directions at once.

The same equations, frames and symbols as ``algorithms/derivatives.py`` (the readable
reference; its docstring derives the seeds and the joint's own turn). Directions are
interleaved, d = 2j for q_j and d = 2j + 1 for qd_j, so that at body k the directions
already alive are the contiguous range [0, 2k): each equation of the recursion is one loop
over them, the tangents stored direction-last (T[component, d]), which the compiler can
run in SIMD lanes. Outward, the tangents of (omega, alpha, acc) and of the tip wrench e
carried outward (T rows 0-2, 3-5, 6-8, 9-14) pass through body k and the body-wrench
tangents (n; f) are stored per body (dB); inward, the joint-wrench tangents (Tf) pass
through every body, joint j+1 adding its own turn to direction 2(j+1). O(n^2).

Forward dynamics: qdd by the Cholesky route (``forward.cholesky_core``, which leaves the
factor L of M in place), then the inverse-dynamics derivatives at (q, qd, qdd), then
d qdd/d x = -M^-1 d tau/d x and M^-1 by triangular solves with L (Featherstone 2008,
Sec. 6.3), in one call.
"""
from numba import njit, types

from . import flags as F
from .cholesky import cholesky_solve_matrix
from .data import new_chol, new_kin, scratch, stack_empty
from .forward import cholesky_core
from .joint import axis, joint_rate, joint_transforms, own_turn, rate_terms, seeds
from .layout import H, IO, KIND, MASS, TIPP
from .rnea import base_state, body_wrench, inward_step, into_body, joint_rates, tip_load, w_length
from .status import BAD_LENGTH, status
from .signatures import D1, D2, D3, In1, Out2, Pm, Vec, f8, i8, internal
from .spatial import force_to_parent, rotate_t, rotation

HAVE_TRANSFORMS = 1 << 16    # flag of derivatives_core: R, p already hold the transforms of q


@njit(cache=True, inline="always")
def _inertia_times(I6, x, y, z):
    """I_O (x, y, z), I_O given as (xx, yy, zz, xy, xz, yz)."""
    return (I6[0] * x + I6[3] * y + I6[4] * z, I6[3] * x + I6[1] * y + I6[5] * z,
            I6[4] * x + I6[5] * y + I6[2] * z)


@njit(cache=True, inline="always")
def _body_tangent(body, dwx, dwy, dwz, dax, day, daz, dlx, dly, dlz):
    """The tangent (d n; d f) of the body wrench (rnea.py) along (d omega, d alpha, d acc):
    d f = m d acc + d alpha x h + d w x (w x h) + w x (d w x h)
        = m d acc + d alpha x h + w (d w.h) + d w (w.h) - 2 h (w.d w),
    d n = I_O d alpha + d w x I_O w + w x I_O d w + h x d acc.
    ``body``: m, h, I_O, omega, I_O omega and omega.h of the body."""
    m, hx, hy, hz, I6, wx, wy, wz, Lx, Ly, Lz, wh = body
    s1 = dwx * hx + dwy * hy + dwz * hz
    s2 = 2.0 * (wx * dwx + wy * dwy + wz * dwz)
    Kx, Ky, Kz = _inertia_times(I6, dwx, dwy, dwz)
    Ax, Ay, Az = _inertia_times(I6, dax, day, daz)
    return (Ax + dwy * Lz - dwz * Ly + wy * Kz - wz * Ky + hy * dlz - hz * dly,
            Ay + dwz * Lx - dwx * Lz + wz * Kx - wx * Kz + hz * dlx - hx * dlz,
            Az + dwx * Ly - dwy * Lx + wx * Ky - wy * Kx + hx * dly - hy * dlx,
            m * dlx + day * hz - daz * hy + wx * s1 + dwx * wh - hx * s2,
            m * dly + daz * hx - dax * hz + wy * s1 + dwy * wh - hy * s2,
            m * dlz + dax * hy - day * hx + wz * s1 + dwz * wh - hz * s2)


@njit(cache=True, inline="always")
def tangent_through(r, px, py, pz, w0x, w0y, w0z, wp, ca, cl, dwx, dwy, dwz, t3, t4, t5, t6, t7, t8):
    """One live tangent (d omega, d alpha, d acc) = (dw, t3..5, t6..8) through body k: rnea's
    into_body linearized, d acc + d alpha x p + d w x (w x p) + w x (d w x p) = ... + w (d w.p)
    + d w (w.p) - 2 p (w.d w) with the parent's omega w0 and wp = w0.p, into frame k (R = r);
    then the joint's rate term d omega' x qd e_z = qd (d w_y, -d w_x, 0) on d alpha (ca = qd,
    revolute) or d acc (cl = 2 qd, prismatic). 9 numbers."""
    s1 = dwx * px + dwy * py + dwz * pz
    s2 = w0x * dwx + w0y * dwy + w0z * dwz
    tx = t6 + t4 * pz - t5 * py + w0x * s1 + dwx * wp - (2.0 * px) * s2
    ty = t7 + t5 * px - t3 * pz + w0y * s1 + dwy * wp - (2.0 * py) * s2
    tz = t8 + t3 * py - t4 * px + w0z * s1 + dwz * wp - (2.0 * pz) * s2
    sx, sy, sz = rotate_t(r, tx, ty, tz)
    cx, cy, cz = rotate_t(r, dwx, dwy, dwz)
    bx, by, bz = rotate_t(r, t3, t4, t5)
    return cx, cy, cz, bx + ca * cy, by - ca * cx, bz, sx + cl * cy, sy - cl * cx, sz


@njit(cache=True, inline="always")
def tip_tangents(P, T, Tf):
    """The tip load's tangents on the last body's joint wrench: d(-e), d(-m + Xtip_p x -e)."""
    n = P.shape[0] - 1
    tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
    for d in range(2 * n):
        gx, gy, gz = T[9, d], T[10, d], T[11, d]
        Tf[3, d] -= gx
        Tf[4, d] -= gy
        Tf[5, d] -= gz
        Tf[0, d] -= T[12, d] + tpy * gz - tpz * gy
        Tf[1, d] -= T[13, d] + tpz * gx - tpx * gz
        Tf[2, d] -= T[14, d] + tpx * gy - tpy * gx


def derivatives_core(P, sc, R, p, f, T, Tf, dB, q, qd, qdd, w, flags, dq, dqd):
    """d tau/d q into ``dq`` and d tau/d qd into ``dqd`` (n, n), [i, j] = d tau_i / d x_j,
    of tau = M qdd + b - J^T w (flags QD, QDD, WRENCH, BASE as ``rnea_core``). Scratch:
    sc, R, p, f (Data Kin), T (15, 2n), Tf (6, 2n), dB (n, 6, 2n). Returns 0.0 or NaN."""
    n = dq.shape[0]
    use_w = (flags & F.WRENCH) != 0
    # R, p (and the check of q) may come from the caller (fd_derivatives_core)
    chk = joint_transforms(P, sc, R, p, q, n) if (flags & HAVE_TRANSFORMS) == 0 else 0.0
    (wx, wy, wz, ax, ay, az, lx, ly, lz), (ex, ey, ez, mx, my, mz), chk = base_state(P, w, flags, n, chk)
    for k in range(n):
        dqk, ddqk, c = joint_rates(qd, qdd, k, flags)
        chk += c
        px, py, pz = p[k, 0], p[k, 1], p[k, 2]
        kind = P[k, KIND]
        r = rotation(R, k)
        w0x, w0y, w0z = wx, wy, wz                        # the parent's omega (frame k-1)
        # rnea outward: omega', alpha', acc' in body k before its joint moves, then after
        wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(r, px, py, pz, wx, wy, wz, ax, ay, az, lx, ly, lz)
        wpx, wpy, apx, apy = wx, wy, ax, ay
        lpx, lpy = lx, ly
        if use_w:
            ex, ey, ez = rotate_t(r, ex, ey, ez)
            mx, my, mz = rotate_t(r, mx, my, mz)
        wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(P[k, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz,
                                                        dqk, ddqk)
        f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5] = body_wrench(
            P, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
        m = P[k, MASS]
        hx, hy, hz = P[k, H], P[k, H + 1], P[k, H + 2]
        I6 = (P[k, IO], P[k, IO + 1], P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5])
        Lx, Ly, Lz = _inertia_times(I6, wx, wy, wz)                              # I_O omega
        body = (m, hx, hy, hz, I6, wx, wy, wz, Lx, Ly, Lz, wx * hx + wy * hy + wz * hz)
        # the live tangents through body k, linearized (rnea outward): d acc + d alpha x p
        # + d w x (w x p) + w x (d w x p) = ... + w (d w.p) + d w (w.p) - 2 p (w.d w), into
        # frame k; then the joint's rate term on d alpha (revolute) or d acc (prismatic,
        # twice): d omega' x qd e_z = qd (d w_y, -d w_x, 0)
        ca, cl = rate_terms(kind, dqk)
        wp = w0x * px + w0y * py + w0z * pz
        for d in range(2 * k):
            (T[0, d], T[1, d], T[2, d], T[3, d], T[4, d], T[5, d], T[6, d], T[7, d],
             T[8, d]) = tangent_through(r, px, py, pz, w0x, w0y, w0z, wp, ca, cl,
                                        T[0, d], T[1, d], T[2, d], T[3, d], T[4, d], T[5, d],
                                        T[6, d], T[7, d], T[8, d])
        if use_w:
            for d in range(2 * k):
                T[9, d], T[10, d], T[11, d] = rotate_t(r, T[9, d], T[10, d], T[11, d])
                T[12, d], T[13, d], T[14, d] = rotate_t(r, T[12, d], T[13, d], T[14, d])
        seeds(T, k, kind, dqk, wz, wpx, wpy, apx, apy, lpx, lpy, ex, ey, mx, my)
        for d in range(2 * k + 2):       # (its own loop: the compiler runs it in SIMD lanes)
            (dB[k, 0, d], dB[k, 1, d], dB[k, 2, d], dB[k, 3, d], dB[k, 4, d],
             dB[k, 5, d]) = _body_tangent(body, T[0, d], T[1, d], T[2, d], T[3, d], T[4, d],
                                          T[5, d], T[6, d], T[7, d], T[8, d])
    # inward: the last body carries the tip load -e (moment about its origin: -m + Xtip_p x -e)
    k = n - 1
    nx, ny, nz, fx, fy, fz = tip_load(P, n, f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5],
                                      ex, ey, ez, mx, my, mz)
    for d in range(2 * n):
        for r in range(6):
            Tf[r, d] = dB[k, r, d]
    if use_w:
        tip_tangents(P, T, Tf)
    _torques(P, Tf, k, dq, dqd)
    for i in range(n - 2, -1, -1):
        j = i + 1
        # joint j's own turn, direction q_j: g = R_j (e_z x f_j); revolute: d f += g,
        # d n += R_j (e_z x n_j) + p_j x g; prismatic: d n += g  (algorithms/derivatives.py)
        r = rotation(R, j)
        px, py, pz = p[j, 0], p[j, 1], p[j, 2]
        sx, sy, sz, gx, gy, gz = own_turn(P[j, KIND], r, px, py, pz, nx, ny, nz, fx, fy)
        # rnea inward: f_i = body wrench + Xup_j^T f_j, for the joint wrench and its tangents
        nx, ny, nz, fx, fy, fz = inward_step(R, p, f, i, nx, ny, nz, fx, fy, fz)
        for d in range(2 * i + 2):    # Xup_j^T: f' = R f, n' = R n + p x f', + body i's
            ux, uy, uz, cx, cy, cz = force_to_parent(r, px, py, pz, Tf[0, d], Tf[1, d], Tf[2, d],
                                                     Tf[3, d], Tf[4, d], Tf[5, d])
            Tf[0, d], Tf[1, d], Tf[2, d] = ux + dB[i, 0, d], uy + dB[i, 1, d], uz + dB[i, 2, d]
            Tf[3, d], Tf[4, d], Tf[5, d] = cx + dB[i, 3, d], cy + dB[i, 4, d], cz + dB[i, 5, d]
        for d in range(2 * i + 2, 2 * n):   # directions of joints outboard of i: carried
            (Tf[0, d], Tf[1, d], Tf[2, d], Tf[3, d], Tf[4, d],
             Tf[5, d]) = force_to_parent(r, px, py, pz, Tf[0, d], Tf[1, d], Tf[2, d],
                                         Tf[3, d], Tf[4, d], Tf[5, d])
        a = 2 * j
        Tf[0, a], Tf[1, a], Tf[2, a] = Tf[0, a] + sx, Tf[1, a] + sy, Tf[2, a] + sz
        Tf[3, a], Tf[4, a], Tf[5, a] = Tf[3, a] + gx, Tf[4, a] + gy, Tf[5, a] + gz
        _torques(P, Tf, i, dq, dqd)
    return chk


@njit(cache=True, inline="always")
def _torques(P, Tf, i, dq, dqd):
    """d tau_i = S_i^T (d n; d f) of every direction (the armature term has none)."""
    r = axis(P[i, KIND])
    for j in range(dq.shape[1]):
        dq[i, j] = Tf[r, 2 * j]
        dqd[i, j] = Tf[r, 2 * j + 1]


derivatives_core = internal(f8(Pm, D2, D3, D2, D2, D2, D2, D3, In1, In1, In1, In1, i8, Out2, Out2),
                            calls=())(derivatives_core)


def fd_derivatives_core(P, sc, R, p, f, M, b, qdd, T, Tf, dB, X, q, qd, tau, w, flags,
                        dq, dqd, Minv):
    """d qdd/d q, d qdd/d qd, d qdd/d tau = -M^-1 d tau/d q, -M^-1 d tau/d qd, M^-1 at
    qdd = FD(q, qd, tau) (flags WRENCH, BASE; qd is always read). Scratch: Kin, Chol
    (M, b), qdd (n,), those of ``derivatives_core`` and X (n, 3n): the right-hand sides
    [d tau/d q, d tau/d qd, 1] solved together. M^-1 is mirrored from its upper triangle
    (exactly symmetric). Returns 0.0 or NaN."""
    n = qdd.shape[0]
    flags = (flags & (F.WRENCH | F.BASE)) | F.QD
    chk = cholesky_core(P, sc, R, p, f, M, b, q, qd, tau, w, tau, flags, qdd)   # M <- L
    chk += derivatives_core(P, sc, R, p, f, T, Tf, dB, q, qd, qdd, w,
                            flags | F.QDD | HAVE_TRANSFORMS, X[:, :n], X[:, n:2 * n])
    solve_minus(M, X, dq, dqd, Minv)
    return chk


@njit(cache=True, inline="always")
def solve_minus(M, X, dq, dqd, Minv):
    """X = [d tau/d q, d tau/d qd, 1] (n, 3n) with M holding the Cholesky factor L of M:
    -M^-1 d tau/d q, -M^-1 d tau/d qd, M^-1 into dq, dqd, Minv (mirrored from its upper
    triangle: exactly symmetric)."""
    n = M.shape[0]
    for i in range(n):
        for c in range(n):
            X[i, 2 * n + c] = 1.0 if i == c else 0.0
    cholesky_solve_matrix(M, X)
    for i in range(n):
        for c in range(n):
            dq[i, c] = -X[i, c]
            dqd[i, c] = -X[i, n + c]
            Minv[i, c] = X[i, 2 * n + c] if c >= i else X[c, 2 * n + i]


fd_derivatives_core = internal(
    f8(Pm, D2, D3, D2, D2, D2, D1, D1, D2, D2, D3, D2, In1, In1, In1, In1, i8, Out2, Out2, Out2),
    calls=("cholesky_core", "derivatives_core", "cholesky_solve_matrix"))(fd_derivatives_core)


# ------------------------------------------------------------------ entry points
@njit(cache=True, inline="always")
def _bad_shapes(P, q, qd, x, w, flags, dq, dqd):
    n = P.shape[0] - 1
    return (q.shape[0] != n or qd.shape[0] != n or x.shape[0] != n
            or dq.shape[0] != n or dq.shape[1] != n or dqd.shape[0] != n or dqd.shape[1] != n
            or w.shape[0] != w_length(flags))


def rnea_derivatives(P, q, qd, qdd, w, flags, out):
    """d tau/d q, d tau/d qd of one state into ``out[0]``, ``out[1]`` (out: (2, n, n); one
    array, one argument: each costs dispatch time). ``w``: as ``rnea.rnea_wrench``
    (W_WRENCH entries, W_ALL with flag BASE; read with flags WRENCH, BASE). Returns OK,
    NOT_FINITE or BAD_LENGTH (status.py)."""
    if out.shape[0] != 2:
        return BAD_LENGTH
    dq, dqd = out[0], out[1]
    if _bad_shapes(P, q, qd, qdd, w, flags, dq, dqd):
        return BAD_LENGTH
    n = dq.shape[0]
    d = new_kin(n)
    T, Tf, dB = stack_empty((15, 2 * n)), stack_empty((6, 2 * n)), scratch((n, 6, 2 * n), 12 * n * n)
    return status(derivatives_core(P, d.sc, d.R, d.p, d.f, T, Tf, dB, q, qd, qdd, w,
                                   (flags & (F.WRENCH | F.BASE)) | F.QD | F.QDD, dq, dqd))


def fd_derivatives(P, q, qd, tau, w, flags, out):
    """d qdd/d q, d qdd/d qd, d qdd/d tau (= M^-1) of one state into ``out[0]``, ``out[1]``,
    ``out[2]`` (out: (3, n, n)). Returns OK, NOT_FINITE or BAD_LENGTH."""
    if out.shape[0] != 3:
        return BAD_LENGTH
    dq, dqd, Minv = out[0], out[1], out[2]
    if _bad_shapes(P, q, qd, tau, w, flags, dq, dqd):
        return BAD_LENGTH
    n = dq.shape[0]
    d, c, qdd = new_kin(n), new_chol(n), stack_empty((n,))
    T, Tf, dB = stack_empty((15, 2 * n)), stack_empty((6, 2 * n)), scratch((n, 6, 2 * n), 12 * n * n)
    X = scratch((n, 3 * n), 3 * n * n)
    return status(fd_derivatives_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, qdd, T, Tf, dB, X,
                                      q, qd, tau, w, flags, dq, dqd, Minv))


_CALLS = ("derivatives_core", "fd_derivatives_core")
Mat3 = types.Array(f8, 3, "C")      # the single-state results, one C-contiguous array
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "rnea_derivatives": (rnea_derivatives, i8(Pm, Vec, Vec, Vec, Vec, i8, Mat3), False, _CALLS[:1]),
    "fd_derivatives": (fd_derivatives, i8(Pm, Vec, Vec, Vec, Vec, i8, Mat3), False, _CALLS[1:]),
}
