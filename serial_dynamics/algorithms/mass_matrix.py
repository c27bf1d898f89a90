"""Generalized inertia (mass) matrix by the composite-rigid-body algorithm (CRBA).

Column j of M is the joint-torque vector that accelerates joint j at unit rate from
rest with no gravity. Bodies j..n-1 then move as one composite body (Walker & Orin,
1982; Featherstone, *Rigid Body Dynamics Algorithms*, Ch. 6). Vectors in the base
frame; the composite's first moment and inertia are kept about joint j's origin o_j
(not the base origin), so light distal links do not cancel against heavy proximal ones.
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
    M = np.empty((N, n, n))
    m_C, h_C, J_C = 0.0, np.zeros((N, 3)), np.zeros((N, 3, 3))   # about o_{j+1}
    for j in range(n - 1, -1, -1):                           # composite body j..n-1, about o_j
        if j < n - 1:   # shift the point from o_{j+1} to o_j by d: parallel-axis theorem
            D, H = skew(o[:, j + 1] - o[:, j]), skew(h_C)
            DT = np.swapaxes(D, -1, -2)
            J_C = J_C + DT @ H + np.swapaxes(H, -1, -2) @ D + m_C * DT @ D
            h_C = h_C + m_C * (o[:, j + 1] - o[:, j])
        r = skew(c[:, j] - o[:, j])                          # add body j
        m_C = m_C + model.mass[j]
        h_C = h_C + model.mass[j] * (c[:, j] - o[:, j])
        J_C = J_C + Ic[:, j] + model.mass[j] * np.swapaxes(r, -1, -2) @ r
        zj = z[:, j]
        if model.kind[j] == PRISMATIC:                       # unit slide: v = z everywhere
            F, N_j = m_C * zj, np.cross(h_C, zj)
        else:                                                # unit spin about (o_j, z_j)
            F, N_j = np.cross(zj, h_C), mv(J_C, zj)          # f = z x h, n_o = J z
        for i in range(j + 1):                               # torque at joint i <= j
            if model.kind[i] == PRISMATIC:
                M[:, i, j] = np.einsum("nk,nk->n", z[:, i], F)
            else:                                            # moment about o_i
                M[:, i, j] = np.einsum("nk,nk->n", z[:, i], N_j + np.cross(o[:, j] - o[:, i], F))
            M[:, j, i] = M[:, i, j]
    return unbatch(single, M)
