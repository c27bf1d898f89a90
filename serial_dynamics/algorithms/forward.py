"""Forward dynamics: qdd = M(q)^-1 (tau - b(q, qd) + J^T w).

Two routes (Angeles, *Fundamentals of Robotic Mechanical Systems*, Sec. 7.7):
- ``"cholesky"``: M by the composite-rigid-body algorithm, b by Newton-Euler at zero
  acceleration, then the Cholesky factor M = L L^T and two triangular solves.
- ``"qr"``: for ill-conditioned chains. With H the block-diagonal square root of the 6n x 6n
  mass matrix (M_6n = H^T H), P = H T gives M = P^T P. The QR factor of P, P = Q R, gives
  M = R^T R without ever forming M, so the condition number is not squared.

Both use the joint frames (see serial_dynamics/model/model.py and docs/conventions.md).
"""
import numpy as np
from scipy.linalg import solve_triangular

from ._batch import as_batch, unbatch
from .crba import mass_matrix
from .kinematics import body_poses
from .noc import twist_shaping
from .rnea import _rnea, _wrench_batch

METHODS = ("cholesky", "qr")


def forward_dynamics(model, q, qd, tau, wrench=None, method="cholesky", gravity=None,
                     base_motion=None):
    """qdd (n,) or (N, n) for applied joint torques ``tau`` (rigid body only, no friction)."""
    single, (q, qd, tau) = as_batch(model, ("q", q), ("qd", qd), ("tau", tau))
    g = model.gravity if gravity is None else np.asarray(gravity, dtype=float)
    rhs = tau - _rnea(model, q, qd, np.zeros_like(q), g, _wrench_batch(wrench, q.shape[0]),
                      base_motion)
    if method == "cholesky":
        L = np.linalg.cholesky(mass_matrix(model, q))                       # M = L L^T
        y = solve_triangular(L, rhs[..., None], lower=True)
        qdd = solve_triangular(np.swapaxes(L, -1, -2), y, lower=False)[..., 0]
    elif method == "qr":
        R = np.linalg.qr(_P(model, q), mode="r")                            # M = R^T R
        y = solve_triangular(np.swapaxes(R, -1, -2), rhs[..., None], lower=True)
        qdd = solve_triangular(R, y, lower=False)[..., 0]
    else:
        raise ValueError(f"forward-dynamics method {method!r} unknown; use one of {METHODS}")
    return unbatch(single, qdd)


def _P(model, q):
    """P = H T, with H_i = diag(sqrt(I_c[i]) R0_i^T, sqrt(m_i) 1), so H_i^T H_i = M_i, the
    body's block of the 6n x 6n mass matrix (``noc.mass_blocks``); the armature adds the
    rows diag(sqrt(I_a)), so that P^T P = T^T M_6n T + diag(I_a)."""
    N, n = q.shape
    w, V = np.linalg.eigh(model.I_c)                                        # joint-frame inertia
    sqrtI = V @ (np.sqrt(np.clip(w, 0, None))[..., None] * np.swapaxes(V, -1, -2))
    R0 = body_poses(model, q)[0]
    T = twist_shaping(model, q).reshape(N, n, 6, n)
    P = np.empty_like(T)
    P[:, :, :3] = sqrtI @ np.swapaxes(R0, -1, -2) @ T[:, :, :3]
    P[:, :, 3:] = np.sqrt(model.mass)[:, None, None] * T[:, :, 3:]
    rotors = np.broadcast_to(np.diag(np.sqrt(model.armature)), (N, n, n))
    return np.concatenate([P.reshape(N, 6 * n, n), rotors], axis=1)
