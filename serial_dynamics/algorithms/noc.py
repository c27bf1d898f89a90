"""The natural orthogonal complement (NOC) of the kinematic constraints.

Angeles & Lee (1988), "The formulation of dynamical equations of holonomic mechanical
systems using a natural orthogonal complement", J. Appl. Mech. 55; Angeles,
*Fundamentals of Robotic Mechanical Systems*, Sec. 7.5-7.6.

The 6n-dimensional twist of the chain stacks, per body i, t_i = [omega_i; cdot_i]
(angular velocity first, then the velocity of the center of mass), in BASE coordinates,
as in the textbook. The geometry comes once from the joint frames (see
serial_dynamics/model/model.py and docs/conventions.md): with R0_i, o_i the pose of joint frame i
in the base, z_i = R0_i e_z, c_i = o_i + R0_i c[i] and the inertia about c_i in base axes
R0_i I_c[i] R0_i^T. Then t = T(q) qd, with T the twist-shaping matrix, and K t = 0 for
the constraint matrix K, so K T = 0. With M = diag(I_i, m_i 1) and W = diag([omega_i]x, 0):

    mass matrix        I = T^T M T
    Coriolis matrix    C = T^T M Tdot + T^T W M T
"""
import numpy as np

from ..joints import PRISMATIC
from ._batch import as_batch, mv, skew, require_chain, unbatch
from .joint import add_rate, world_column, world_column_rate
from .kinematics import body_poses


def _geometry(model, q):
    """Joint-frame poses R0, o; joint axes z_i = R0_i e_z; centers of mass c_i; base frame."""
    R0, o = body_poses(model, q)
    return R0, o, R0[..., 2], o + mv(R0, model.c)


def body_velocities(model, o, z, qd):
    """Angular velocities omega_i and origin velocities odot_i of the bodies, base frame."""
    N, n = qd.shape
    omega, odot = np.zeros((N, n, 3)), np.zeros((N, n, 3))
    zero = np.zeros((N, 3))
    for i in range(n):
        l = model.parent[i]                                   # the parent (the base: at rest)
        w, v, o_prev = (zero, zero, zero) if l < 0 else (omega[:, l], odot[:, l], o[:, l])
        v = v + np.cross(w, o[:, i] - o_prev)                 # transport along the parent
        w, v = add_rate(model.kind[i], w, v, z[:, i], qd[:, i])      # + S_i qd_i
        omega[:, i], odot[:, i] = w, v
    return omega, odot


def _subtree(model, j):
    """The bodies that joint j moves: j and its descendants (a slice for a chain)."""
    if model.is_chain:
        return slice(j, None)
    return [i for i in range(j, model.dof) if j in model.ancestors(i)]


def twist_shaping(model, q):
    """T (N, 6n, n): column j, body i that joint j moves (i >= j in a chain): revolute
    [z_j; z_j x (c_i - o_j)], prismatic [0; z_j]; zero elsewhere."""
    single, (q,) = as_batch(model, ("q", q))
    _, o, z, c = _geometry(model, q)
    return unbatch(single, _T(model, o, z, c))


def _T(model, o, z, c):
    N, n = o.shape[:2]
    T = np.zeros((N, n, 6, n))
    for j in range(n):
        s, Tj = _subtree(model, j), T[..., j]                 # Tj: column j, a view
        Tj[:, s, 3:], Tj[:, s, :3] = world_column(model.kind[j], z[:, None, j], c[:, s] - o[:, None, j])
    return T.reshape(N, 6 * n, n)


