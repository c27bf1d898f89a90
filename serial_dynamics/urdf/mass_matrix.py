"""Is a model's mass matrix positive definite? The check of a loaded model that needs the
dynamics algorithms, so it lives above both ``model/`` (which validates the numbers
without them) and ``algorithms/``: ``load_model`` runs it on every model it builds."""
import numpy as np

from ..algorithms._batch import motion_transform, rigid_body_inertia
from ..algorithms.crba import mass_matrix
from ..algorithms.floating import mass_matrix_joints
from ..algorithms.kinematics import joint_transforms
from ..joints import PRISMATIC
from ..model.errors import ModelError


def check_mass_matrix(model) -> None:
    """A joint that moves no mass makes M(q) singular: name it.

    Checked at q = 0 and at two seeded random configurations within the limits. Without
    mimic joints in O(n): the diagonal M_ii = S_i^T IC_i S_i (composite inertias, as the
    CRBA computes it) and the pivots D_i = S_i^T IA_i S_i of the articulated-body
    inertias (Featherstone 2008, Sec. 7.3): M = L^T D L with L unit triangular
    (Sec. 6.5), so M is positive definite exactly when every D_i > 0, and D_i is the
    inertia joint i feels with the joints beyond it free, 0 <= D_i <= M_ii. With mimic
    joints, the same O(n) check of the whole chain's M at q_all = G q + o suffices: M
    positive definite makes G^T M G positive definite, G having full column rank (each
    independent joint's row of G is a unit row). Only where it does not pass (a mimic
    joint that moves no mass of its own) does the dense check of the reduced mass matrix
    G^T M G decide, O(n^2).
    """
    rng = np.random.default_rng(0)
    ind = model.independent
    lo = np.where(np.isfinite(model.lower[ind]), model.lower[ind], -np.pi)
    hi = np.where(np.isfinite(model.upper[ind]), model.upper[ind], np.pi)
    lo, hi = np.clip(lo, -1e6, 1e6), np.clip(hi, -1e6, 1e6)   # hi - lo must not overflow
    qs = np.vstack([np.clip(np.zeros(ind.size), lo, hi), rng.uniform(lo, hi, (2, ind.size))])
    if ind.size < model.dof:
        G, o = model.mimic_matrix
        diag, pivot = _diagonal_and_pivots(model, qs @ G.T + o)
        if np.all(diag > 1e-16 * np.max(np.abs(diag), axis=1, keepdims=True)) \
                and np.all(pivot > PIVOT_RTOL * diag):
            return
        return _check_reduced_mass_matrix(model, qs)
    if model.floating:
        _check_floating_mass_matrix(model, qs)
    if model.dof == 0:                  # a free body: its 6 x 6 block, checked above
        return
    diag, pivot = _diagonal_and_pivots(model, qs)
    for q, M_ii, D in zip(qs, diag, pivot):
        scale = max(np.max(np.abs(M_ii)), 1e-300)
        for i in np.flatnonzero(M_ii <= 1e-16 * scale):      # zero to working precision
            raise ModelError(
                f"joint {model.joint_names[i]!r} moves no mass (its diagonal of the mass "
                f"matrix is {M_ii[i]:.3g} {_at(q)}): the mass matrix is singular. Give the "
                "links it moves an <inertial>, or make it fixed.")
        for i in np.flatnonzero(D <= PIVOT_RTOL * M_ii):
            raise ModelError(
                f"the mass matrix of the {_scope(model)} is "
                f"singular {_at(q)}: joint {model.joint_names[i]!r} moves its bodies only in "
                "ways the joints after it can as well (the inertia it feels with them free "
                f"is {D[i]:.3g}, against {M_ii[i]:.3g} with them locked), so two joints "
                "move the same mass the same way. Check joint axes and link inertias.")

