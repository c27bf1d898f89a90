"""The joint types of the compiled core, each said once (spatial_v2's ``jcalc``, Pinocchio's
joint models; Featherstone 2008, Sec. 4.4 and Table 4.1): what a joint's type changes in a
recursion is a function here, and the recursions call it instead of asking the type.

A joint of the core moves body i about or along the z axis of its joint frame; its type is
``kind = P[i, KIND]`` (``layout.py``): 0.0 revolute, 1.0 prismatic. Spatial vectors are
angular first (docs/conventions.md): a motion (omega; v), a force (n; f). Then

    X_J(q)   revolute: Rz(q), no offset;  prismatic: no turn, the offset q e_z
    S        revolute: e_z angular (index 2);  prismatic: e_z linear (index 5)
    S^T x    x[2] or x[5]: the z of its angular or of its linear part
    S qd     omega_z += qd  or  v_z += qd (``add_rate``); the velocity product v x (S qd)

A free-flyer root joint (a floating base, 6 coordinates: q a pose on SE(3), v = [v_O,
omega] in the base frame, S = 1) is the third type: ``free_flyer`` below. It is asked once
per robot, not per body: it is body ``nb - 1`` of a floating base's virtual chain
(robot/floating.py), whose recursions start with it (``nb`` = 6, a constant of the caller).

The armature (reflected rotor inertia I_a) is added after the passes, as Pinocchio's
``rnea.hxx`` and ``crba.hxx`` add it: ``armature_torques`` (tau_i += I_a,i qdd_i) and
``armature_diagonal`` (M_ii += I_a,i); articulated bodies add it to D_i in their pass, as
its own equation says (D_i = S_i^T IA_i S_i + I_a,i).

A loop over the lanes of a batch (``*_lanes.py``) reads ``kind`` once before it, so that the
type is a constant of the loop (the loop writes arrays that numba cannot prove apart from
``P``, so LLVM would not hoist the read itself) and every step below is a select, not a
branch.

A new one-degree-of-freedom type (a helical joint) is a new ``kind`` value and a branch in
each function here (and in the reference's, ``algorithms/joint.py``).
"""
import math

from numba import njit

from .planar_layout import DX as PDX, DY as PDY, KIND as PKIND, SGN as PSGN
from .data import stack_empty
from .layout import ARM, ARMATURE, KIND, XP, XR
from .signatures import internal
from .spatial import SMALL_ANGLE, sincos

REVOLUTE, PRISMATIC = 0.0, 1.0      # P[i, KIND]


@njit(cache=True, inline="always")
def axis(kind):
    """The index of S = e_s in a spatial vector: 2 (revolute) or 5 (prismatic)."""
    return 2 if kind == REVOLUTE else 5


@njit(cache=True, inline="always")
def project(kind, az, lz):
    """S^T x of a spatial vector x given its angular z and linear z: n_z or f_z of a force
    (tau = S^T f), omega_z or v_z of a motion."""
    return az if kind == REVOLUTE else lz


@njit(cache=True, inline="always")
def joint_transform(P, i, s, c, q):
    """X_J(q) after Xtree: R_i = Xtree_R Rz(q) (revolute) or Xtree_R (prismatic) and p_i =
    Xtree_p (+ q Xtree_R e_z): body i's frame in its parent's, (R row-major, p_x, p_y, p_z)
    (s, c = sin q, cos q; Featherstone 2008, Sec. 4.2). The CPU's ``joint_transforms`` and
    the card's ``gpu/steps.joint_transform`` both call it."""
    if P[i, KIND] == REVOLUTE:      # columns 0, 1: c Xtree_R e_x + s Xtree_R e_y, c Xtree_R e_y - s Xtree_R e_x
        r = (c * P[i, XR] + s * P[i, XR + 1], c * P[i, XR + 1] - s * P[i, XR], P[i, XR + 2],
             c * P[i, XR + 3] + s * P[i, XR + 4], c * P[i, XR + 4] - s * P[i, XR + 3], P[i, XR + 5],
             c * P[i, XR + 6] + s * P[i, XR + 7], c * P[i, XR + 7] - s * P[i, XR + 6], P[i, XR + 8])
        return r, P[i, XP], P[i, XP + 1], P[i, XP + 2]
    r = (P[i, XR], P[i, XR + 1], P[i, XR + 2], P[i, XR + 3], P[i, XR + 4], P[i, XR + 5],
         P[i, XR + 6], P[i, XR + 7], P[i, XR + 8])
    return (r, P[i, XP] + q * P[i, XR + 2], P[i, XP + 1] + q * P[i, XR + 5],
            P[i, XP + 2] + q * P[i, XR + 8])


