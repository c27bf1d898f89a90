"""The planar fast path's packed model ``Q``: its columns and ``planar_pack``, which
detects a planar chain and packs it (the planar analogue of ``layout.py``'s P). The
equations are ``algorithms/planar.py``'s (the reference, with the reasons the dropped
components change no joint torque) and ``planar.py``'s (compiled).

Planar frames and the layout ``Q``
----------------------------------
The base planar frame has axes E1, E2, N (base coordinates; N = the first revolute joint's
axis at q = 0). Body i's planar frame has its origin at joint frame i's origin and z = N;
its x axis is joint frame i's x axis for a revolute joint (the planar frame is then joint
frame i, or joint frame i turned by pi about x when the joint axis is -N), and parallel to
the parent's planar x axis at q = 0 for a prismatic joint. Body i in body i-1 (planar):

    rotation by  theta_i = ANG_i + SGN_i q_i          (SGN = +-1 revolute, 0 prismatic)
    origin at    p_i = (RX_i, RY_i) + q_i Rot(theta_i) d_i     (d_i = (DX_i, DY_i); 0 revolute)

    Q[i, ANG]        fixed angle of planar frame i from planar frame i-1 at q = 0 (about N)
    Q[i, RX:RY+1]    fixed in-plane offset of its origin, in planar frame i-1
    Q[i, KIND]       0.0 revolute, 1.0 prismatic
    Q[i, SGN]        revolute: +1 if the joint axis is +N, -1 if -N; prismatic: 0
    Q[i, DX:DY+1]    prismatic: the joint axis (unit, in the plane) in planar frame i; else 0
    Q[i, MASS]       m
    Q[i, HX:HY+1]    m (c_x, c_y), planar frame i
    Q[i, IZ]         moment of inertia about the normal through the planar origin
    Q[i, ARM]        armature (rotor inertia reflected to the joint), kg m^2 or kg:
                     tau_i += ARM qdd_i, M_ii += ARM
    Q[n, GX:GY+1]    gravity in the base planar frame (E1 . g, E2 . g)
    Q[n, TX:TY+1]    the tip point (where a tip wrench acts) in planar frame n-1
    Q[n, E1:E1+3], Q[n, E2:E2+3], Q[n, NRM:NRM+3]   the base planar axes (base coordinates),
                     to project a tip wrench: (E1 . f, E2 . f, N . m)

n = Q.shape[0] - 1 joints. A revolute joint's motion subspace in planar coordinates is
S_i = (SGN_i; 0, 0), a prismatic one's (0; d_i).
"""
from __future__ import annotations

import numpy as np

from ..joints import PRISMATIC

# columns of Q, per body (rows 0..n-1)
ANG, RX, RY, KIND, SGN, DX, DY, MASS, HX, HY, IZ, ARM = range(12)
# columns of Q's last row (row n)
GX, GY, TX, TY, E1, E2, NRM = 0, 1, 2, 3, 4, 7, 10
WIDTH = 13
TOL = 1e-12     # |sin| of the angle by which an axis may miss being parallel / perpendicular


def planar_pack(model, tol=TOL):
    """``Q`` (n + 1, WIDTH) for a planar ``model`` (module docstring), or None when the
    chain does not move in one plane (or has no revolute joint)."""
    n = model.dof
    kind = np.asarray(model.kind)
    if not np.any(kind != PRISMATIC) or not model.is_chain:
        return None                                   # no revolute joint (or a tree): no plane
    # joint frame i in the base at q = 0 (R_i = Xtree_R at q = 0 for both kinds)
    R0 = np.empty((n, 3, 3))
    R = np.eye(3)
    for i in range(n):
        R = R @ model.Xtree_R[i]
        R0[i] = R
    axes = R0[:, :, 2]                                # joint axes, base coordinates
    N = axes[int(np.flatnonzero(kind != PRISMATIC)[0])]
    for i in range(n):
        if kind[i] == PRISMATIC:
            if abs(axes[i] @ N) > tol:                # a prismatic axis out of the plane
                return None
        elif np.linalg.norm(np.cross(axes[i], N)) > tol:   # a revolute axis off the normal
            return None
    # base planar frame: x = joint 0's x axis (revolute) or its axis (prismatic), in the plane
    x = R0[0][:, 0] if kind[0] != PRISMATIC else axes[0]
    x = x - (x @ N) * N
    e1 = x / np.linalg.norm(x)
    e2 = np.cross(N, e1)
    arm = getattr(model, "armature", None)
    arm = np.zeros(n) if arm is None else np.asarray(arm, dtype=float).reshape(n)
    Q = np.zeros((n + 1, WIDTH))
    B_prev = np.column_stack([e1, e2, N])             # planar frame i-1's axes, base coords
    R_prev = np.eye(3)                                # joint frame i-1 in the base, q = 0
    for i in range(n):
        if kind[i] == PRISMATIC:                      # planar frame parallel to the parent's
            B = B_prev
            Q[i, KIND] = 1.0
            Q[i, DX], Q[i, DY] = B[:, :2].T @ axes[i]
        else:                                         # joint frame i, turned by pi about x if -N
            s = 1.0 if axes[i] @ N > 0.0 else -1.0
            B = R0[i] @ np.diag([1.0, s, s])
            Q[i, SGN] = s
        xb = B_prev.T @ B[:, 0]                       # planar x axis of i in planar frame i-1
        Q[i, ANG] = np.arctan2(xb[1], xb[0])
        Q[i, RX], Q[i, RY] = B_prev[:, :2].T @ (R_prev @ model.Xtree_p[i])
        Rp = R0[i].T @ B                              # planar frame i's axes in joint frame i
        Q[i, MASS] = model.mass[i]
        Q[i, HX], Q[i, HY] = Rp[:, :2].T @ model.h[i]
        Q[i, IZ] = Rp[:, 2] @ model.I_O[i] @ Rp[:, 2]
        Q[i, ARM] = arm[i]
        B_prev, R_prev = B, R0[i]
    Q[n, GX], Q[n, GY] = e1 @ model.gravity, e2 @ model.gravity
    Q[n, TX], Q[n, TY] = B_prev[:, :2].T @ (R_prev @ model.Xtip_p)
    Q[n, E1:E1 + 3], Q[n, E2:E2 + 3], Q[n, NRM:NRM + 3] = e1, e2, N
    return Q