def twist_shaping_dot(model, q, qd):
    """dT/dt (N, 6n, n), using zdot_j = omega_j x z_j and the body velocities."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    _, o, z, c = _geometry(model, q)
    omega, odot = body_velocities(model, o, z, qd)
    cdot = odot + np.cross(omega, c - o)
    zdot = np.cross(omega, z)
    N, n = q.shape
    Td = np.zeros((N, n, 6, n))
    for j in range(n):
        s, Tj = _subtree(model, j), Td[..., j]
        Tj[:, s, 3:], Tj[:, s, :3] = world_column_rate(model.kind[j], z[:, None, j], zdot[:, None, j],
                                                       c[:, s] - o[:, None, j], cdot[:, s] - odot[:, None, j])
    return unbatch(single, Td.reshape(N, 6 * n, n))


def _block_diag(blocks):
    """(N, n, 6, 6) -> (N, 6n, 6n) block diagonal."""
    N, n = blocks.shape[:2]
    out = np.zeros((N, n, 6, n, 6))
    idx = np.arange(n)
    out[:, idx, :, idx, :] = np.moveaxis(blocks, 1, 0)
    return out.reshape(N, 6 * n, 6 * n)


def mass_blocks(model, q):
    """Per-body 6x6 blocks diag(I_i, m_i 1) in the base frame, (N, n, 6, 6); I_i about c_i."""
    R0 = body_poses(model, q)[0]
    B = np.zeros(R0.shape[:2] + (6, 6))
    B[..., :3, :3] = R0 @ model.I_c @ np.swapaxes(R0, -1, -2)        # I_i = R0_i I_c R0_i^T
    B[..., 3:, 3:] = model.mass[:, None, None] * np.eye(3)
    return B


def mass_matrix_6n(model, q):
    """M (N, 6n, 6n) = diag(I_i, m_i 1)."""
    single, (q,) = as_batch(model, ("q", q))
    return unbatch(single, _block_diag(mass_blocks(model, q)))


def angular_velocity_matrix_6n(model, q, qd):
    """W (N, 6n, 6n) = diag([omega_i]x, 0)."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    _, o, z, _ = _geometry(model, q)
    omega, _ = body_velocities(model, o, z, qd)
    B = np.zeros(omega.shape[:2] + (6, 6))
    B[..., :3, :3] = skew(omega)
    return unbatch(single, _block_diag(B))


def constraint_matrix(model, q):
    """K (N, 6n, 6n) with K t = 0 for every admissible twist, hence K T = 0.

    Block row i couples bodies i-1 and i at joint i (the base has zero twist):
    revolute   [z]x (omega_i - omega_{i-1}) = 0 and equal velocities of the joint point o_i;
    prismatic  omega_i - omega_{i-1} = 0 and [z]x (velocity difference at o_i) = 0.
    The velocity of point o_i on body k: cdot_k + omega_k x (o_i - c_k) = cdot_k - [o_i - c_k]x omega_k.
    """
    single, (q,) = as_batch(model, ("q", q))
    require_chain(model, "the constraint matrix K")
    _, o, z, c = _geometry(model, q)
    N, n = q.shape
    K = np.zeros((N, n, 6, n, 6))
    eye = np.broadcast_to(np.eye(3), (N, 3, 3))
    for i in range(n):
        Z = skew(z[:, i])
        # point-velocity map of body k at o_i: [ -[o_i - c_k]x , 1 ]
        A_i = np.concatenate([-skew(o[:, i] - c[:, i]), eye], axis=-1)
        A_p = np.concatenate([-skew(o[:, i] - c[:, i - 1]), eye], axis=-1) if i > 0 else None
        if model.kind[i] == PRISMATIC:
            K[:, i, :3, i, :3] = eye
            K[:, i, 3:, i, :] = Z @ A_i
            if i > 0:
                K[:, i, :3, i - 1, :3] = -eye
                K[:, i, 3:, i - 1, :] = -Z @ A_p
        else:
            K[:, i, :3, i, :3] = Z
            K[:, i, 3:, i, :] = A_i
            if i > 0:
                K[:, i, :3, i - 1, :3] = -Z
                K[:, i, 3:, i - 1, :] = -A_p
    return unbatch(single, K.reshape(N, 6 * n, 6 * n))


def coriolis_matrix(model, q, qd):
    """C(q, qd) = T^T M Tdot + T^T W M T, (N, n, n); C qd + g = b and Mdot - 2C is skew."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    N, n = q.shape
    T = twist_shaping(model, q).reshape(N, n, 6, n)
    Td = twist_shaping_dot(model, q, qd).reshape(N, n, 6, n)
    Mb = mass_blocks(model, q)
    _, o, z, _ = _geometry(model, q)
    omega, _ = body_velocities(model, o, z, qd)
    W = np.zeros_like(Mb)
    W[..., :3, :3] = skew(omega)
    # sum over bodies of T_i^T (M_i Tdot_i + W_i M_i T_i): block-diagonal products, body by body
    C = np.einsum("nbkr,nbkl,nblc->nrc", T, Mb, Td) + np.einsum("nbkr,nbkl,nblc->nrc", T, W @ Mb, T)
    return unbatch(single, C)
