"""Kinematics, momentum and the Coriolis matrix, compiled: chains and trees, fixed or floating.

The same equations, frames and symbols as the NumPy reference (``algorithms/kinematics.py``,
``algorithms/energy.py``, ``algorithms/floating.py``): body i's joint frame in the world
from its parent's, λ = parent(i) (Featherstone 2008, Sec. 4.4; a chain is λ = i - 1),

    R0_i = R0_λ R_i,   o_i = o_λ + R0_λ p_i          (λ = -1: the base, at R_b, p_b)

and what is read off the poses and the joint rates: a frame fixed on a body, the geometric
Jacobian of its origin and its acceleration, the first moment of mass sum m_i c_i, the
centroidal momentum and the Coriolis matrix (``coriolis``).

The base is a joint like the others: a state q of n entries is a fixed base (R_b = 1,
p_b = 0, the world is the base frame); q of n + 7, [x, y, z, qx, qy, qz, qw, joints], is a
free-flyer root at p_b = (x, y, z), R_b of the quaternion (normalized; its velocity
v = [v_O; omega] in base axes, the first 6 of n + 6). ``base`` (10,) is the base body's
[m, h = m c, I_O: xx yy zz xy xz yz] (base frame; zeros for a fixed base, which does not
move).

Each entry point takes a batch (N, width) -- one state is N = 1 -- and computes row after
row with nothing carried between rows, so a row's bits are those of the same state alone.
A frame's pose and Jacobian also have single-state entry points (``frame_pose_one``,
``frame_jacobian_one``: a vector q, a matrix out, the batch's per-state steps ``pose_of``,
``jacobian_of``), which save a call the two views a batch of one needs. Each per-state step
is the poses (``root_and_bodies``) then ``pose_at``, ``jacobian_at`` or ``acceleration_at``
on them, which compiled code that needs several frames of one state (the contacts' rows)
calls on poses it computed once.
Status codes (``status.py``): BAD_LENGTH, NOT_FINITE (a NaN or Inf anywhere in the states,
or a quaternion of zero length), OK.
"""
import math

from numba import njit

from .data import new_poses, stack_empty
from .joint import (PRISMATIC, REVOLUTE, cross, joint_transforms, world_column, world_column_rate,
                    world_joint_rate, world_rate)
from .layout import H, IO, KIND, MASS, PARENT
from .signatures import In1, In2, Mat, Out2, Out3, Pm, Vec, i8, internal, row
from .status import BAD_LENGTH, NOT_FINITE, OK


@internal
def not_finite(x):
    """True if some entry of the batch x is NaN or Inf (x * 0.0 is NaN iff x is)."""
    chk = 0.0
    for s in range(x.shape[0]):
        for i in range(x.shape[1]):
            chk += x[s, i] * 0.0
    return chk != 0.0


@njit(cache=True, inline="always")
def not_finite_one(x):
    """True if some entry of the vector x is NaN or Inf."""
    chk = 0.0
    for i in range(x.shape[0]):
        chk += x[i] * 0.0
    return chk != 0.0