@internal
def joint_transforms(P, sc, R, p, q, n, first=0):
    """R_i = Xtree_R Rz(q_i) (revolute) or Xtree_R (prismatic) and p_i = Xtree_p
    (+ q_i Xtree_R e_z): body i in body i-1, into R, p; sin q, cos q into sc (2, n)
    (Featherstone 2008, Sec. 4.2), for i = first .. n-1 (6: past a free-flyer root's virtual
    joints, whose transforms its recursions do not read). Returns 0.0, or NaN when some
    q_i is NaN or Inf (x * 0.0 is NaN iff x is)."""
    small = True
    for i in range(first, n):
        small &= abs(q[i]) < SMALL_ANGLE
    chk = 0.0
    if small:                            # 8 at a time in loops of their own, so that they
        x, z = stack_empty((8,)), stack_empty((2, 8))   # vectorize (a loop of n < 8 would not)
        for i0 in range(first, n, 8):
            for j in range(8):
                x[j] = q[i0 + j] if i0 + j < n else 0.0
            for j in range(8):
                z[0, j], z[1, j] = sincos(x[j])
            for j in range(min(8, n - i0)):
                sc[0, i0 + j], sc[1, i0 + j] = z[0, j], z[1, j]
    else:                                # huge, NaN or Inf angles: libm's argument reduction
        for i in range(first, n):
            chk += q[i] * 0.0
            sc[0, i], sc[1, i] = math.sin(q[i]), math.cos(q[i])
    for i in range(first, n):
        r, p[i, 0], p[i, 1], p[i, 2] = joint_transform(P, i, sc[0, i], sc[1, i], q[i])
        R[i, 0, 0], R[i, 0, 1], R[i, 0, 2] = r[0], r[1], r[2]
        R[i, 1, 0], R[i, 1, 1], R[i, 1, 2] = r[3], r[4], r[5]
        R[i, 2, 0], R[i, 2, 1], R[i, 2, 2] = r[6], r[7], r[8]
    return chk


@njit(cache=True, inline="always")
def lane_transforms(P, i, QV, RB, PB, nl, small):
    """Joint i's transform in every lane (``joint_transforms``' operations): R_i into
    RB rows 9i..9i+8 (row-major), p_i into PB rows 3i..3i+2."""
    lane_transforms_at(P, i, QV, RB, PB, nl, small, 9 * i, 3 * i)


@njit(cache=True, inline="always")
def lane_transforms_at(P, i, QV, RB, PB, nl, small, ri, pi):
    """``lane_transforms`` into RB rows ri..ri+8 and PB rows pi..pi+2."""
    n = P.shape[0] - 1
    rp0, rp1, rp2, rp3, rp4, rp5, rp6, rp7, rp8 = (P[i, XR], P[i, XR + 1], P[i, XR + 2],
                                                   P[i, XR + 3], P[i, XR + 4], P[i, XR + 5],
                                                   P[i, XR + 6], P[i, XR + 7], P[i, XR + 8])
    pp0, pp1, pp2 = P[i, XP], P[i, XP + 1], P[i, XP + 2]
    # joint transform R = Rp' Rz(q) | Rp',  p = p' | p' + q Rp' e_z
    if P[i, KIND] == REVOLUTE:
        # sin q, cos q of every lane into PB's rows of p_i (written last): the polynomial
        # in one packed loop, then libm's for a lane with a huge angle. (In one loop with a
        # select, LLVM called libm's sincos in every lane and threw the result away.)
        for b in range(nl):
            PB[pi, b], PB[pi + 1, b] = sincos(QV[i, b])
        if not small:
            for b in range(nl):
                if QV[3 * n, b] != 1.0:
                    PB[pi, b], PB[pi + 1, b] = math.sin(QV[i, b]), math.cos(QV[i, b])
        for b in range(nl):
            s, c = PB[pi, b], PB[pi + 1, b]
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


@njit(cache=True, inline="always")
def add_rate(kind, az, lz, x):
    """A motion's angular z and linear z plus S x: a velocity plus S qd, an acceleration
    plus S qdd."""
    if kind == REVOLUTE:
        return az + x, lz
    return az, lz + x


