"""Inverse dynamics, compiled: the recursive Newton-Euler algorithm in joint frames.

The same equations, frames and symbols as ``algorithms/rnea.py`` (the readable reference):
outward, the angular velocity omega (w*), angular acceleration alpha (a*) and classical
acceleration of the body origin acc (l*) of each body, gravity as the base acceleration
-g (Luh, Walker & Paul, 1980); the body wrench about its origin; inward, the joint
wrenches and tau_i = S_i^T f_i (Featherstone 2008, Sec. 5.3). The tip wrench w (ROS
order [f; m], base frame, exerted on the tip) enters as the load -w on the last body. A
base with known motion (flag BASE; Angeles, Sec. 7.5.2) starts the outward recursion with
its angular velocity and acceleration and the acceleration of its origin minus gravity;
the armature adds I_a qdd to each joint's torque, after the passes. What a joint's type
changes (S, its rate, S^T f) is ``joint.py``'s.
"""
from numba import njit

from . import flags as F
from .data import new_kin
from .status import BAD_LENGTH, status
from .signatures import D2, D3, In1, Out1, Pm, f8, i8, internal
from .joint import armature_torques, free_flyer, joint_rate, joint_transforms, project
from .layout import (G, H, IO, KIND, MASS, PARENT, ROOT, TIPP, TIPPATH, W_ACC, W_ALL, W_ALPHA,
                     W_OMEGA, W_WRENCH)
from .spatial import finite, rotate_t, rotation, to_child, to_parent


@njit(cache=True, inline="always")
def w_length(flags):
    """The length the external inputs ``w`` must have: W_ALL with flag BASE, else W_WRENCH."""
    return W_ALL if (flags & F.BASE) != 0 else W_WRENCH


@njit(cache=True, inline="always")
def base_state(P, w, flags, n, chk):
    """The start of the outward recursion: ((omega, alpha, acc) of the base, 9 numbers;
    the tip wrench [f; m], 6 numbers; the check of what was read from ``w``). A fixed base
    has omega = alpha = 0 and acc = -g (gravity as a base acceleration); a moving base
    (flag BASE) its omega_0, alpha_0 and acc_0 - g (Angeles Sec. 7.5.2); the tip wrench is
    w[:6] with flag WRENCH, else 0. ``chk`` plus NaN if one of them is NaN/Inf."""
    wx = wy = wz = 0.0                                  # omega
    ax = ay = az = 0.0                                  # alpha
    lx, ly, lz = -P[n, G], -P[n, G + 1], -P[n, G + 2]   # acc; base: -g
    ex = ey = ez = mx = my = mz = 0.0                   # tip wrench [f; m], carried outward
    if (flags & F.WRENCH) != 0:
        ex, ey, ez, mx, my, mz = w[0], w[1], w[2], w[3], w[4], w[5]
        chk += finite(ex) + finite(ey) + finite(ez) + finite(mx) + finite(my) + finite(mz)
    if (flags & F.BASE) != 0:
        wx, wy, wz = w[W_OMEGA], w[W_OMEGA + 1], w[W_OMEGA + 2]
        ax, ay, az = w[W_ALPHA], w[W_ALPHA + 1], w[W_ALPHA + 2]
        lx, ly, lz = w[W_ACC] - P[n, G], w[W_ACC + 1] - P[n, G + 1], w[W_ACC + 2] - P[n, G + 2]
        chk += (finite(wx) + finite(wy) + finite(wz) + finite(ax) + finite(ay) + finite(az)
                + finite(lx) + finite(ly) + finite(lz))
    return (wx, wy, wz, ax, ay, az, lx, ly, lz), (ex, ey, ez, mx, my, mz), chk


@njit(cache=True, inline="always")
def joint_rates(qd, qdd, i, flags):
    """(qd_i, qdd_i, their check): each 0.0 unless flag QD, QDD says it is given."""
    dq = qd[i] if (flags & F.QD) != 0 else 0.0
    ddq = qdd[i] if (flags & F.QDD) != 0 else 0.0
    return dq, ddq, finite(dq) + finite(ddq)


@njit(cache=True, inline="always")
def into_body(r, px, py, pz, wx, wy, wz, ax, ay, az, lx, ly, lz):
    """Body i-1's omega, alpha and acc carried to body i's origin p (acc + alpha x p +
    omega x (omega x p)) and into joint frame i (R_i = r, ``spatial.rotation``), before
    joint i moves: 9 numbers."""
    ux, uy, uz = wy * pz - wz * py, wz * px - wx * pz, wx * py - wy * px
    tx = lx + ay * pz - az * py + wy * uz - wz * uy
    ty = ly + az * px - ax * pz + wz * ux - wx * uz
    tz = lz + ax * py - ay * px + wx * uy - wy * ux
    lx, ly, lz = rotate_t(r, tx, ty, tz)
    wx, wy, wz = rotate_t(r, wx, wy, wz)
    ax, ay, az = rotate_t(r, ax, ay, az)
    return wx, wy, wz, ax, ay, az, lx, ly, lz