@internal
def root_and_bodies(P, ps, q, nb, k):
    """The base pose (ps.Rb, ps.pb) and R0_i, o_i of bodies 0 .. k-1 (a prefix holds each
    body's ancestors) into ``ps`` (data.Poses) for the state q (nb = 0: a fixed base; 7: a
    free-flyer root). Returns False for a quaternion of zero length."""
    sc, R, p, R0, o, Rb, pb = ps.sc, ps.R, ps.p, ps.R0, ps.o, ps.Rb, ps.pb
    for r in range(3):
        pb[r] = q[r] if nb else 0.0
        for c in range(3):
            Rb[r, c] = 1.0 if r == c else 0.0
    if nb:        # R of the unit quaternion (x, y, z, w) (Hamilton, ROS order)
        x, y, z, s = q[3], q[4], q[5], q[6]
        nrm = math.sqrt(x * x + y * y + z * z + s * s)
        if not nrm > 1e-12:
            return False
        x, y, z, s = x / nrm, y / nrm, z / nrm, s / nrm
        Rb[0, 0], Rb[0, 1], Rb[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * s), 2 * (x * z + y * s)
        Rb[1, 0], Rb[1, 1], Rb[1, 2] = 2 * (x * y + z * s), 1 - 2 * (x * x + z * z), 2 * (y * z - x * s)
        Rb[2, 0], Rb[2, 1], Rb[2, 2] = 2 * (x * z - y * s), 2 * (y * z + x * s), 1 - 2 * (x * x + y * y)
    joint_transforms(P, sc, R, p, q[nb:], k)
    for i in range(k):
        l = int(P[i, PARENT])
        for r in range(3):    # o_i = o_l + R0_l p_i, R0_i = R0_l R_i (l = -1: the base)
            if l < 0:
                o[i, r] = pb[r] + Rb[r, 0] * p[i, 0] + Rb[r, 1] * p[i, 1] + Rb[r, 2] * p[i, 2]
                for c in range(3):
                    R0[i, r, c] = Rb[r, 0] * R[i, 0, c] + Rb[r, 1] * R[i, 1, c] + Rb[r, 2] * R[i, 2, c]
            else:
                o[i, r] = o[l, r] + R0[l, r, 0] * p[i, 0] + R0[l, r, 1] * p[i, 1] + R0[l, r, 2] * p[i, 2]
                for c in range(3):
                    R0[i, r, c] = R0[l, r, 0] * R[i, 0, c] + R0[l, r, 1] * R[i, 1, c] + R0[l, r, 2] * R[i, 2, c]
    return True


@njit(cache=True, inline="always")
def frame_of(Rb, pb, R0, o, body):
    """(R, o) of joint frame ``body`` (-1: the base)."""
    return (Rb, pb) if body < 0 else (R0[body], o[body])


@njit(cache=True, inline="always")
def rotate(R, x, y, z):
    """R (x, y, z)."""
    return (R[0, 0] * x + R[0, 1] * y + R[0, 2] * z, R[1, 0] * x + R[1, 1] * y + R[1, 2] * z,
            R[2, 0] * x + R[2, 1] * y + R[2, 2] * z)


@njit(cache=True, inline="always")
def rotate_t(R, x, y, z):
    """R^T (x, y, z)."""
    return (R[0, 0] * x + R[1, 0] * y + R[2, 0] * z, R[0, 1] * x + R[1, 1] * y + R[2, 1] * z,
            R[0, 2] * x + R[1, 2] * y + R[2, 2] * z)


@njit(cache=True, inline="always")
def pose_at(ps, body, F, X):
    """X (4 x 4): the pose in the world of the frame F = [R_f row-major, p_f] fixed on joint
    frame ``body`` (-1: the base), from the poses ``ps`` (``root_and_bodies``'s, up to
    ``body`` at least): R = R0_b R_f, x = o_b + R0_b p_f."""
    Ri, oi = frame_of(ps.Rb, ps.pb, ps.R0, ps.o, body)
    x = rotate(Ri, F[9], F[10], F[11])
    for r in range(3):
        for c in range(3):
            X[r, c] = Ri[r, 0] * F[c] + Ri[r, 1] * F[3 + c] + Ri[r, 2] * F[6 + c]
        X[r, 3] = oi[r] + x[r]
        X[3, r] = 0.0
    X[3, 3] = 1.0


@njit(cache=True, inline="always")
def pose_of(P, ps, q, nb, body, F, X):
    """X (4 x 4) of one state q: ``pose_at`` on the poses of q. False for a quaternion of
    zero length."""
    if not root_and_bodies(P, ps, q, nb, body + 1):
        return False
    pose_at(ps, body, F, X)
    return True


def frame_pose(P, q, body, F, X):
    """X[s] (4 x 4): ``pose_of`` each state q[s]."""
    n = P.shape[0] - 1
    nb = q.shape[1] - n
    if nb not in (0, 7) or X.shape[0] != q.shape[0] or body >= n:
        return BAD_LENGTH
    if not_finite(q):
        return NOT_FINITE
    ps = new_poses(n)
    for s in range(q.shape[0]):
        if not pose_of(P, ps, q[s], nb, body, F, X[s]):
            return NOT_FINITE
    return OK


def frame_pose_one(P, q, body, F, X):
    """``frame_pose`` of one state, q (width,) into X (4, 4): the same steps, without the
    batch's views (a single-state entry point: other argument types answer OTHER_TYPES)."""
    n = P.shape[0] - 1
    nb = q.shape[0] - n
    if nb not in (0, 7) or body >= n:
        return BAD_LENGTH
    if not_finite_one(q):
        return NOT_FINITE
    return OK if pose_of(P, new_poses(n), q, nb, body, F, X) else NOT_FINITE


