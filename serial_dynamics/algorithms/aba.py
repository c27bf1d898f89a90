"""Forward dynamics by the articulated-body algorithm (ABA): O(n) in the number of joints.

Featherstone, *Rigid Body Dynamics Algorithms* (2008), Sec. 7.3 and Table 7.1, in joint
frames (see serial_dynamics/model/model.py and docs/conventions.md). Spatial vectors of body i are
in joint frame i, angular part first, about its origin: motion (omega, v_O), force (n_O, f);
S_i = e_z (angular for a revolute joint, linear for a prismatic one).

    pass 1 (outward)  v_i = X_i v_{i-1} + S_i qd_i       c_i = v_i x S_i qd_i
                      IA_i = I_i                          pA_i = v_i x* I_i v_i - f_ext_i
    pass 2 (inward)   U_i = IA_i S_i   D_i = S_i^T U_i    u_i = tau_i - S_i^T pA_i
                      Ia = IA_i - U_i U_i^T / D_i         pa = pA_i + Ia c_i + U_i u_i / D_i
                      IA_{i-1} += X_i^T Ia X_i            pA_{i-1} += X_i^T pa
    pass 3 (outward)  a'_i = X_i a_{i-1} + c_i            qdd_i = (u_i - U_i^T a'_i) / D_i
                      a_i = a'_i + S_i qdd_i              with a_{-1} = (0, -g)

The armature I_a,i adds to D_i (as to M_ii). A base with known motion starts pass 1 with
v_{-1} = (omega_0, 0) and pass 3 with a_{-1} = (alpha_0, acc_0 - g): the spatial
acceleration of a base origin at rest is its classical acceleration.

``X_i`` carries motion vectors from joint frame i-1 to joint frame i; with (R, p) body i in
body i-1 (``kinematics.joint_transforms``), X = [[R^T, 0], [-R^T [p]x, R^T]]. Gravity is the
base acceleration -g, as in the Newton-Euler recursion. The result is the same as the
Cholesky route of ``forward.py`` (tests compare them); ABA wins for long chains (``CROSSOVER``).
"""
import numpy as np

from ._batch import (as_batch, cross_motion, motion_transform, mtv,
                     rigid_body_inertia, skew, unbatch)
from .joint import motion_subspaces
from .kinematics import joint_transforms
from .rnea import _tip_rotation, _wrench_batch

# forward_dynamics(method="auto") uses ABA from this many joints on and the Cholesky route
# below: with the compiled kernels, single calls, ABA overtakes CRBA + Cholesky between 28
# and 32 joints (bench/bench_speed.py, docs/speed.md).
CROSSOVER = 30


def spatial_inertia(mass, com, inertia):
    """6x6 rigid-body inertia about the body origin from the center of mass ``com`` and the
    rotational inertia ``inertia`` about it: [[I_c + m [c]x [c]x^T, m [c]x], [m [c]x^T, m 1]]
    (Featherstone eq. 2.63); the algorithms use ``rigid_body_inertia(m, h, I_O)``."""
    m, c = np.asarray(mass, dtype=float), np.asarray(com, dtype=float)
    C = skew(c)
    I_O = inertia + m[..., None, None] * C @ np.swapaxes(C, -1, -2)
    return rigid_body_inertia(m, m[..., None] * c, I_O)


def forward_dynamics(model, q, qd, tau, wrench=None, gravity=None, base_motion=None):
    """qdd (n,) or (N, n) for applied joint torques ``tau`` (rigid body only, no friction);
    ``wrench`` (6,) or (N, 6) on the tip frame origin, base coordinates; ``base_motion`` a
    ``BaseMotion`` or None."""
    single, (q, qd, tau) = as_batch(model, ("q", q), ("qd", qd), ("tau", tau))
    g = model.gravity if gravity is None else np.asarray(gravity, dtype=float)
    w = _wrench_batch(wrench, q.shape[0])
    return unbatch(single, _aba(model, q, qd, tau, g, w, base_motion))