@njit(cache=True, inline="always")
def velocity_product(kind, wx, wy, vx, vy, dq):
    """c = v x (S qd) of body i's velocity (omega; v) before its joint's rate (Featherstone
    2008, eq. 7.4 with a constant S): 6 numbers."""
    if kind == REVOLUTE:                     # (omega x qd e_z; v x qd e_z)
        return wy * dq, -wx * dq, 0.0, vy * dq, -vx * dq, 0.0
    return 0.0, 0.0, 0.0, wy * dq, -wx * dq, 0.0   # (0; omega x qd e_z)


@njit(cache=True, inline="always")
def joint_rate(kind, wx, wy, wz, ax, ay, az, lx, ly, lz, dq, ddq):
    """Joint i's rate qd, qdd added to body i's omega, alpha and classical acc (in its frame):
    9 numbers. Revolute: alpha += omega x (qd e_z) + qdd e_z, omega += qd e_z; prismatic:
    acc += 2 omega x (qd e_z) + qdd e_z."""
    if kind == REVOLUTE:
        return wx, wy, wz + dq, ax + wy * dq, ay - wx * dq, az + ddq, lx, ly, lz
    return wx, wy, wz, ax, ay, az, lx + 2.0 * wy * dq, ly - 2.0 * wx * dq, lz + ddq


@njit(cache=True, inline="always")
def joint_momentum(kind, m, hx, hy, Ixz, Iyz, Izz):
    """F = IC S, the momentum (n; f) of a composite body (m, h, I_O) moving with a unit rate
    of the joint, and S^T F: 7 numbers. Revolute: n = I_O e_z, f = e_z x h; prismatic:
    n = h x e_z, f = m e_z."""
    if kind == REVOLUTE:
        return Ixz, Iyz, Izz, -hy, hx, 0.0, Izz
    return hy, -hx, 0.0, 0.0, 0.0, m, m