@njit(cache=True, inline="always")
def jacobian_at(P, ps, nb, body, F, J):
    """J (6 x nv): the geometric Jacobian of frame F's origin x, [linear; angular], world
    axes, from the poses ``ps`` (``root_and_bodies``'s, up to ``body`` at least; nb = 0 a
    fixed base, 7 a free-flyer root). Column j of an ancestor of ``body`` (the joints that
    move it), z_j = R0_j e_z: revolute [z_j x (x - o_j); z_j], prismatic [z_j; 0]; zero for
    the others. A free-flyer root's six columns, for v = [v_O; omega] in base axes: [R_b,
    -[x - p_b]x R_b; 0, R_b]."""
    n, nv = P.shape[0] - 1, J.shape[1]
    jv = nv - n               # the first joint's column
    R0, o, Rb, pb = ps.R0, ps.o, ps.Rb, ps.pb
    Ri, oi = frame_of(Rb, pb, R0, o, body)
    fx, fy, fz = rotate(Ri, F[9], F[10], F[11])
    x = (oi[0] + fx, oi[1] + fy, oi[2] + fz)
    for r in range(6):
        for j in range(nv):
            J[r, j] = 0.0
    if nb:
        dx, dy, dz = x[0] - pb[0], x[1] - pb[1], x[2] - pb[2]
        for c in range(3):
            J[0, c], J[1, c], J[2, c] = Rb[0, c], Rb[1, c], Rb[2, c]
            J[3, 3 + c], J[4, 3 + c], J[5, 3 + c] = Rb[0, c], Rb[1, c], Rb[2, c]
            J[0, 3 + c], J[1, 3 + c], J[2, 3 + c] = cross(Rb[0, c], Rb[1, c], Rb[2, c], dx, dy, dz)
    j = body
    while j >= 0:
        (J[0, jv + j], J[1, jv + j], J[2, jv + j], J[3, jv + j], J[4, jv + j],
         J[5, jv + j]) = world_column(P[j, KIND], R0[j, 0, 2], R0[j, 1, 2], R0[j, 2, 2],
                                      x[0] - o[j, 0], x[1] - o[j, 1], x[2] - o[j, 2])
        j = int(P[j, PARENT])


@njit(cache=True, inline="always")
def jacobian_of(P, ps, q, nb, body, F, J):
    """J (6 x nv) of one state q: ``jacobian_at`` on the poses of q. False for a quaternion
    of zero length."""
    if not root_and_bodies(P, ps, q, nb, body + 1):
        return False
    jacobian_at(P, ps, nb, body, F, J)
    return True


def frame_jacobian(P, q, body, F, J):
    """J[s] (6 x nv): ``jacobian_of`` each state q[s]."""
    n = P.shape[0] - 1
    nb = q.shape[1] - n
    nv = n + (6 if nb else 0)
    if nb not in (0, 7) or J.shape[0] != q.shape[0] or J.shape[2] != nv or body >= n:
        return BAD_LENGTH
    if not_finite(q):
        return NOT_FINITE
    ps = new_poses(n)
    for s in range(q.shape[0]):
        if not jacobian_of(P, ps, q[s], nb, body, F, J[s]):
            return NOT_FINITE
    return OK


def frame_jacobian_one(P, q, body, F, J):
    """``frame_jacobian`` of one state, q (width,) into J (6, nv)."""
    n = P.shape[0] - 1
    nb = q.shape[0] - n
    if nb not in (0, 7) or J.shape[0] != 6 or J.shape[1] != n + (6 if nb else 0) or body >= n:
        return BAD_LENGTH
    if not_finite_one(q):
        return NOT_FINITE
    return OK if jacobian_of(P, new_poses(n), q, nb, body, F, J) else NOT_FINITE


