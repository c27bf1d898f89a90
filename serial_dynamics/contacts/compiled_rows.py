"""The contacts' rows in compiled code, for ``compiled.py``'s kernel: what
``jacobians.contact_rows`` computes in NumPy (the stacked contact Jacobian, J-dot v and the
position errors Baumgarte's term reads) from the poses of every body, computed once
(``root_and_bodies``), at each contact link's frame, moved to the contact point.

The contacts enter as one array (``contact_table``), a row per contact: its body and frame
on it (the link's frame [R row-major, p] in the body's joint frame, or the point's where it
is folded: ``jacobians.point_frames``), the point on the link, the other link's body and
frame (a loop), the anchor [R row-major, p].
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..algorithms.kinematics import frame_of
from ..core.data import new_poses, stack_empty
from ..core.joint import cross
from ..core.kinematics import (acceleration_at, ancestors, jacobian_at, pose_at,
                               root_and_bodies, rotate, rotate_t)

# the table's columns (F1, F2, ANCHOR: 12 each; POINT: 3) and its width
BODY, FRAME, OTHER, BODY2, ANCHORED, F1, POINT, F2, ANCHOR = 0, 1, 2, 3, 4, 5, 17, 20, 32
WIDTH = 44


@njit(inline="always")
def _classical(S, rx, ry, rz):
    """A body point's classical acceleration at zero joint acceleration, r from the origin:
    a_o + alpha x r + w x (w x r) (S rows: a_o, alpha, v_o, w)."""
    ex, ey, ez = cross(S[1, 0], S[1, 1], S[1, 2], rx, ry, rz)
    fx, fy, fz = cross(S[3, 0], S[3, 1], S[3, 2], rx, ry, rz)
    gx, gy, gz = cross(S[3, 0], S[3, 1], S[3, 2], fx, fy, fz)
    return S[0, 0] + ex + gx, S[0, 1] + ey + gy, S[0, 2] + ez + gz


@njit(inline="always")
def _spatial(S, rx, ry, rz):
    """The linear part of the body's spatial acceleration at the point r from the origin:
    a_o + alpha x r - w x v_o (Featherstone 2008, Sec. 2.11); its angular part is alpha."""
    ex, ey, ez = cross(S[1, 0], S[1, 1], S[1, 2], rx, ry, rz)
    fx, fy, fz = cross(S[3, 0], S[3, 1], S[3, 2], S[2, 0], S[2, 1], S[2, 2])
    return S[0, 0] + ex - fx, S[0, 1] + ey - fy, S[0, 2] + ez - fz


@njit(inline="always")
def _point_rows(J, rx, ry, rz, sign, out, i):
    """out[i:i+3] += sign (J_v - [r]x J_w): the rows of the body point at r from the origin
    of the frame whose Jacobian is J (v_P = v_o + w x r)."""
    for j in range(J.shape[1]):
        cx, cy, cz = cross(rx, ry, rz, J[3, j], J[4, j], J[5, j])
        out[i, j] += sign * (J[0, j] - cx)
        out[i + 1, j] += sign * (J[1, j] - cy)
        out[i + 2, j] += sign * (J[2, j] - cz)


@njit(inline="always")
def _rotation_log(R):
    """phi with exp([phi]x) = R (3 x 3), through R's unit quaternion (Shepperd 1978: the
    largest of the trace and the diagonal picks the well-conditioned formula), then
    phi = theta / sin(theta / 2) (x, y, z), theta = 2 atan2(|(x, y, z)|, w), w >= 0."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    qv = stack_empty((4,))
    i = 0
    for k in range(1, 3):
        if R[k, k] > R[i, i]:
            i = k
    if tr > R[i, i]:
        qv[0], qv[1], qv[2] = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
        qv[3] = 1.0 + tr
    else:
        j, k = (i + 1) % 3, (i + 2) % 3
        qv[i] = 1.0 - tr + 2.0 * R[i, i]
        qv[j] = R[j, i] + R[i, j]
        qv[k] = R[k, i] + R[i, k]
        qv[3] = R[k, j] - R[j, k]
    s = 1.0 if qv[3] >= 0.0 else -1.0
    nq = math.sqrt(qv[0] ** 2 + qv[1] ** 2 + qv[2] ** 2 + qv[3] ** 2)
    x, y, z, w = s * qv[0] / nq, s * qv[1] / nq, s * qv[2] / nq, s * qv[3] / nq
    theta = 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
    # theta / sin(theta / 2) by its Taylor series near 0 (2 + t^2 / 12 + 7 t^4 / 2880)
    c = (2.0 + theta * theta / 12.0 + 7.0 * theta ** 4 / 2880.0 if theta <= 1e-3
         else theta / math.sin(0.5 * theta))
    return c * x, c * y, c * z