# ---- in world axes (core/kinematics.py): the joint's axis z and origin o, world coordinates
@njit(cache=True, inline="always")
def cross(ax, ay, az, bx, by, bz):
    """a x b."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True, inline="always")
def world_column(kind, zx, zy, zz, rx, ry, rz):
    """The joint's Jacobian column [linear; angular], r the point minus the joint's origin:
    (z x r; z) revolute, (z; 0) prismatic."""
    if kind == REVOLUTE:
        jx, jy, jz = cross(zx, zy, zz, rx, ry, rz)
        return jx, jy, jz, zx, zy, zz
    return zx, zy, zz, 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def world_rate(kind, wx, wy, wz, vx, vy, vz, zx, zy, zz, a):
    """omega += z a (revolute) or v += z a (prismatic): 6 numbers."""
    if kind == REVOLUTE:
        return wx + zx * a, wy + zy * a, wz + zz * a, vx, vy, vz
    return wx, wy, wz, vx + zx * a, vy + zy * a, vz + zz * a


@njit(cache=True, inline="always")
def world_joint_rate(kind, wx, wy, wz, bx, by, bz, ax, ay, az, zx, zy, zz, hx, hy, hz, qd, qdd):
    """``joint_rate`` in world axes, h = omega x z: revolute alpha += z qdd + h qd, omega +=
    z qd; prismatic acc += z qdd + 2 h qd. (omega, alpha, acc): 9 numbers."""
    if kind == REVOLUTE:
        return (wx + zx * qd, wy + zy * qd, wz + zz * qd, bx + zx * qdd + hx * qd,
                by + zy * qdd + hy * qd, bz + zz * qdd + hz * qd, ax, ay, az)
    return (wx, wy, wz, bx, by, bz, ax + zx * qdd + 2.0 * hx * qd, ay + zy * qdd + 2.0 * hy * qd,
            az + zz * qdd + 2.0 * hz * qd)


@njit(cache=True, inline="always")
def world_column_rate(kind, zx, zy, zz, ex, ey, ez, rx, ry, rz, ux, uy, uz, Ic, wx, wy, wz):
    """A column of the natural orthogonal complement's T_i = [J_omega; J_c] of a body with
    center of mass c, rotational inertia Ic (world axes, row-major) and angular velocity w,
    and of d/dt: e = dz/dt, r = c - o, u = cdot - odot. Revolute: J_omega = z, J_c = z x r,
    dJ_c/dt = e x r + z x u; prismatic: J_omega = 0, J_c = z, dJ_c/dt = e. Returns
    (J_omega, J_c, Ic e + w x (Ic z), dJ_c/dt): 12 numbers (core/kinematics.add_body)."""
    if kind == REVOLUTE:
        jx, jy, jz = cross(zx, zy, zz, rx, ry, rz)
        ax, ay, az = cross(ex, ey, ez, rx, ry, rz)
        bx, by, bz = cross(zx, zy, zz, ux, uy, uz)
        gx = Ic[0] * zx + Ic[1] * zy + Ic[2] * zz                       # I_c z
        gy = Ic[3] * zx + Ic[4] * zy + Ic[5] * zz
        gz = Ic[6] * zx + Ic[7] * zy + Ic[8] * zz
        fx, fy, fz = cross(wx, wy, wz, gx, gy, gz)
        return (zx, zy, zz, jx, jy, jz, Ic[0] * ex + Ic[1] * ey + Ic[2] * ez + fx,
                Ic[3] * ex + Ic[4] * ey + Ic[5] * ez + fy, Ic[6] * ex + Ic[7] * ey + Ic[8] * ez + fz,
                ax + bx, ay + by, az + bz)
    return 0.0, 0.0, 0.0, zx, zy, zz, 0.0, 0.0, 0.0, ex, ey, ez


# ---- derivatives (core/derivatives.py, tree_derivatives.py and their lanes): a joint's
# d X_J/dq and the linearized rate terms
@njit(cache=True, inline="always")
def rate_terms(kind, dq):
    """(c_alpha, c_acc): d omega' x (qd e_z) enters d alpha with qd (revolute) or d acc with
    2 qd (prismatic), the linearized ``joint_rate``."""
    return (dq, 0.0) if kind == REVOLUTE else (0.0, 2.0 * dq)


@njit(cache=True, inline="always")
def seeds(T, k, kind, dqk, wz, wpx, wpy, apx, apy, lpx, lpy, ex, ey, mx, my):
    """The seeds of directions q_k (column 2k of T) and qd_k (2k + 1) of joint k (its
    d X_J / dq and S; algorithms/derivatives.py):
    omega', alpha', acc' before joint k moves, wz after, the tip wrench (e; m) in frame k."""
    a, b = 2 * k, 2 * k + 1
    for i in range(15):
        T[i, a] = 0.0
        T[i, b] = 0.0
    if kind == REVOLUTE:
        T[0, a], T[1, a] = wpy, -wpx                  # d omega = omega x e_z
        T[3, a], T[4, a] = apy - dqk * wpx, -apx - dqk * wpy   # alpha' x e_z + qd (omega' x e_z) x e_z
        T[6, a], T[7, a] = lpy, -lpx                  # d acc = acc x e_z
        T[9, a], T[10, a], T[12, a], T[13, a] = ey, -ex, my, -mx   # d e = e x e_z
        T[2, b] = 1.0                                 # d omega = e_z
        T[3, b], T[4, b] = wpy, -wpx                  # d alpha = omega' x e_z
    else:
        # d acc = alpha' x e_z + omega' x (omega' x e_z)
        T[6, a], T[7, a], T[8, a] = apy + wz * wpx, -apx + wz * wpy, -(wpx * wpx + wpy * wpy)
        T[6, b], T[7, b] = 2.0 * wpy, -2.0 * wpx      # d acc = 2 omega' x e_z


@njit(cache=True, inline="always")
def own_turn(kind, r, px, py, pz, nx, ny, nz, fx, fy):
    """Joint j's own turn on the joint wrench (n; f) of body j carried to body j-1, along
    direction q_j: g = R_j (e_z x f); revolute: d f = g, d n = R_j (e_z x n) + p_j x g;
    prismatic: d n = g  (algorithms/derivatives.py). Returns (d n, d f)."""
    gx = -r[0] * fy + r[1] * fx
    gy = -r[3] * fy + r[4] * fx
    gz = -r[6] * fy + r[7] * fx
    if kind == REVOLUTE:
        return (-r[0] * ny + r[1] * nx + py * gz - pz * gy, -r[3] * ny + r[4] * nx + pz * gx - px * gz,
                -r[6] * ny + r[7] * nx + px * gy - py * gx, gx, gy, gz)
    return gx, gy, gz, 0.0, 0.0, 0.0


