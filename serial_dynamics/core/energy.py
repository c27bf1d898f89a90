"""The gradient of the kinetic energy and the symplectic Euler step, compiled.

``ke_gradient_core``: dT/dq at fixed qd, T = 1/2 qd^T M(q) qd (= C(q, qd)^T qd), O(n),
the same recursion, frames and symbols as ``algorithms/energy.py``'s
``kinetic_energy_gradient``: outward, the velocity (omega; v) of each body origin and its
momentum h = I V about it; inward, the momentum H_k of bodies k.. and
dT/dq_k = -S_k . (V_k x* H_k) (Featherstone 2008, Sec. 2.9).

``symplectic_euler``: one step of symplectic Euler in momentum form (Hairer, Lubich &
Wanner, GNI, Sec. VI.3, eq. 3.1 with H = 1/2 p^T M(q)^-1 p + V(q)):

    p0 = M(q0) qd0
    p1 = p0 + dt (dT/dq(q0, v) - g(q0) + J^T w + f - diag(beta) v),   v = M(q0)^-1 p1
    q1 = q0 + dt v,   qd1 = M(q1)^-1 p1

solved for v by fixed-point iteration on (M(q0) + dt diag(beta)) v = p0 + dt (f - g +
J^T w + dT/dq(q0, v)): M, its Cholesky factor and g are computed once per step, each
iteration is one O(n) gradient and two triangular solves. ``held`` joints (stuck by
friction or on a stop) are removed: their rows and columns of M become the identity,
so v and qd1 are zero there. A step depends on its inputs only (no state carried from
the last step: p0 = M(q0) qd0 equals the last step's p1 to round-off), so the same
(q, qd) gives the same bits whatever came before.
"""
from numba import types

from . import flags as F
from .cholesky import cholesky_factor, cholesky_solve_factored
from .crba import crba_core
from .data import new_kin, scratch, stack_empty
from .joint import add_rate, joint_transforms, project
from .layout import H, IO, KIND, MASS, W_WRENCH
from .rnea import rnea_core
from .status import BAD_LENGTH, NOT_CONVERGED, NOT_FINITE, status
from .signatures import D2, D3, In1, Out1, Pm, f8, i8, internal
from .spatial import finite, to_child, to_parent

ROUNDOFF = 1e-10        # a correction below this (relative) that stops shrinking is round-off


@internal
def body_velocity(P, R, p, i, wx, wy, wz, vx, vy, vz, qdi):
    """Body i's velocity (omega; v at its origin) in frame i from its parent's (omega; v
    at the parent's origin, parent frame): moved to i's origin, turned into frame i, plus the
    joint's rate qdi about (along) z."""
    px, py, pz = p[i, 0], p[i, 1], p[i, 2]
    vx, vy, vz = to_child(R, i, vx + wy * pz - wz * py, vy + wz * px - wx * pz,
                          vz + wx * py - wy * px)
    wx, wy, wz = to_child(R, i, wx, wy, wz)
    wz, vz = add_rate(P[i, KIND], wz, vz, qdi)     # v_i += S_i qd_i
    return wx, wy, wz, vx, vy, vz


@internal
def body_momentum(P, i, wx, wy, wz, vx, vy, vz):
    """h_i = I_i V_i about body i's origin: angular I_O omega + h x v, linear m v + omega x h."""
    m, hx, hy, hz = P[i, MASS], P[i, H], P[i, H + 1], P[i, H + 2]
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (P[i, IO], P[i, IO + 1], P[i, IO + 2], P[i, IO + 3],
                                    P[i, IO + 4], P[i, IO + 5])
    return (Ixx * wx + Ixy * wy + Ixz * wz + hy * vz - hz * vy,
            Ixy * wx + Iyy * wy + Iyz * wz + hz * vx - hx * vz,
            Ixz * wx + Iyz * wy + Izz * wz + hx * vy - hy * vx,
            m * vx + wy * hz - wz * hy, m * vy + wz * hx - wx * hz, m * vz + wx * hy - wy * hx)


@internal
def axis_gradient(P, k, wx, wy, wz, vx, vy, vz, nx, ny, nz, fx, fy, fz):
    """dT/dq_k = -S_k . (V_k x* H_k): -(omega x Hn + v x Hf)_z or -(omega x Hf)_z."""
    return project(P[k, KIND], -(wx * ny - wy * nx + vx * fy - vy * fx), -(wx * fy - wy * fx))


@internal(types.void(Pm, D3, D2, In1, D2, Out1), calls=())
def ke_gradient_core(P, R, p, qd, V, out):
    """dT/dq into ``out``; R, p the joint transforms at q; V (n, 12) scratch."""
    n = out.shape[0]
    wx = wy = wz = vx = vy = vz = 0.0
    for i in range(n):
        wx, wy, wz, vx, vy, vz = body_velocity(P, R, p, i, wx, wy, wz, vx, vy, vz, qd[i])
        V[i, 0], V[i, 1], V[i, 2], V[i, 3], V[i, 4], V[i, 5] = wx, wy, wz, vx, vy, vz
        V[i, 6], V[i, 7], V[i, 8], V[i, 9], V[i, 10], V[i, 11] = body_momentum(
            P, i, wx, wy, wz, vx, vy, vz)
    nx = ny = nz = fx = fy = fz = 0.0
    for k in range(n - 1, -1, -1):
        if k < n - 1:               # H of bodies k+1.. into frame k
            nx, ny, nz, fx, fy, fz = to_parent(R, p, k + 1, nx, ny, nz, fx, fy, fz)
        nx, ny, nz = nx + V[k, 6], ny + V[k, 7], nz + V[k, 8]
        fx, fy, fz = fx + V[k, 9], fy + V[k, 10], fz + V[k, 11]
        out[k] = axis_gradient(P, k, V[k, 0], V[k, 1], V[k, 2], V[k, 3], V[k, 4], V[k, 5],
                               nx, ny, nz, fx, fy, fz)


