"""The torque regressor Y(q, qd, qdd): inverse dynamics is linear in the inertial parameters.

Every body's wrench about its origin (the Newton-Euler equations of ``rnea.py``, joint
frame i, classical acceleration ``acc`` of the origin; Luh, Walker & Paul 1980)

    f = m acc + alpha x h + omega x (omega x h)
    n = I_O alpha + omega x (I_O omega) + h x acc

is linear in the body's ten numbers (m, h = m c, I_O): (n; f) = A_i(omega, alpha, acc) phi_i
(Atkeson, An & Hollerbach, "Estimation of inertial parameters of manipulator loads
and links", Int. J. Robotics Research 5(3), 1986). The inward recursion is linear too, so carrying each
body's 6x10 block A_i to every joint below it (f' = R f, n' = R n + p x f', as ``rnea.py``)
and projecting on the joint's axis, tau_j = S_j^T X_{j<-i}^T A_i phi_i, gives the columns of
body i (Khalil & Dombre, *Modeling, Identification and Control of Robots*, 2002: the
Newton-Euler form of the identification model).

Columns per body, in Pinocchio's ``Inertia.toDynamicParameters`` order,

    [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]

with (mx, my, mz) = m c and I about the body origin, all in the body's **URDF link frame**
(Pinocchio's joint frame). The recursion runs in joint frames (docs/conventions.md); a
constant 10x10 map per body (``joint_frame_map``) carries the columns to the link frame:
with x_link = A x_joint, h_joint = A^T h_link and I_joint = A^T I_link A, so
phi_joint = T phi_link and Y_link = Y_joint T.

The armature (reflected rotor inertia I_a, tau_i += I_a qdd_i) has the column qdd_i e_i.
"""
import numpy as np

from ._batch import as_batch, mv, skew, unbatch
from .joint import axes, joint_rate
from .kinematics import joint_transforms
from .rnea import into_body

PARAMETERS = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))   # Ixx Ixy Iyy Ixz Iyz Izz


def regressor(model, q, qd, qdd, armature=False):
    """Y (n, 10 n) or (N, n, 10 n), the link-frame columns of every body (then, with
    ``armature``, n columns qdd_i e_i): inverse_dynamics(q, qd, qdd) == Y @ phi."""
    single, (q, qd, qdd) = as_batch(model, ("q", q), ("qd", qd), ("qdd", qdd))
    Y = _regressor_joint_frames(model, q, qd, qdd) @ _block_diagonal(joint_frame_map(model.A))
    if armature:
        Y = np.concatenate([Y, qdd[:, :, None] * np.eye(model.dof)], axis=2)
    return unbatch(single, Y)


def link_frame_parameters(mass, com, inertia):
    """(n, 10) standard parameters of bodies given as in the URDF (``Model.mass``, ``com``,
    ``inertia`` about the center of mass, link axes): [m, m c, I_O] with the rotational
    inertia about the link origin, I_O = I_c + m (|c|^2 1 - c c^T) (parallel axes)."""
    mass, com, inertia = np.asarray(mass, float), np.asarray(com, float), np.asarray(inertia, float)
    I_O = inertia + mass[:, None, None] * (np.einsum("ni,ni->n", com, com)[:, None, None]
                                           * np.eye(3) - np.einsum("ni,nj->nij", com, com))
    return np.column_stack([mass, mass[:, None] * com] + [I_O[:, a, b] for a, b in _SYM])


def joint_frame_map(A):
    """T (n, 10, 10): the parameters of body i in its joint frame from those in its link
    frame, phi_joint = T[i] phi_link, for x_link = A[i] x_joint: m unchanged,
    h_joint = A^T h_link, I_joint = A^T I_link A. Built column by column from the unit
    parameter vectors (the map is linear)."""
    A = np.asarray(A, dtype=float)
    T = np.zeros((A.shape[0], 10, 10))
    for k in range(10):
        e = np.zeros(10)
        e[k] = 1.0
        I = np.zeros((3, 3))
        for s, (a, b) in enumerate(_SYM):
            I[a, b] = I[b, a] = e[4 + s]
        h_j = np.einsum("nji,j->ni", A, e[1:4])                       # A^T h
        I_j = np.swapaxes(A, 1, 2) @ I @ A                            # A^T I A
        T[:, 0, k] = e[0]
        T[:, 1:4, k] = h_j
        T[:, 4:, k] = np.stack([I_j[:, a, b] for a, b in _SYM], axis=1)
    return T


def _block_diagonal(T):
    n = T.shape[0]
    out = np.zeros((10 * n, 10 * n))
    for i in range(n):
        out[10 * i:10 * i + 10, 10 * i:10 * i + 10] = T[i]
    return out


def _inertia_columns(v):
    """L(v) (N, 3, 6): I v = L(v) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz] for a symmetric I."""
    L = np.zeros(v.shape[:-1] + (3, 6))
    for s, (a, b) in enumerate(_SYM):
        L[..., a, s] += v[..., b]
        if a != b:
            L[..., b, s] += v[..., a]
    return L


def body_block(omega, alpha, acc):
    """A (N, 6, 10): the body wrench (n; f) about the origin = A (m, h, I_O) (joint frame)."""
    N = omega.shape[0]
    A = np.zeros((N, 6, 10))
    W = skew(omega)
    A[:, 3:, 0] = acc                                            # f: m acc
    A[:, 3:, 1:4] = skew(alpha) + W @ W                          #    + alpha x h + w x (w x h)
    A[:, :3, 1:4] = -skew(acc)                                   # n: h x acc = -acc x h
    A[:, :3, 4:] = _inertia_columns(alpha) + W @ _inertia_columns(omega)  # I alpha + w x I w
    return A


def _regressor_joint_frames(model, q, qd, qdd):
    """Y (N, n, 10 n) for the parameters (m, h, I_O) of every body in its joint frame. On a
    tree body i's block reaches the joints on its path to the base (its ancestors j). (A
    floating base: this on its instantaneous tree, ``robot/floating.py``.)"""
    N, n = q.shape
    R, p = joint_transforms(model, q)
    base = (np.zeros((N, 3)), np.zeros((N, 3)),
            np.broadcast_to(-model.gravity, (N, 3)))        # gravity as a base acceleration
    motion, blocks = [], []
    for i in range(n):                                   # outward, as rnea.py
        l = model.parent[i]
        omega, alpha, acc = into_body(R, p, i, *(base if l < 0 else motion[l]))
        motion.append(joint_rate(model.kind[i], omega, alpha, acc, qd[:, i], qdd[:, i]))
        blocks.append(body_block(*motion[i]))
    Y = np.zeros((N, n, 10 * n))
    row = axes(model.kind)                               # tau_j = S_j^T (n; f): n_z or f_z
    for i in range(n):                                   # inward: body i's block to joints j
        B = blocks[i]
        for j in model.ancestors(i)[::-1]:               # i, its parent, ..., up to the base
            Y[:, j, 10 * i:10 * i + 10] = B[:, row[j]]
            if model.parent[j] >= 0:                     # to the parent: f' = R f, n' = R n + p x f'
                f = mv(R[:, j, None], np.swapaxes(B[:, 3:], 1, 2))             # (N, 10, 3)
                m = mv(R[:, j, None], np.swapaxes(B[:, :3], 1, 2)) + np.cross(p[:, j, None], f)
                B = np.concatenate([np.swapaxes(m, 1, 2), np.swapaxes(f, 1, 2)], axis=1)
    return Y