@internal
def outward_step(P, R, p, i, wx, wy, wz, ax, ay, az, lx, ly, lz, dq, ddq):
    """Newton-Euler outward recursion, one body: ``into_body`` then ``joint_rate``.
    Returns (omega, alpha, acc) of body i, 9 numbers."""
    wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(rotation(R, i), p[i, 0], p[i, 1], p[i, 2],
                                                   wx, wy, wz, ax, ay, az, lx, ly, lz)
    return joint_rate(P[i, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz, dq, ddq)


@njit(cache=True, inline="always")
def inertia(P, i):
    """Body i's inertial parameters (m, h = m c, I_O: xx yy zz xy xz yz), 10 numbers."""
    return (P[i, MASS], P[i, H], P[i, H + 1], P[i, H + 2], P[i, IO], P[i, IO + 1], P[i, IO + 2],
            P[i, IO + 3], P[i, IO + 4], P[i, IO + 5])


@njit(cache=True, inline="always")
def body_wrench(P, i, wx, wy, wz, ax, ay, az, lx, ly, lz):
    """Body i's wrench (n; f) about its origin, 6 numbers: ``rigid_wrench`` of its inertia."""
    return rigid_wrench(inertia(P, i), wx, wy, wz, ax, ay, az, lx, ly, lz)


@njit(cache=True, inline="always")
def rigid_wrench(I10, wx, wy, wz, ax, ay, az, lx, ly, lz):
    """A body's wrench (n; f) about its origin, 6 numbers (Luh, Walker & Paul, 1980), from its
    inertial parameters I10 (``inertia``):
    n = I_O alpha + omega x (I_O omega) + h x acc,  f = m acc + alpha x h + omega x (omega x h)."""
    m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = I10
    ux, uy, uz = wy * hz - wz * hy, wz * hx - wx * hz, wx * hy - wy * hx
    fx = m * lx + ay * hz - az * hy + wy * uz - wz * uy
    fy = m * ly + az * hx - ax * hz + wz * ux - wx * uz
    fz = m * lz + ax * hy - ay * hx + wx * uy - wy * ux
    Lx = Ixx * wx + Ixy * wy + Ixz * wz
    Ly = Ixy * wx + Iyy * wy + Iyz * wz
    Lz = Ixz * wx + Iyz * wy + Izz * wz
    nx = Ixx * ax + Ixy * ay + Ixz * az + wy * Lz - wz * Ly + hy * lz - hz * ly
    ny = Ixy * ax + Iyy * ay + Iyz * az + wz * Lx - wx * Lz + hz * lx - hx * lz
    nz = Ixz * ax + Iyz * ay + Izz * az + wx * Ly - wy * Lx + hx * ly - hy * lx
    return nx, ny, nz, fx, fy, fz


@njit(cache=True, inline="always")
def tip_load(P, n, bx, by, bz, bfx, bfy, bfz, ex, ey, ez, mx, my, mz):
    """The joint wrench of the last body n-1: its body wrench (b; bf) and the load -w of
    the environment (w = [e; m] in its frame; moment about its origin: -m + Xtip_p x -e)."""
    tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
    nx = bx - mx - tpy * ez + tpz * ey
    ny = by - my - tpz * ex + tpx * ez
    nz = bz - mz - tpx * ey + tpy * ex
    return nx, ny, nz, bfx - ex, bfy - ey, bfz - ez


@njit(cache=True, inline="always")
def inward_step(R, p, f, i, nx, ny, nz, fx, fy, fz):
    """Newton-Euler inward recursion, one body: f_i = body wrench + Xup_{i+1}^T f_{i+1}
    (Featherstone 2008, Sec. 5.3), from body i+1's joint wrench (n; f)."""
    nx, ny, nz, fx, fy, fz = to_parent(R, p, i + 1, nx, ny, nz, fx, fy, fz)
    return nx + f[i, 0], ny + f[i, 1], nz + f[i, 2], fx + f[i, 3], fy + f[i, 4], fz + f[i, 5]


@njit(cache=True, inline="always")
def free_flyer_motion(qd, qdd, base, flags):
    """A free-flyer root joint's body motion (omega, alpha, acc) in its frame, 9 numbers: a
    floating base's six coordinates (a virtual tree's first six, robot/floating.py) as one
    joint (Featherstone 2008, Sec. 9.3). ``base``: base_state's start (acc = -g there);
    qd[:6] = v = [v_O, omega] and qdd[:6] = dv/dt plus the velocity products
    (core/floating.rnea_inputs), both in the base frame; the root adds the products of its
    successive axes: alpha = qdd[3:6] + (wy wz, -wx wz, wx wy), acc = base acc + qdd[:3]."""
    wx, wy, wz = (qd[3], qd[4], qd[5]) if (flags & F.QD) != 0 else (0.0, 0.0, 0.0)
    a0, a1, a2, a3, a4, a5 = ((qdd[0], qdd[1], qdd[2], qdd[3], qdd[4], qdd[5])
                              if (flags & F.QDD) != 0 else (0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    return free_flyer(wx, wy, wz, a0, a1, a2, a3, a4, a5, base[6], base[7], base[8])


@njit(cache=True, inline="always")
def newton_euler(P, sc, R, p, f, mo, q, qd, qdd, w, flags, tau, tree, nb):
    """tau = M(q) qdd + b(q, qd) - J^T w into ``tau``; fills the Data arrays sc, R, p, f (and
    mo on a tree). ``w``: the external inputs (layout.W_*): the tip wrench (flag WRENCH),
    the base motion (flag BASE). ``tree``, a constant of the caller: the parent of body i is
    lambda(i) = ``P[i, PARENT]`` and each body's (omega, alpha, acc) is kept in ``mo`` (n, 9)
    for its children (Featherstone 2008, Table 5.1, written for trees), else i - 1, the
    parent's motion in registers (a chain; ``mo`` unread). ``nb``: 0, or 6: a floating
    base's six coordinates (its virtual chain's or tree's first bodies) as one free-flyer
    root joint (tau[:6] the base wrench [f; n]).
    Returns 0.0, or NaN if an input has a NaN/Inf entry. Every operation is that of the
    lane-parallel batch kernels (rnea_lanes.py, tree_lanes.py) in the same order, so both
    give the same bits; a tree kernel run on a chain gives the chain kernel's bits."""
    n = tau.shape[0]
    use_qdd, use_w = (flags & F.QDD) != 0, (flags & F.WRENCH) != 0
    chk = joint_transforms(P, sc, R, p, q, n, nb)
    base, (ex, ey, ez, mx, my, mz), chk = base_state(P, w, flags, n, chk)
    wx, wy, wz, ax, ay, az, lx, ly, lz = base
    if nb > 0:                  # the free-flyer root: body nb-1's motion and wrench at once
        for i in range(nb):
            chk += joint_rates(qd, qdd, i, flags)[2]
        wx, wy, wz, ax, ay, az, lx, ly, lz = free_flyer_motion(qd, qdd, base, flags)
        k = nb - 1
        if tree:
            keep_motion(mo, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
        f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5] = body_wrench(
            P, k, wx, wy, wz, ax, ay, az, lx, ly, lz)
    # outward: each body's motion from its parent's, then its wrench
    for i in range(nb, n):
        dq, ddq, c = joint_rates(qd, qdd, i, flags)
        chk += c
        if tree:                # the parent's (a chain's: the previous step's, in registers)
            l = int(P[i, PARENT])
            wx, wy, wz, ax, ay, az, lx, ly, lz = base if l < 0 else (
                mo[l, 0], mo[l, 1], mo[l, 2], mo[l, 3], mo[l, 4], mo[l, 5], mo[l, 6], mo[l, 7],
                mo[l, 8])
        wx, wy, wz, ax, ay, az, lx, ly, lz = outward_step(P, R, p, i, wx, wy, wz, ax, ay, az,
                                                          lx, ly, lz, dq, ddq)
        if tree:
            keep_motion(mo, i, wx, wy, wz, ax, ay, az, lx, ly, lz)
        f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5] = body_wrench(
            P, i, wx, wy, wz, ax, ay, az, lx, ly, lz)
        if use_w and (not tree or P[i, TIPPATH] != 0.0):   # the tip wrench into frame i
            ex, ey, ez = to_child(R, i, ex, ey, ez)
            mx, my, mz = to_child(R, i, mx, my, mz)
    k = n - 1                   # the load -w on the tip's body (n - 1; a chain's also w = 0)
    if use_w or not tree:
        f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5] = tip_load(
            P, n, f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5], ex, ey, ez, mx, my, mz)
    # inward: tau_i = S_i^T f_i;  f_lambda(i) += Xup_i^T f_i
    nx, ny, nz, fx, fy, fz = f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5]
    for i in range(n - 1, nb - 1, -1):
        if tree:
            nx, ny, nz, fx, fy, fz = f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5]
        tau[i] = project(P[i, KIND], nz, fz)
        l = int(P[i, PARENT]) if tree else i - 1
        if l >= 0:
            nx, ny, nz, fx, fy, fz = to_parent(R, p, i, nx, ny, nz, fx, fy, fz)
            if tree:
                f[l, 0], f[l, 1], f[l, 2] = f[l, 0] + nx, f[l, 1] + ny, f[l, 2] + nz
                f[l, 3], f[l, 4], f[l, 5] = f[l, 3] + fx, f[l, 4] + fy, f[l, 5] + fz
            else:               # a chain carries the sum in registers
                nx, ny, nz = nx + f[l, 0], ny + f[l, 1], nz + f[l, 2]
                fx, fy, fz = fx + f[l, 3], fy + f[l, 4], fz + f[l, 5]
    if nb > 0:                  # the free-flyer's generalized forces: [f; n] on the base
        k = nb - 1
        if tree:
            nx, ny, nz, fx, fy, fz = f[k, 0], f[k, 1], f[k, 2], f[k, 3], f[k, 4], f[k, 5]
        tau[0], tau[1], tau[2], tau[3], tau[4], tau[5] = fx, fy, fz, nx, ny, nz
    armature_torques(P, qdd, use_qdd, tau, nb)      # tau_i += I_a,i qdd_i
    return chk