@internal(types.void(D2, In1))
def mask_held(M, held):
    """Rows and columns of held joints of M to the identity."""
    n = M.shape[0]
    for i in range(n):
        if held[i] != 0.0:
            for j in range(n):
                M[i, j] = 0.0
                M[j, i] = 0.0
            M[i, i] = 1.0


# ------------------------------------------------------------------ entry points
def kinetic_energy_gradient(P, q, qd, out):
    """dT/dq of one state into ``out`` (n,). Returns OK, NOT_FINITE or BAD_LENGTH."""
    n = P.shape[0] - 1
    if q.shape[0] != n or qd.shape[0] != n or out.shape[0] != n:
        return BAD_LENGTH
    d = new_kin(n)
    V = scratch((n, 12), 12 * n)
    chk = joint_transforms(P, d.sc, d.R, d.p, q, n)
    for i in range(n):
        chk += finite(qd[i])
    ke_gradient_core(P, d.R, d.p, qd, V, out)
    return status(chk)


def symplectic_euler(P, q, qd, f, w, beta, held, dt, tol, maxit, flags, qo, qdo, vo):
    """One symplectic Euler step (module doc) from (q, qd) with the generalized forces
    ``f`` (n,) held over the step, viscous coefficients ``beta`` (implicit), the tip
    wrench ``w`` (flag WRENCH) and ``held`` joints (1.0: held). Writes q1, qd1 and the
    velocity v of the position update into qo, qdo, vo.
    Returns the fixed-point iterations (>= 1), or minus a status (status.py): -NOT_CONVERGED
    when the corrections did not fall below ``tol`` (relative) within ``maxit`` iterations,
    -NOT_FINITE on a NaN/Inf, -BAD_LENGTH on a wrong length."""
    n = P.shape[0] - 1
    if (q.shape[0] != n or qd.shape[0] != n or f.shape[0] != n or beta.shape[0] != n
            or held.shape[0] != n
            or qo.shape[0] != n or qdo.shape[0] != n or vo.shape[0] != n
            or ((flags & F.WRENCH) != 0 and w.shape[0] != W_WRENCH)):
        return -BAD_LENGTH
    d = new_kin(n)
    M, L = scratch((n, n), n * n), scratch((n, n), n * n)
    V = scratch((n, 12), 12 * n)
    gw, r, t, x = stack_empty((n,)), stack_empty((n,)), stack_empty((n,)), stack_empty((n,))
    # g(q0) - J^T w, and the joint transforms at q0
    chk = rnea_core(P, d.sc, d.R, d.p, d.f, q, q, q, w, flags & F.WRENCH, gw)
    crba_core(P, d.R, d.p, M)
    mask_held(M, held)
    for i in range(n):
        chk += finite(qd[i]) + finite(f[i]) + finite(beta[i])
        free = held[i] == 0.0
        s = 0.0                                                  # p0 = M(q0) qd0
        if free:
            for j in range(n):
                if held[j] == 0.0:
                    s += M[i, j] * qd[j]
        r[i] = s + dt * (f[i] - gw[i]) if free else 0.0         # p0 + dt (f - g + J^T w)
        vo[i] = qd[i] if free else 0.0
        for j in range(n):
            L[i, j] = M[i, j]
        L[i, i] += dt * beta[i] if free else 0.0                 # M + dt diag(beta)
    if chk != 0.0:
        return -NOT_FINITE
    cholesky_factor(L)
    done, prev, k = False, 0.0, 0
    while k < maxit and not done:
        k += 1
        ke_gradient_core(P, d.R, d.p, vo, V, t)                  # dT/dq(q0, v)
        for i in range(n):
            x[i] = r[i] + dt * t[i] if held[i] == 0.0 else 0.0
        cholesky_solve_factored(L, x)                            # v = (M + dt B)^-1 (...)
        diff, vmax = 0.0, 0.0
        for i in range(n):
            diff = max(diff, abs(x[i] - vo[i]))
            vmax = max(vmax, abs(x[i]))
            vo[i] = x[i]
        scale = 1.0 + vmax
        if not diff <= 1e300:                                    # NaN or Inf
            return -NOT_FINITE
        done = diff <= tol * scale or (k > 1 and diff >= prev and diff <= ROUNDOFF * scale)
        prev = diff
    for i in range(n):                                           # p1 = M(q0) v
        s = 0.0
        for j in range(n):
            s += M[i, j] * vo[j]
        x[i] = s if held[i] == 0.0 else 0.0
        qo[i] = q[i] + dt * vo[i]                                # q1 = q0 + dt v
    joint_transforms(P, d.sc, d.R, d.p, qo, n)
    crba_core(P, d.R, d.p, M)                                    # M(q1)
    mask_held(M, held)
    for i in range(n):
        qdo[i] = x[i]
    cholesky_factor(M)
    cholesky_solve_factored(M, qdo)                              # qd1 = M(q1)^-1 p1
    return k if done else -NOT_CONVERGED


ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "kinetic_energy_gradient": (kinetic_energy_gradient, i8(Pm, In1, In1, Out1), False,
                                ("ke_gradient_core",)),
    "symplectic_euler": (symplectic_euler,
                         i8(Pm, In1, In1, In1, In1, In1, In1, f8, f8, i8, i8, Out1, Out1, Out1),
                         False, ("rnea_core", "crba_core", "ke_gradient_core", "cholesky_factor",
                                 "cholesky_solve_factored", "mask_held")),
}