@njit(inline="always")
def _se3_log(R, px, py, pz):
    """log6 of the pose (R, p): [rho; phi], rho = V(phi)^-1 p (``jacobians.se3_log``; Eade,
    'Lie groups for 2D and 3D transformations')."""
    fx, fy, fz = _rotation_log(R)
    t = math.sqrt(fx * fx + fy * fy + fz * fz)
    # V^-1 = 1 - [phi]x / 2 + c [phi]x^2, c = (1 - t sin t / (2 (1 - cos t))) / t^2
    c = (1.0 / 12.0 + t * t / 720.0 if t < 1e-4
         else (1.0 - t * math.sin(t) / (2.0 * (1.0 - math.cos(t)))) / (t * t))
    ax, ay, az = cross(fx, fy, fz, px, py, pz)
    bx, by, bz = cross(fx, fy, fz, ax, ay, az)
    return px - 0.5 * ax + c * bx, py - 0.5 * ay + c * by, pz - 0.5 * az + c * bz, fx, fy, fz


# ------------------------------------------------------------------ the rows
@njit(inline="always")
def _link(P, ps, nb, v, z, body, F, pose, rates, X, J, A, S, path):
    """One link's kinematics at (q, v), world axes, from the poses ``ps`` of every body
    (``root_and_bodies`` of q, once for all contacts; core/kinematics.py's per-state steps,
    so the bits of its kernels): its pose X (where ``pose``), the Jacobian J at the frame F's
    origin and S's rows a_o, alpha (acceleration at zero joint acceleration: z, zeros), v_o,
    w (where ``rates``, else zeros). ``path``: scratch for the link's ancestors."""
    if pose:
        pose_at(ps, body, F, X)
    jacobian_at(P, ps, nb, body, F, J)
    acceleration_at(P, ps, nb, path, ancestors(P, body, path), v, z, body, F, A)
    for r in range(3):
        S[0, r], S[1, r] = A[r], A[3 + r]
        S[2, r], S[3, r] = 0.0, 0.0
        if rates:
            for j in range(v.shape[0]):
                S[2, r] += J[r, j] * v[j]
                S[3, r] += J[3 + r, j] * v[j]


@njit(inline="always")
def _frame_error(row, X1, X2, other, Px, Py, Pz, err, i):
    """err[i:i+6] = R1 log6(c2^-1 c1) (``jacobians._frame_error``): c1 the contact frame
    (link 1's axes at P), c2 the anchor, in the world or on link 2 (X2)."""
    A, R2, Rr = stack_empty((3, 3)), stack_empty((3, 3)), stack_empty((3, 3))
    for r in range(3):
        for c in range(3):
            A[r, c] = row[ANCHOR + 3 * r + c]
    ax, ay, az = row[ANCHOR + 9], row[ANCHOR + 10], row[ANCHOR + 11]
    if other:            # R2 = R_link2 A_R, p2 = o2 + R_link2 A_p
        for r in range(3):
            for c in range(3):
                R2[r, c] = X2[r, 0] * A[0, c] + X2[r, 1] * A[1, c] + X2[r, 2] * A[2, c]
        bx, by, bz = rotate(X2, ax, ay, az)
        ax, ay, az = X2[0, 3] + bx, X2[1, 3] + by, X2[2, 3] + bz
    else:
        for r in range(3):
            for c in range(3):
                R2[r, c] = A[r, c]
    for r in range(3):   # R2^T R1
        for c in range(3):
            Rr[r, c] = R2[0, r] * X1[0, c] + R2[1, r] * X1[1, c] + R2[2, r] * X1[2, c]
    px, py, pz = rotate_t(R2, Px - ax, Py - ay, Pz - az)
    e0, e1, e2, e3, e4, e5 = _se3_log(Rr, px, py, pz)
    err[i], err[i + 1], err[i + 2] = rotate(X1, e0, e1, e2)
    err[i + 3], err[i + 4], err[i + 5] = rotate(X1, e3, e4, e5)