@njit(cache=True, inline="always")
def keep_motion(mo, i, wx, wy, wz, ax, ay, az, lx, ly, lz):
    """Body i's (omega, alpha, acc) into mo[i] for its children (a tree)."""
    mo[i, 0], mo[i, 1], mo[i, 2], mo[i, 3], mo[i, 4] = wx, wy, wz, ax, ay
    mo[i, 5], mo[i, 6], mo[i, 7], mo[i, 8] = az, lx, ly, lz


def rnea_core(P, sc, R, p, f, q, qd, qdd, w, flags, tau):
    """``newton_euler`` of a chain on a fixed base (a moving one with flag BASE)."""
    return newton_euler(P, sc, R, p, f, f, q, qd, qdd, w, flags, tau, False, 0)


def floating_rnea_core(P, sc, R, p, f, q, qd, qdd, w, flags, tau):
    """``newton_euler`` with a free-flyer root (a floating base's virtual chain)."""
    return newton_euler(P, sc, R, p, f, f, q, qd, qdd, w, flags, tau, False, 6)


def tree_rnea_core(P, sc, R, p, f, mo, q, qd, qdd, w, flags, tau):
    """``newton_euler`` of a tree (its free-flyer root where ``P[n, ROOT]`` = 6); mo (n, 9)."""
    return newton_euler(P, sc, R, p, f, mo, q, qd, qdd, w, flags, tau, True,
                        int(P[tau.shape[0], ROOT]))