def _aba(model, q, qd, tau, g, w, base=None, root=None):
    """qdd (N, n); with ``root`` = (I_root (6, 6), v_root (N, 6), f_root (N, 6): the force
    applied to it), a floating root (body -1; Featherstone 2008, Ch. 9, floating bases):
    passes 1 and 2 run through it too, its acceleration is a'_-1 = -IA_-1^-1 pA_-1, and
    (qdd, a'_-1) is returned (a'_-1 with gravity removed: the root's spatial acceleration
    is a'_-1 + (0, g))."""
    N, n = q.shape
    R, p = joint_transforms(model, q)
    X = motion_transform(R, p)                                   # (N, n, 6, 6)
    S = motion_subspaces(model)                                  # (n, 6)
    I = rigid_body_inertia(model.mass, model.h, model.I_O)       # (n, 6, 6)
    mv6 = lambda A, x: np.einsum("...ij,...j->...i", A, x)      # noqa: E731
    mtv6 = lambda A, x: np.einsum("...ji,...j->...i", A, x)     # noqa: E731
    # --- pass 1, outward
    v = np.zeros((N, 6))
    if base is not None:                                         # v_{-1} = (omega_0, 0)
        v[:, :3] = base.angular_velocity
    if root is not None:                                         # the root's velocity
        v = v + root[1]
        IA_root = np.repeat(root[0][None], N, axis=0)            # IA_-1 = I_-1
        pA_root = -mtv6(cross_motion(v), mv6(root[0], v)) - root[2]   # v x* I v - f_-1
    c = np.empty((N, n, 6))
    IA = np.empty((N, n, 6, 6))
    pA = np.empty((N, n, 6))
    V = [v] * n                                                  # v_i (a list: no strided views)
    v_base = v
    for i in range(n):                                           # a tree: from the parent l
        vJ = qd[:, i, None] * S[i]
        l = model.parent[i]
        v = mv6(X[:, i], v_base if l < 0 else V[l]) + vJ         # v_i = X_i v_l + S_i qd_i
        V[i] = v
        c[:, i] = mv6(cross_motion(v), vJ)                       # c_i = v_i x S_i qd_i
        IA[:, i] = I[i]
        pA[:, i] = -mtv6(cross_motion(v), mv6(I[i], v))          # v x* I v = -[v]x^T I v
    if w is not None:            # f_ext on the last body: w, in joint frame n-1, about its origin
        R_tip = _tip_rotation(model, R)                                 # base <- joint frame n-1
        f = mtv(R_tip, w[:, :3])
        m = mtv(R_tip, w[:, 3:]) + np.cross(model.Xtip_p, f)
        pA_tip = pA[:, n - 1] if n else pA_root                 # a free body: on the root
        pA_tip[:, :3] -= m
        pA_tip[:, 3:] -= f
    # --- pass 2, inward
    U = np.empty((N, n, 6))
    D = np.empty((N, n))
    u = np.empty((N, n))
    for i in range(n - 1, -1, -1):
        U[:, i] = mv6(IA[:, i], S[i])                            # U_i = IA_i S_i
        D[:, i] = U[:, i] @ S[i] + model.armature[i]             # D_i = S_i^T U_i + I_a,i
        u[:, i] = tau[:, i] - pA[:, i] @ S[i]                    # u_i = tau_i - S_i^T pA_i
        l = model.parent[i]
        if l >= 0 or root is not None:
            Ia = IA[:, i] - U[:, i, :, None] * U[:, i, None, :] / D[:, i, None, None]
            pa = pA[:, i] + mv6(Ia, c[:, i]) + U[:, i] * (u[:, i] / D[:, i])[:, None]
            Xi = X[:, i]
            IA_parent, pA_parent = (IA[:, l], pA[:, l]) if l >= 0 else (IA_root, pA_root)
            IA_parent += np.swapaxes(Xi, -1, -2) @ Ia @ Xi       # IA_l += X^T Ia X
            pA_parent += mtv6(Xi, pa)                            # pA_l += X^T pa
    # --- pass 3, outward
    a = np.zeros((N, 6))
    a[:, 3:] = -g                                                # a_{-1} = (0, -g)
    if base is not None:                                         # moving: (alpha_0, acc_0 - g)
        a[:, :3], a[:, 3:] = base.angular_acceleration, base.linear_acceleration - g
    if root is not None:                                         # a'_-1 = -IA_-1^-1 pA_-1
        a = -np.linalg.solve(IA_root, pA_root[..., None])[..., 0]
        a_root = a
    qdd = np.empty((N, n))
    Acc = [a] * n                                                # a_i
    a_base = a
    for i in range(n):
        l = model.parent[i]
        a = mv6(X[:, i], a_base if l < 0 else Acc[l]) + c[:, i]  # a'_i = X_i a_l + c_i
        qdd[:, i] = (u[:, i] - np.einsum("nk,nk->n", U[:, i], a)) / D[:, i]
        Acc[i] = a + qdd[:, i, None] * S[i]                      # a_i = a'_i + S_i qdd_i
    return qdd if root is None else (qdd, a_root)