def mass_moment(P, q, base, mc):
    """mc[s] (4,) = [sum m c; sum m]: the first moment of mass of the base body and the
    bodies, world frame (m_i c_i = m_i o_i + R0_i h_i, h_i = m_i c_i in frame i), and the
    mass: their center of mass is mc[:3] / mc[3]."""
    n = P.shape[0] - 1
    nb = q.shape[1] - n
    if nb not in (0, 7) or mc.shape[0] != q.shape[0] or base.shape[0] != 10:
        return BAD_LENGTH
    if not_finite(q):
        return NOT_FINITE
    ps = new_poses(n)
    R0, o, Rb, pb = ps.R0, ps.o, ps.Rb, ps.pb
    for s in range(q.shape[0]):
        if not root_and_bodies(P, ps, q[s], nb, n):
            return NOT_FINITE
        cx, cy, cz = rotate(Rb, base[1], base[2], base[3])
        m, cx, cy, cz = base[0], base[0] * pb[0] + cx, base[0] * pb[1] + cy, base[0] * pb[2] + cz
        for i in range(n):
            hx, hy, hz = rotate(R0[i], P[i, H], P[i, H + 1], P[i, H + 2])
            mi = P[i, MASS]
            m, cx, cy, cz = m + mi, cx + mi * o[i, 0] + hx, cy + mi * o[i, 1] + hy, cz + mi * o[i, 2] + hz
        mc[s, 0], mc[s, 1], mc[s, 2], mc[s, 3] = cx, cy, cz, m
    return OK


@njit(cache=True, inline="always")
def ancestors(P, body, path):
    """The joints from ``body`` to the root into path; their number."""
    k = 0
    j = body
    while j >= 0:
        path[k] = j
        k += 1
        j = int(P[j, PARENT])
    return k


@njit(cache=True, inline="always")
def acceleration_at(P, ps, nb, path, k, u, du, body, F, out):
    """out (6,) = [a; alpha] of one state (``frame_acceleration``) from the poses ``ps``
    (``root_and_bodies``'s), the rates u = qd, du = qdd and ``body``'s ``k`` ancestors in
    ``path`` (``ancestors``)."""
    n, nv = P.shape[0] - 1, u.shape[0]
    jv = nv - n
    R0, o, Rb, pb = ps.R0, ps.o, ps.Rb, ps.pb
    wx = wy = wz = bx = by = bz = ax = ay = az = 0.0
    if nb:
        wx, wy, wz = rotate(Rb, u[3], u[4], u[5])
        bx, by, bz = rotate(Rb, du[3], du[4], du[5])
        cx, cy, cz = cross(u[3], u[4], u[5], u[0], u[1], u[2])
        ax, ay, az = rotate(Rb, du[0] + cx, du[1] + cy, du[2] + cz)
    ox, oy, oz = pb[0], pb[1], pb[2]
    for m in range(k - 1, -1, -1):
        j = int(path[m])
        dx, dy, dz = o[j, 0] - ox, o[j, 1] - oy, o[j, 2] - oz
        ex, ey, ez = cross(bx, by, bz, dx, dy, dz)
        fx, fy, fz = cross(wx, wy, wz, dx, dy, dz)
        gx, gy, gz = cross(wx, wy, wz, fx, fy, fz)
        ax, ay, az = ax + ex + gx, ay + ey + gy, az + ez + gz
        zx, zy, zz, c, dc = R0[j, 0, 2], R0[j, 1, 2], R0[j, 2, 2], u[jv + j], du[jv + j]
        hx, hy, hz = cross(wx, wy, wz, zx, zy, zz)
        wx, wy, wz, bx, by, bz, ax, ay, az = world_joint_rate(
            P[j, KIND], wx, wy, wz, bx, by, bz, ax, ay, az, zx, zy, zz, hx, hy, hz, c, dc)
        ox, oy, oz = o[j, 0], o[j, 1], o[j, 2]
    Ri = Rb if body < 0 else R0[body]
    fx, fy, fz = rotate(Ri, F[9], F[10], F[11])     # the frame's origin from its body's
    ex, ey, ez = cross(bx, by, bz, fx, fy, fz)
    gx, gy, gz = cross(wx, wy, wz, fx, fy, fz)
    hx, hy, hz = cross(wx, wy, wz, gx, gy, gz)
    out[0], out[1], out[2] = ax + ex + hx, ay + ey + hy, az + ez + hz
    out[3], out[4], out[5] = bx, by, bz


