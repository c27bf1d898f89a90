"""Kinetic and potential energy of the chain (joint frames; see serial_dynamics/model.py and
docs/conventions.md)."""
import numpy as np

from ._batch import as_batch, mv, unbatch
from .crba import mass_matrix
from .kinematics import body_poses


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