rnea_inline = njit(cache=True, inline="always")(rnea_core)   # into the single-state entries
rnea_core = internal(f8(Pm, D2, D3, D2, D2, In1, In1, In1, In1, i8, Out1))(rnea_core)   # the others call it
floating_rnea_core = internal(f8(Pm, D2, D3, D2, D2, In1, In1, In1, In1, i8, Out1))(
    floating_rnea_core)
tree_rnea_core = internal(f8(Pm, D2, D3, D2, D2, D2, In1, In1, In1, In1, i8, Out1))(tree_rnea_core)


# ------------------------------------------------------------------ entry points
# Two single-state entry points, without and with a tip wrench: every array argument of
# a compiled call costs ~40 ns of dispatch, a fifth of a short chain's whole call.
def rnea(P, q, qd, qdd, flags, out):
    """Inverse dynamics of one state into ``out`` (n,). Returns OK, NOT_FINITE or BAD_LENGTH
    (status.py)."""
    n = P.shape[0] - 1
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n:
        return BAD_LENGTH
    d = new_kin(n)
    return status(rnea_inline(P, d.sc, d.R, d.p, d.f, q, qd, qdd, q, flags & (F.QD | F.QDD), out))


def rnea_wrench(P, q, qd, qdd, w, flags, out):
    """``rnea`` with external inputs ``w`` (layout.W_*): with flag WRENCH the tip wrench
    w[:6], [f; m] in base coordinates, on the tip; with flag BASE also the base motion
    (then ``w`` has W_ALL entries, else W_WRENCH)."""
    n = P.shape[0] - 1
    if (q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n
            or w.shape[0] != w_length(flags)):
        return BAD_LENGTH
    d = new_kin(n)
    return status(rnea_core(P, d.sc, d.R, d.p, d.f, q, qd, qdd, w, flags, out))