def frame_acceleration(P, q, qd, qdd, body, F, out):
    """out[s] = [a; alpha]: the classical acceleration of frame F's origin and the angular
    acceleration of its body, world axes (J qdd + J-dot qd; ``algorithms/task_space.py``).
    Outward along the joints from the base to ``body``, with d = o_i - o_l (Featherstone
    2008, Sec. 2.11): a_i = a_l + alpha_l x d + omega_l x (omega_l x d), then a revolute
    joint adds omega_i = omega_l + z qd, alpha_i = alpha_l + omega_l x z qd + z qdd, a
    prismatic one a_i += 2 omega_l x z qd + z qdd. A free-flyer root starts from the base's
    omega = R w, alpha = R dw/dt, a = R (dv_O/dt + w x v_O) (v = [v_O; w], a = dv/dt in base
    axes). qd, qdd (N or 1, nv) broadcast."""
    n = P.shape[0] - 1
    N = q.shape[0]
    nb = q.shape[1] - n
    nv = n + (6 if nb else 0)
    if (nb not in (0, 7) or qd.shape[1] != nv or qdd.shape[1] != nv or out.shape[0] != N
            or qd.shape[0] not in (1, N) or qdd.shape[0] not in (1, N) or body >= n):
        return BAD_LENGTH
    if not_finite(q) or not_finite(qd) or not_finite(qdd):
        return NOT_FINITE
    ps = new_poses(n)
    path = stack_empty((n,))              # the ancestors of body, from it to the root
    k = ancestors(P, body, path)
    for s in range(N):
        if not root_and_bodies(P, ps, q[s], nb, body + 1):
            return NOT_FINITE
        acceleration_at(P, ps, nb, path, k, row(qd, s), row(qdd, s), body, F, out[s])
    return OK


@njit(cache=True, inline="always")
def body_momentum(Ri, ox, oy, oz, vx, vy, vz, wx, wy, wz, m, h, I):
    """A body's momentum about the world origin, world axes, for the velocity (v; omega) of
    its origin o: p = m v + omega x h0, L = I0 omega + h0 x v + o x p (h0 = R h,
    I0 = R I_O R^T; Featherstone 2008, eq. 2.62). h: (hx, hy, hz), I: (xx, yy, zz, xy, xz, yz)."""
    ax, ay, az = rotate_t(Ri, wx, wy, wz)
    bx = I[0] * ax + I[3] * ay + I[4] * az
    by = I[3] * ax + I[1] * ay + I[5] * az
    bz = I[4] * ax + I[5] * ay + I[2] * az
    nx, ny, nz = rotate(Ri, bx, by, bz)
    hx, hy, hz = rotate(Ri, h[0], h[1], h[2])
    cx, cy, cz = cross(wx, wy, wz, hx, hy, hz)
    px, py, pz = m * vx + cx, m * vy + cy, m * vz + cz
    ex, ey, ez = cross(hx, hy, hz, vx, vy, vz)
    fx, fy, fz = cross(ox, oy, oz, px, py, pz)
    return px, py, pz, nx + ex + fx, ny + ey + fy, nz + ez + fz


