"""Generalized inertia (mass) matrix by the composite-rigid-body algorithm (CRBA).

Column j of M is the joint-torque vector that accelerates joint j at unit rate from
rest with no gravity. Bodies j..n-1 then move as one composite body (Walker & Orin,
1982; Featherstone, *Rigid Body Dynamics Algorithms*, Ch. 6). Quantities in the base
frame; moments about the base origin.
"""
import numpy as np

from ..model import PRISMATIC
from ._batch import as_batch, mv, skew, unbatch
from .kinematics import body_poses


def mass_matrix(model, q):
    """M(q), (n, n) or (N, n, n); symmetric positive definite for a valid model."""
    single, (q,) = as_batch(model, ("q", q))
    N, n = q.shape
    R0, o = body_poses(model, q)
    z = mv(R0, model.axis)                                   # joint axes, base frame
    c = o + mv(R0, model.com)                                # centers of mass
    Ic = R0 @ model.inertia @ np.swapaxes(R0, -1, -2)        # inertia about c, base axes
    Cx = skew(c)
    # per body: mass m, first moment h = m c, inertia about the base origin m [c]x^T[c]x + Ic
    m_b = np.broadcast_to(model.mass, (N, n))
    h_b = model.mass[:, None] * c
    J_b = Ic + model.mass[:, None, None] * np.swapaxes(Cx, -1, -2) @ Cx
    M = np.empty((N, n, n))
    m_C, h_C, J_C = np.zeros(N), np.zeros((N, 3)), np.zeros((N, 3, 3))
    for j in range(n - 1, -1, -1):                           # composite body j..n-1
        m_C, h_C, J_C = m_C + m_b[:, j], h_C + h_b[:, j], J_C + J_b[:, j]
        zj = z[:, j]
        if model.kind[j] == PRISMATIC:                       # unit slide: v = z everywhere
            F = m_C[:, None] * zj
            N0 = np.cross(h_C, zj)
        else:                                                # unit spin about (o_j, z_j)
            F = np.cross(zj, h_C - m_C[:, None] * o[:, j])   # F = z x (h - m o_j)
            N0 = mv(J_C, zj) - np.cross(h_C, np.cross(zj, o[:, j]))  # dL/dt about base origin
        for i in range(j + 1):                               # torque at joint i <= j
            if model.kind[i] == PRISMATIC:
                M[:, i, j] = np.einsum("nk,nk->n", z[:, i], F)
            else:
                M[:, i, j] = np.einsum("nk,nk->n", z[:, i], N0 - np.cross(o[:, i], F))
            M[:, j, i] = M[:, i, j]
    return unbatch(single, M)