@njit(inline="always")
def contact_rows(Pk, q, v, spec, kp, Jc, drift, err):
    """The stacked rows J (Jc), J-dot v (drift) and the position errors (err) of the
    contacts of ``spec`` (``jacobians.contact_rows``), on the poses of every body computed
    once. False for a quaternion of zero length (q's lengths are the caller's to check)."""
    n, nv = Pk.shape[0] - 1, v.shape[0]
    nb = q.shape[0] - n
    ps = new_poses(n)
    if not root_and_bodies(Pk, ps, q, nb, n):
        return False
    J1, J2 = stack_empty((6, nv)), stack_empty((6, nv))
    X1, X2, A = stack_empty((4, 4)), stack_empty((4, 4)), stack_empty((6,))
    S1, S2 = stack_empty((4, 3)), stack_empty((4, 3))
    F, path = stack_empty((12,)), stack_empty((n,))
    z = stack_empty((nv,))
    for j in range(nv):
        z[j] = 0.0
    for i in range(Jc.shape[0]):
        err[i] = 0.0
        for j in range(nv):
            Jc[i, j] = 0.0
    i = 0
    for c in range(spec.shape[0]):
        row = spec[c]
        frame, other, anchored = row[FRAME] != 0.0, row[OTHER] != 0.0, row[ANCHORED] != 0.0
        ux, uy, uz = row[POINT], row[POINT + 1], row[POINT + 2]
        pose = kp != 0.0 or other or ux != 0.0 or uy != 0.0 or uz != 0.0
        for k in range(12):
            F[k] = row[F1 + k]
        _link(Pk, ps, nb, v, z, int(row[BODY]), F, pose, pose or frame, X1, J1, A, S1, path)
        rx, ry, rz = rotate(X1, ux, uy, uz) if pose else (0.0, 0.0, 0.0)
        Px, Py, Pz = X1[0, 3] + rx, X1[1, 3] + ry, X1[2, 3] + rz     # the point (if pose)
        if other:
            for k in range(12):
                F[k] = row[F2 + k]
            _link(Pk, ps, nb, v, z, int(row[BODY2]), F, True, True, X2, J2, A, S2, path)
        _point_rows(J1, rx, ry, rz, 1.0, Jc, i)
        if not frame:                  # p1'' - p2'' (classical accelerations)
            drift[i], drift[i + 1], drift[i + 2] = _classical(S1, rx, ry, rz)
            if other:                  # link 2's anchor point, r2 = R2 anchor
                sx, sy, sz = rotate(X2, row[ANCHOR + 9], row[ANCHOR + 10], row[ANCHOR + 11])
                _point_rows(J2, sx, sy, sz, -1.0, Jc, i)
                bx, by, bz = _classical(S2, sx, sy, sz)
                drift[i], drift[i + 1] = drift[i] - bx, drift[i + 1] - by
                drift[i + 2] -= bz
                err[i], err[i + 1], err[i + 2] = (Px - (X2[0, 3] + sx), Py - (X2[1, 3] + sy),
                                                  Pz - (X2[2, 3] + sz))
            elif anchored:
                err[i], err[i + 1], err[i + 2] = (Px - row[ANCHOR + 9], Py - row[ANCHOR + 10],
                                                  Pz - row[ANCHOR + 11])
            i += 3
            continue
        # a frame: twists at P, [v(P); w], and spatial accelerations at P
        for j in range(nv):
            for k in range(3):
                Jc[i + 3 + k, j] = J1[3 + k, j]
        ax, ay, az = _spatial(S1, rx, ry, rz)
        bx, by, bz = S1[1, 0], S1[1, 1], S1[1, 2]
        if other:                      # link 2 at P, r2 = P - o2
            sx, sy, sz = Px - X2[0, 3], Py - X2[1, 3], Pz - X2[2, 3]
            _point_rows(J2, sx, sy, sz, -1.0, Jc, i)
            for j in range(nv):
                for k in range(3):
                    Jc[i + 3 + k, j] -= J2[3 + k, j]
            cx, cy, cz = _spatial(S2, sx, sy, sz)
            w1x, w1y, w1z = S1[3, 0], S1[3, 1], S1[3, 2]
            w2x, w2y, w2z = S2[3, 0], S2[3, 1], S2[3, 2]
            ex, ey, ez = cross(w1x, w1y, w1z, rx, ry, rz)           # v1 = v_o1 + w1 x r1
            v1x, v1y, v1z = S1[2, 0] + ex, S1[2, 1] + ey, S1[2, 2] + ez
            ex, ey, ez = cross(w2x, w2y, w2z, sx, sy, sz)           # v2 = v_o2 + w2 x r2
            v2x, v2y, v2z = S2[2, 0] + ex, S2[2, 1] + ey, S2[2, 2] + ez
            # d/dt of the relative twist in link's frame: A1 - A2 + V1 x V2 (the motion
            # cross product [w1 x v2 + v1 x w2; w1 x w2]; Featherstone 2008, Sec. 2.9)
            gx, gy, gz = cross(w1x, w1y, w1z, v2x, v2y, v2z)
            hx, hy, hz = cross(w2x, w2y, w2z, v1x, v1y, v1z)
            kx, ky, kz = cross(w1x, w1y, w1z, w2x, w2y, w2z)
            ax, ay, az = ax - cx + (gx - hx), ay - cy + (gy - hy), az - cz + (gz - hz)
            bx, by, bz = bx - S2[1, 0] + kx, by - S2[1, 1] + ky, bz - S2[1, 2] + kz
        drift[i], drift[i + 1], drift[i + 2] = ax, ay, az
        drift[i + 3], drift[i + 4], drift[i + 5] = bx, by, bz
        if kp != 0.0 and (other or anchored):
            _frame_error(row, X1, X2, other, Px, Py, Pz, err, i)
        i += 6
    return True