def centroidal(P, q, qd, base, out):
    """out[s] = [p; L]: the linear momentum and the angular momentum about the center of
    mass of the base body and the bodies, world axes (Orin, Goswami & Lee 2013). Outward,
    the velocity of each body origin: omega_i = omega_l (+ z_i qd_i), v_i = v_l + omega_l x
    (o_i - o_l) (+ z_i qd_i); each body's momentum (``body_momentum``) summed about the
    world origin, then L_c = L_O - c x p. qd (N or 1, nv) broadcasts."""
    n = P.shape[0] - 1
    N = q.shape[0]
    nb = q.shape[1] - n
    nv = n + (6 if nb else 0)
    if (nb not in (0, 7) or qd.shape[1] != nv or out.shape[0] != N or qd.shape[0] not in (1, N)
            or base.shape[0] != 10):
        return BAD_LENGTH
    if not_finite(q) or not_finite(qd):
        return NOT_FINITE
    ps = new_poses(n)
    R0, o, Rb, pb = ps.R0, ps.o, ps.Rb, ps.pb
    V = stack_empty((n, 6))
    jv = nv - n
    for s in range(N):
        if not root_and_bodies(P, ps, q[s], nb, n):
            return NOT_FINITE
        u = row(qd, s)
        ux, uy, uz = rotate(Rb, u[0], u[1], u[2]) if nb else (0.0, 0.0, 0.0)
        bx, by, bz = rotate(Rb, u[3], u[4], u[5]) if nb else (0.0, 0.0, 0.0)
        px, py, pz, lx, ly, lz = body_momentum(Rb, pb[0], pb[1], pb[2], ux, uy, uz, bx, by, bz,
                                               base[0], base[1:4], base[4:10])
        m = base[0]
        cx, cy, cz = rotate(Rb, base[1], base[2], base[3])
        cx, cy, cz = cx + m * pb[0], cy + m * pb[1], cz + m * pb[2]
        for i in range(n):
            l = int(P[i, PARENT])
            if l < 0:
                vx, vy, vz, wx, wy, wz = ux, uy, uz, bx, by, bz
                dx, dy, dz = o[i, 0] - pb[0], o[i, 1] - pb[1], o[i, 2] - pb[2]
            else:
                vx, vy, vz, wx, wy, wz = V[l, 0], V[l, 1], V[l, 2], V[l, 3], V[l, 4], V[l, 5]
                dx, dy, dz = o[i, 0] - o[l, 0], o[i, 1] - o[l, 1], o[i, 2] - o[l, 2]
            ex, ey, ez = cross(wx, wy, wz, dx, dy, dz)
            vx, vy, vz = vx + ex, vy + ey, vz + ez
            wx, wy, wz, vx, vy, vz = world_rate(P[i, KIND], wx, wy, wz, vx, vy, vz, R0[i, 0, 2],
                                                R0[i, 1, 2], R0[i, 2, 2], u[jv + i])
            V[i, 0], V[i, 1], V[i, 2], V[i, 3], V[i, 4], V[i, 5] = vx, vy, vz, wx, wy, wz
            fx, fy, fz, nx, ny, nz = body_momentum(R0[i], o[i, 0], o[i, 1], o[i, 2], vx, vy, vz,
                                                   wx, wy, wz, P[i, MASS], P[i, H:H + 3],
                                                   P[i, IO:IO + 6])
            px, py, pz, lx, ly, lz = px + fx, py + fy, pz + fz, lx + nx, ly + ny, lz + nz
            hx, hy, hz = rotate(R0[i], P[i, H], P[i, H + 1], P[i, H + 2])
            mi = P[i, MASS]
            m, cx, cy, cz = m + mi, cx + mi * o[i, 0] + hx, cy + mi * o[i, 1] + hy, cz + mi * o[i, 2] + hz
        ex, ey, ez = cross(cx / m, cy / m, cz / m, px, py, pz)
        out[s, 0], out[s, 1], out[s, 2] = px, py, pz
        out[s, 3], out[s, 4], out[s, 5] = lx - ex, ly - ey, lz - ez
    return OK


@njit(cache=True, inline="always")
def inertia_at_com(R0, m, h, I, Ic):
    """Ic (9,) = R0 I_c R0^T, row-major: a body's rotational inertia about its center of
    mass in world axes, I_c = I_O - (|h|^2 1 - h h^T) / m (the parallel-axis theorem,
    h = m c; I_c = I_O for a massless body, whose h is zero)."""
    k = 1.0 / m if m > 0.0 else 0.0
    hh = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]) * k
    A = ((I[0] - hh + h[0] * h[0] * k, I[3] + h[0] * h[1] * k, I[4] + h[0] * h[2] * k),
         (I[3] + h[1] * h[0] * k, I[1] - hh + h[1] * h[1] * k, I[5] + h[1] * h[2] * k),
         (I[4] + h[2] * h[0] * k, I[5] + h[2] * h[1] * k, I[2] - hh + h[2] * h[2] * k))
    for r in range(3):
        for c in range(3):
            acc = 0.0
            for a in range(3):
                for b in range(3):
                    acc += R0[r, a] * A[a][b] * R0[c, b]
            Ic[3 * r + c] = acc