@njit(cache=True, inline="always")
def free_flyer(wx, wy, wz, a0, a1, a2, a3, a4, a5, bx, by, bz):
    """The free-flyer root's body motion (omega, alpha, acc) in its frame, 9 numbers, from
    omega = qd[3:6], qdd[:6] = dv/dt plus the velocity products (core/floating.rnea_inputs)
    and the base's start acceleration b (-g): its successive axes add their products,
    alpha = qdd[3:6] + (wy wz, -wx wz, wx wy), acc = b + qdd[:3] (Featherstone 2008, Sec. 9.3)."""
    return wx, wy, wz, a3 + wy * wz, a4 - wx * wz, a5 + wx * wy, bx + a0, by + a1, bz + a2


@njit(cache=True, inline="always")
def has_armature(P):
    """Some joint has armature (``layout.pack``): else the kernels add none (a loop of adds
    of zero costs a single mass-matrix call 3-4 %)."""
    return P[P.shape[0] - 1, ARMATURE] != 0.0


@njit(cache=True, inline="always")
def armature_torques(P, qdd, use_qdd, tau, first):
    """tau_i += I_a,i qdd_i (the rotor's inertia reflected through the gear), i >= first:
    after the Newton-Euler passes."""
    if has_armature(P):
        for i in range(first, tau.shape[0]):
            tau[i] += P[i, ARM] * (qdd[i] if use_qdd else 0.0)


@njit(cache=True, inline="always")
def armature_torques_lanes(P, QV, TB, nl, first):
    """``armature_torques`` in every lane of a batch kernel: TB[i, b] += I_a,i qdd_i, with
    qdd in QV rows 2n.. (``rnea_lanes.gather``)."""
    if has_armature(P):
        n = P.shape[0] - 1
        for i in range(first, n):
            arm = P[i, ARM]
            for b in range(nl):
                TB[i, b] += arm * QV[2 * n + i, b]


@njit(cache=True, inline="always")
def armature_diagonal(P, M, first):
    """M_ii += I_a,i, i >= first: after the composite-body pass."""
    if has_armature(P):
        for i in range(first, M.shape[0]):
            M[i, i] += P[i, ARM]


# ---- planar joints: the planar fast path's layout Q (planar_layout.planar_pack), the
# body's motion (omega_N; acc_x, acc_y) and wrench (n_N; f_x, f_y) as 3-vectors in the plane.
# A revolute joint turns about SGN N, a prismatic one slides along d = (DX, DY); a loop reads
# the joint once, ``planar_joint``, and passes the tuple.
@njit(cache=True, inline="always")
def planar_joint(Q, i):
    """(kind, SGN, d_x, d_y) of planar joint i."""
    return Q[i, PKIND], Q[i, PSGN], Q[i, PDX], Q[i, PDY]


@njit(cache=True, inline="always")
def planar_origin(jt, rx, ry, c, s, q):
    """Body i's origin in its parent's planar frame: r (revolute), r + q Rot(theta) d
    (prismatic; c, s = cos, sin theta)."""
    if jt[0] == REVOLUTE:
        return rx, ry
    dx, dy = jt[2], jt[3]
    return rx + q * (c * dx - s * dy), ry + q * (s * dx + c * dy)


@njit(cache=True, inline="always")
def planar_rate(jt, wz, az, lx, ly, dq, ddq):
    """``joint_rate`` in the plane: revolute alpha += SGN qdd, omega += SGN qd; prismatic
    acc += 2 omega x (qd d) + qdd d. (omega, alpha, acc_x, acc_y)."""
    kind, sg, dx, dy = jt
    if kind == REVOLUTE:
        return wz + sg * dq, az + sg * ddq, lx, ly
    return wz, az, lx - 2.0 * wz * dq * dy + ddq * dx, ly + 2.0 * wz * dq * dx + ddq * dy


@njit(cache=True, inline="always")
def planar_project(jt, nz, fx, fy):
    """S^T (n; f) in the plane: SGN n_N (revolute) or d . f (prismatic)."""
    kind, sg, dx, dy = jt
    return sg * nz if kind == REVOLUTE else dx * fx + dy * fy


@njit(cache=True, inline="always")
def planar_momentum(jt, m, hx, hy, Izz):
    """F = IC S of a composite (m, h, I_nn) and S^T F: revolute (SGN I_nn; SGN N x h),
    prismatic (h x d; m d). (n, f_x, f_y, S^T F)."""
    kind, sg, dx, dy = jt
    if kind == REVOLUTE:
        nz, fx, fy = sg * Izz, -sg * hy, sg * hx
    else:
        nz, fx, fy = hx * dy - hy * dx, m * dx, m * dy
    return nz, fx, fy, planar_project(jt, nz, fx, fy)