def contact_table(robot, contacts, folded):
    """The kernel's table of ``contacts`` (checked), a row per contact (module docstring).
    ``folded``: each point as a frame of its body (``jacobians.point_frames``: the link's
    placement with p moved by R point), its point then zero."""
    table = np.zeros((len(contacts), WIDTH))
    for row, c in zip(table, contacts):
        body, R, p = frame_of(robot.model, c.link)       # the link in its body's joint frame
        row[BODY], row[FRAME] = body, float(c.frame)
        point = np.asarray(c.point)
        if folded:
            row[F1:F1 + 12] = np.concatenate((R.ravel(), p + R @ point))
        else:
            row[F1:F1 + 12] = np.concatenate((R.ravel(), p))
            row[POINT:POINT + 3] = point
        if c.other_link is not None:
            body2, R2, p2 = frame_of(robot.model, c.other_link)
            row[OTHER], row[BODY2] = 1.0, body2
            row[F2:F2 + 12] = np.concatenate((R2.ravel(), p2))
        A = np.eye(4)
        if c.anchor is not None:
            row[ANCHORED] = 1.0
            A = np.array(c.anchor) if c.frame else np.r_[np.c_[np.eye(3), c.anchor], [[0, 0, 0, 1]]]
        row[ANCHOR:ANCHOR + 12] = np.concatenate((A[:3, :3].ravel(), A[:3, 3]))
    return table