@internal
def add_body(cols, nc, Z, O, Od, W, kinds, c, cd, w, m, Ic, C, T):
    """Body i's share of C (Angeles & Lee 1988, the NOC):

        C += T_i^T M_i dT_i/dt + T_i^T W_i M_i T_i,  T_i = [J_omega; J_c], M_i = diag(I_c, m),

    over the columns ``cols[:nc]`` that move it. Column k with axis z_k through o_k on a
    body turning at omega_k (origin velocity odot_k): revolute J_omega = z_k, J_c = z_k x
    (c - o_k); prismatic J_c = z_k; dz_k/dt = omega_k x z_k, and d/dt of J_c by the product
    rule with cdot the velocity of the center of mass c. T holds (J_omega, J_c, I_c dJ_omega/dt
    + omega x I_c J_omega, m dJ_c/dt) for each column."""
    for a in range(nc):
        k = int(cols[a])
        zx, zy, zz = Z[k, 0], Z[k, 1], Z[k, 2]
        ex, ey, ez = cross(W[k, 0], W[k, 1], W[k, 2], zx, zy, zz)           # dz/dt
        (T[a, 0], T[a, 1], T[a, 2], T[a, 3], T[a, 4], T[a, 5], T[a, 6], T[a, 7], T[a, 8],
         dx, dy, dz) = world_column_rate(kinds[k], zx, zy, zz, ex, ey, ez, c[0] - O[k, 0],
                                         c[1] - O[k, 1], c[2] - O[k, 2], cd[0] - Od[k, 0],
                                         cd[1] - Od[k, 1], cd[2] - Od[k, 2], Ic, w[0], w[1], w[2])
        T[a, 9], T[a, 10], T[a, 11] = m * dx, m * dy, m * dz
    for a in range(nc):
        for b in range(nc):
            C[int(cols[a]), int(cols[b])] += (T[a, 0] * T[b, 6] + T[a, 1] * T[b, 7] + T[a, 2] * T[b, 8]
                                    + T[a, 3] * T[b, 9] + T[a, 4] * T[b, 10] + T[a, 5] * T[b, 11])


