"""Kinetic and potential energy of the chain, its center of mass and centroidal momentum
(joint frames; see serial_dynamics/model/model.py and docs/conventions.md)."""
import numpy as np

from ._batch import as_batch, mtv, mv, unbatch
from .crba import mass_matrix
from .kinematics import body_poses, joint_transforms
from .noc import body_velocities
from .joint import E_Z, add_rate, project


def kinetic_energy(model, q, qd):
    """T = 1/2 qd^T M(q) qd (J)."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    return unbatch(single, 0.5 * np.einsum("ni,nij,nj->n", qd, mass_matrix(model, q), qd))


def potential_energy(model, q):
    """V = -sum_i m_i g . c_i (J), zero with every center of mass at the base origin."""
    single, (q,) = as_batch(model, ("q", q))
    R0, o = body_poses(model, q)
    c = o + mv(R0, model.c)                                  # c_i = o_i + R0_i c[i]
    return unbatch(single, -np.einsum("i,nik,k->n", model.mass, c, model.gravity))


def center_of_mass(model, q):
    """c (3,) or (N, 3): the center of mass of the moving bodies, base frame (a fixed
    base's own link is not part of the model)."""
    single, (q,) = as_batch(model, ("q", q))
    R0, o = body_poses(model, q)
    return unbatch(single, np.einsum("i,nik->nk", model.mass, o + mv(R0, model.c))
                   / model.mass.sum())                       # sum m_i c_i / m


def centroidal_momentum(model, q, qd):
    """h (6,) or (N, 6): [linear momentum; angular momentum about the center of mass] of
    the moving bodies, base axes: P = sum m_i cdot_i, L = sum I_i omega_i + m_i (c_i - c) x
    cdot_i (Orin, Goswami & Lee 2013, "Centroidal dynamics of a humanoid robot")."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    R0, o = body_poses(model, q)
    c = o + mv(R0, model.c)                                  # c_i
    omega, odot = body_velocities(model, o, R0[..., 2], qd)
    cdot = odot + np.cross(omega, c - o)                     # velocity of c_i
    m = model.mass[:, None]
    P = np.sum(m * cdot, axis=1)
    r = c - (np.sum(m * c, axis=1) / model.mass.sum())[:, None]
    I = R0 @ model.I_c @ np.swapaxes(R0, -1, -2)             # about c_i, base axes
    L = np.sum(mv(I, omega) + m * np.cross(r, cdot), axis=1)
    return unbatch(single, np.concatenate([P, L], axis=1))


def kinetic_energy_gradient(model, q, qd):
    """dT/dq at fixed qd (N m), T = 1/2 qd^T M(q) qd; equal to C(q, qd)^T qd.

    O(n), from the spatial velocities V_i = (omega_i; v_i) of the bodies (v_i: velocity of
    body i's origin) and their momenta h_i = I_i V_i about their origins. In a common
    (base) frame the joint axes beyond joint k and the bodies' inertias turn with it:
    dV_i/dq_k = S_k x (V_i - V_k) and dI_i/dq_k = S_k x* I_i - I_i S_k x for k <= i, so
    dT/dq_k = sum_{i >= k} h_i . (V_k x S_k) = -S_k . (V_k x* H_k), with H_k = sum_{i >= k}
    h_i the momentum of bodies k.. (on a tree: k and the bodies below it), carried inward
    like the joint forces of Newton-Euler
    (x, x*: the spatial cross products of motions and forces; Featherstone 2008, Sec. 2.9;
    f . (S x u) = S . (u x* f))."""
    single, (q, qd) = as_batch(model, ("q", q), ("qd", qd))
    N, n = q.shape
    R, p = joint_transforms(model, q)
    zero = np.zeros((N, 3))
    W, U = np.empty((N, n, 3)), np.empty((N, n, 3))          # omega_i, v_i (frame i)
    hn, hf = np.empty((N, n, 3)), np.empty((N, n, 3))        # h_i: angular, linear momentum
    for i in range(n):
        # the parent's velocity at body i's origin, in frame i; then the joint's rate
        l = model.parent[i]
        omega, v = (zero, zero) if l < 0 else (W[:, l], U[:, l])
        v = mtv(R[:, i], v + np.cross(omega, p[:, i]))
        omega = mtv(R[:, i], omega)
        omega, v = add_rate(model.kind[i], omega, v, E_Z, qd[:, i])       # + S_i qd_i
        m, h, I_O = model.mass[i], model.h[i], model.I_O[i]
        hf[:, i] = m * v + np.cross(omega, h)                # momentum, linear
        hn[:, i] = omega @ I_O.T + np.cross(h, v)            # angular, about the origin
        W[:, i], U[:, i] = omega, v
    carried = [None] * n                                     # H of the bodies below, carried in
    grad = np.empty((N, n))
    for k in range(n - 1, -1, -1):
        Hn, Hf = carried[k] or (0.0, 0.0)
        Hn, Hf = Hn + hn[:, k], Hf + hf[:, k]                # H_k: bodies k and below
        # -V_k x* H_k = -(omega x Hn + v x Hf; omega x Hf), projected on the joint axis S_k
        yn = -np.cross(W[:, k], Hn) - np.cross(U[:, k], Hf)
        yf = -np.cross(W[:, k], Hf)
        grad[:, k] = project(model.kind[k], yn, yf)
        l = model.parent[k]
        if l >= 0:         # H_k into the parent's frame: f' = R f, n' = R n + p x f'
            Hf = mv(R[:, k], Hf)
            Hn = mv(R[:, k], Hn) + np.cross(p[:, k], Hf)
            carried[l] = (Hn, Hf) if carried[l] is None else (carried[l][0] + Hn, carried[l][1] + Hf)
    return unbatch(single, grad)