def _check_reduced_mass_matrix(model, qs) -> None:
    """``_check_mass_matrix`` for a chain with mimic joints: G^T M G, dense."""
    G, o = model.mimic_matrix
    names = [model.joint_names[i] for i in model.independent]
    for q in qs:
        M = G.T @ mass_matrix(model, G @ q + o) @ G
        scale = max(np.max(np.abs(np.diag(M))), 1e-300)
        for i in np.flatnonzero(np.diag(M) <= 1e-16 * scale):   # zero to working precision
            raise ModelError(
                f"joint {names[i]!r} moves no mass (its diagonal of the mass "
                f"matrix is {M[i, i]:.3g} {_at(q)}): the mass matrix "
                "is singular. Give the links it moves an <inertial>, or make it fixed.")
        eig = np.linalg.eigvalsh(M)
        if eig[0] <= 1e-15 * eig[-1]:
            raise ModelError(
                f"the mass matrix of the {_scope(model)} is "
                f"singular {_at(q)} (eigenvalues {eig[0]:.3g} .. "
                f"{eig[-1]:.3g}): two joints move the same mass the same way. "
                "Check joint axes and link inertias.")


def _check_floating_mass_matrix(model, qs) -> None:
    """A floating chain moves as a whole: its (n+6) x (n+6) mass matrix must be positive
    definite too (a base and chain with no mass, or no rotational inertia, is refused)."""
    for q in qs:
        eig = np.linalg.eigvalsh(mass_matrix_joints(model, q[None])[0])
        if not eig[0] > 1e-15 * eig[-1]:
            raise ModelError(
                f"the floating {_scope(model)} has a singular "
                f"mass matrix {_at(q)} (eigenvalues {eig[0]:.3g} .. {eig[-1]:.3g}): the base "
                "and the bodies it carries must have mass and rotational inertia about every "
                "axis. Give the base link an <inertial>.")


def _at(q) -> str:
    """Where a mass-matrix check failed, for a message (a long q is summarized)."""
    if q.size <= 12:
        return f"at q = {[float(f'{x:.4g}') for x in q]}"
    return ("at q = 0" if not np.any(q) else
            f"at a seeded random q in the limits ({q.size} joints, |q| <= {np.max(np.abs(q)):.3g})")


# A pivot D_i of the mass matrix at or below PIVOT_RTOL M_ii is zero to working precision:
# D_i = M_ii - (what the joints beyond i take over), a difference of terms of size M_ii that
# round-off leaves at ~1e-16 M_ii (exactly 0, or 1e-16, in chains of 6 to 1,000 joints with
# two coaxial joints). Valid chains are far above it (over every chain of example-robot-data
# the smallest D_i / M_ii is 5e-4; a synthetic chain of 1,000 joints 1.3e-8), and
# D_i / M_ii <= PIVOT_RTOL implies cond(M) >= 1 / PIVOT_RTOL, since D_i >= lambda_min(M) and
# M_ii <= lambda_max(M).
PIVOT_RTOL = 1e-12


def _diagonal_and_pivots(model, qs):
    """(M_ii, D_i), each (N, n), at the configurations ``qs`` (N, n) in one inward pass:
    composite inertias IC_l += X_i^T IC_i X_i (the CRBA's) and articulated inertias
    IA_l += X_i^T (IA_i - U_i U_i^T / D_i) X_i (the ABA's), U_i = IA_i S_i, l = parent[i]."""
    N, n = qs.shape
    X = motion_transform(*joint_transforms(model, qs))              # (N, n, 6, 6)
    Xt = np.swapaxes(X, -1, -2)
    k = np.where(model.kind == PRISMATIC, 5, 2)                      # S_i = e_k
    I = rigid_body_inertia(model.mass, model.h, model.I_O)          # (n, 6, 6)
    diag, pivot = np.empty((N, n)), np.empty((N, n))
    IC = np.repeat(I[None], N, axis=0)
    IA = IC.copy()
    for i in range(n - 1, -1, -1):
        diag[:, i] = IC[:, i, k[i], k[i]] + model.armature[i]
        U = IA[:, i, :, k[i]]
        D = U[:, k[i]] + model.armature[i]
        pivot[:, i] = D
        l = model.parent[i]
        if l >= 0:
            safe = np.where(D > 0, D, np.inf)[:, None, None]         # a zero pivot is refused
            IC[:, l] += Xt[:, i] @ IC[:, i] @ X[:, i]
            IA[:, l] += Xt[:, i] @ (IA[:, i] - U[:, :, None] * U[:, None, :] / safe) @ X[:, i]
    return diag, pivot


def _scope(model):
    """The model in words, for a message: a chain's ends, or a tree's base."""
    if model.is_chain:
        return f"chain {model.base_link!r} -> {model.tip_link!r}"
    return f"tree below {model.base_link!r}"