def coriolis(P, q, qd, base, out):
    """out[s] (nv x nv): the Coriolis matrix C with C qd = b - g and dM/dt - 2 C skew, of the
    base body and the bodies (``add_body``), world axes; the same matrix as the NumPy
    reference's NOC (algorithms/noc.py, and algorithms/floating.py for a floating base,
    whose six columns are three slides along and three turns about the base's axes through
    its origin). qd (N or 1, nv) broadcasts."""
    n = P.shape[0] - 1
    N = q.shape[0]
    nb = q.shape[1] - n
    nv = n + (6 if nb else 0)
    if (nb not in (0, 7) or qd.shape[1] != nv or out.shape[0] != N or qd.shape[0] not in (1, N)
            or out.shape[1] != nv or out.shape[2] != nv or base.shape[0] != 10):
        return BAD_LENGTH
    if not_finite(q) or not_finite(qd):
        return NOT_FINITE
    ps = new_poses(n)
    R0, o, Rb, pb = ps.R0, ps.o, ps.Rb, ps.pb
    # each column: its axis Z through O on a body turning at W, O moving at Od; revolute?
    Z, O, W, Od = stack_empty((nv, 3)), stack_empty((nv, 3)), stack_empty((nv, 3)), stack_empty((nv, 3))
    kinds, cols = stack_empty((nv,)), stack_empty((nv,))   # each column's joint type; indices
    T, Ic = stack_empty((nv, 12)), stack_empty((9,))
    c, cd = stack_empty((3,)), stack_empty((3,))
    jv = nv - n
    for s in range(N):
        if not root_and_bodies(P, ps, q[s], nb, n):
            return NOT_FINITE
        u = row(qd, s)
        C = out[s]
        for a in range(nv):
            for b in range(nv):
                C[a, b] = 0.0
        vx, vy, vz = rotate(Rb, u[0], u[1], u[2]) if nb else (0.0, 0.0, 0.0)
        wx, wy, wz = rotate(Rb, u[3], u[4], u[5]) if nb else (0.0, 0.0, 0.0)
        for k in range(jv):          # the base: slides along, then turns about, its axes
            Z[k, 0], Z[k, 1], Z[k, 2] = Rb[0, k % 3], Rb[1, k % 3], Rb[2, k % 3]
            O[k, 0], O[k, 1], O[k, 2] = pb[0], pb[1], pb[2]
            W[k, 0], W[k, 1], W[k, 2] = wx, wy, wz
            Od[k, 0], Od[k, 1], Od[k, 2] = vx, vy, vz
            kinds[k] = REVOLUTE if k >= 3 else PRISMATIC
            cols[k] = k
        if nb and base[0] > 0.0:     # the base body
            hx, hy, hz = rotate(Rb, base[1], base[2], base[3])
            m = base[0]
            c[0], c[1], c[2] = pb[0] + hx / m, pb[1] + hy / m, pb[2] + hz / m
            ex, ey, ez = cross(wx, wy, wz, hx / m, hy / m, hz / m)
            cd[0], cd[1], cd[2] = vx + ex, vy + ey, vz + ez
            inertia_at_com(Rb, m, base[1:4], base[4:10], Ic)
            add_body(cols, jv, Z, O, Od, W, kinds, c, cd, (wx, wy, wz), m, Ic, C, T)
        for i in range(n):           # the joints, outward: their axes and velocities
            l = int(P[i, PARENT])
            k = jv + i
            if l < 0:
                ox, oy, oz, ax, ay, az = vx, vy, vz, wx, wy, wz
                dx, dy, dz = o[i, 0] - pb[0], o[i, 1] - pb[1], o[i, 2] - pb[2]
            else:
                ox, oy, oz = Od[jv + l, 0], Od[jv + l, 1], Od[jv + l, 2]
                ax, ay, az = W[jv + l, 0], W[jv + l, 1], W[jv + l, 2]
                dx, dy, dz = o[i, 0] - o[l, 0], o[i, 1] - o[l, 1], o[i, 2] - o[l, 2]
            ex, ey, ez = cross(ax, ay, az, dx, dy, dz)
            ox, oy, oz = ox + ex, oy + ey, oz + ez          # odot_i = odot_l + omega_l x (o_i - o_l)
            zx, zy, zz = R0[i, 0, 2], R0[i, 1, 2], R0[i, 2, 2]
            kinds[k] = P[i, KIND]
            ax, ay, az, ox, oy, oz = world_rate(kinds[k], ax, ay, az, ox, oy, oz, zx, zy, zz, u[k])
            Z[k, 0], Z[k, 1], Z[k, 2] = zx, zy, zz
            O[k, 0], O[k, 1], O[k, 2] = o[i, 0], o[i, 1], o[i, 2]
            W[k, 0], W[k, 1], W[k, 2] = ax, ay, az
            Od[k, 0], Od[k, 1], Od[k, 2] = ox, oy, oz
        for i in range(n):           # each body: the columns that move it
            m = P[i, MASS]
            hx, hy, hz = rotate(R0[i], P[i, H], P[i, H + 1], P[i, H + 2])
            km = 1.0 / m if m > 0.0 else 0.0
            c[0], c[1], c[2] = o[i, 0] + hx * km, o[i, 1] + hy * km, o[i, 2] + hz * km
            k = jv + i
            ex, ey, ez = cross(W[k, 0], W[k, 1], W[k, 2], hx * km, hy * km, hz * km)
            cd[0], cd[1], cd[2] = Od[k, 0] + ex, Od[k, 1] + ey, Od[k, 2] + ez
            nc = jv
            j = i
            while j >= 0:
                cols[nc] = jv + j
                nc += 1
                j = int(P[j, PARENT])
            inertia_at_com(R0[i], m, P[i, H:H + 3], P[i, IO:IO + 6], Ic)
            add_body(cols, nc, Z, O, Od, W, kinds, c, cd, (W[k, 0], W[k, 1], W[k, 2]), m, Ic, C, T)
    return OK


SINGLE_STATE = ("frame_pose_one", "frame_jacobian_one")   # one signature each (dispatch.py)
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "frame_pose": (frame_pose, i8(Pm, In2, i8, In1, Out3), False, ()),
    "frame_jacobian": (frame_jacobian, i8(Pm, In2, i8, In1, Out3), False, ()),
    "frame_pose_one": (frame_pose_one, i8(Pm, Vec, i8, Vec, Mat), False, ()),
    "frame_jacobian_one": (frame_jacobian_one, i8(Pm, Vec, i8, Vec, Mat), False, ()),
    "mass_moment": (mass_moment, i8(Pm, In2, In1, Out2), False, ()),
    "centroidal": (centroidal, i8(Pm, In2, In2, In1, Out2), False, ()),
    "coriolis": (coriolis, i8(Pm, In2, In2, In1, Out3), False, ()),
    "frame_acceleration": (frame_acceleration, i8(Pm, In2, In2, In2, i8, In1, Out2), False, ()),
}
