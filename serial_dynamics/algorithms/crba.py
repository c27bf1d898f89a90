"""Generalized inertia (mass) matrix by the composite-rigid-body algorithm (CRBA).

Featherstone, *Rigid Body Dynamics Algorithms* (2008), Sec. 6.2 and Table 6.2, in joint
frames (see serial_dynamics/model/model.py and docs/conventions.md): the composite inertia IC_i of
bodies i..n-1 is a 6x6 spatial inertia about joint i's origin, in joint frame i, and
S_i = e_z (angular for a revolute joint, linear for a prismatic one).

    IC_i = I_i;   IC_{i-1} += Xup_i^T IC_i Xup_i           (composite bodies, inward)
    F = IC_i S_i;  M_ii = S_i^T F;  F = Xup_j^T F, M_ij = S_j^T F   for j = i-1 .. 0

with Xup_i the motion transform from joint frame i-1 to joint frame i. The armature
(reflected rotor inertia) I_a,i adds to M_ii. A floating root (Featherstone 2008, Ch. 9, the
base as body -1 with a 6-DoF joint) carries the recursion one step further: IC_-1 = I_-1 +
Xup_0^T IC_0 Xup_0 is its block, F_i carried into the base its column (``crba``).
"""
import numpy as np

from ._batch import as_batch, motion_transform, rigid_body_inertia, unbatch
from .joint import motion_subspaces
from .kinematics import joint_transforms


def mass_matrix(model, q):
    """M(q), (n, n) or (N, n, n); symmetric positive definite for a valid model."""
    single, (q,) = as_batch(model, ("q", q))
    return unbatch(single, crba(model, q)[0])


def crba(model, q, I_root=None):
    """(M (N, n, n), IC_-1 (N, 6, 6), F (N, 6, n)) for q (N, n). With ``I_root`` (6, 6), the
    spatial inertia of a floating root (body -1), IC_-1 is the composite inertia of the root
    and every body and F[:, :, i] = Xup_0^T .. Xup_i^T IC_i S_i, joint i's column of the
    root's block rows (both in the base frame, angular first); otherwise both are None.
    A tree: IC_i adds to its parent's, and F climbs the ancestors j = parent[j] (Featherstone
    2008, Table 6.2); M_ij = 0 where neither of i, j is an ancestor of the other."""
    N, n = q.shape
    Xup = motion_transform(*joint_transforms(model, q))            # (N, n, 6, 6)
    S = motion_subspaces(model)                                     # (n, 6)
    IC = np.repeat(rigid_body_inertia(model.mass, model.h, model.I_O)[None], N, axis=0)
    M = np.zeros((N, n, n))
    root = I_root is not None
    IC_root, F_root = (np.repeat(I_root[None], N, axis=0), np.empty((N, 6, n))) if root else (
        None, None)
    for i in range(n - 1, -1, -1):
        l = model.parent[i]
        if l >= 0:                                                  # IC_l += X^T IC_i X
            IC[:, l] += np.swapaxes(Xup[:, i], -1, -2) @ IC[:, i] @ Xup[:, i]
        elif root:                                                  # the root's: IC_-1
            IC_root = IC_root + np.swapaxes(Xup[:, i], -1, -2) @ IC[:, i] @ Xup[:, i]
        F = IC[:, i] @ S[i]                                         # F = IC_i S_i
        M[:, i, i] = F @ S[i]                                       # M_ii = S_i^T F
        j = i
        while model.parent[j] >= 0:
            F = np.einsum("nki,nk->ni", Xup[:, j], F)               # F = Xup_j^T F
            j = model.parent[j]
            M[:, i, j] = M[:, j, i] = F @ S[j]                      # M_ij = S_j^T F
        if root:                                                    # F = Xup_j^T F, the root's
            F_root[:, :, i] = np.einsum("nki,nk->ni", Xup[:, j], F)
    M[:, np.arange(n), np.arange(n)] += model.armature              # M_ii += I_a,i, after the pass
    return M, IC_root, F_root


def ltdl(M, parent):
    """(L, d) with M = L^T diag(d) L for M (n, n) or (N, n, n) whose entry (i, j) is zero
    unless one of i, j is an ancestor of the other in ``parent`` (the branch-induced
    sparsity of a tree's mass matrix). L is unit lower triangular with M's sparsity: no
    fill-in (Featherstone 2005; RBDA 2008, Sec. 6.5, Table 6.3). ``parent`` = i - 1 (a
    chain) factors any symmetric positive-definite M densely."""
    L = np.array(M, dtype=float)
    n = L.shape[-1]
    for k in range(n - 1, -1, -1):
        i = parent[k]
        while i >= 0:
            a = L[..., k, i] / L[..., k, k]                          # L_ki = M_ki / D_k
            j = i
            while j >= 0:                                            # M_ij -= M_kj L_ki
                L[..., i, j] -= L[..., k, j] * a
                j = parent[j]
            L[..., k, i] = a
            i = parent[i]
    d = np.diagonal(L, axis1=-2, axis2=-1).copy()
    L = np.tril(L, -1)
    L[..., np.arange(n), np.arange(n)] = 1.0
    return L, d
