"""Inverse dynamics by the recursive Newton-Euler algorithm (RNEA).

Outward recursion for body velocities and accelerations, inward recursion for the
forces between bodies (Angeles, *Fundamentals of Robotic Mechanical Systems*, 4th ed.,
Sec. 7.5; Craig, *Introduction to Robotics*, Sec. 6.5). Vectors of body i are in body
i's frame. Gravity enters as a base acceleration -g (Luh, Walker & Paul, 1980).

Returns what the actuators must supply:  tau = M(q) qdd + b(q, qd) - J^T w.
"""
import numpy as np

from ..model import PRISMATIC
from ._batch import as_batch, mtv, mv, unbatch
from .kinematics import joint_transforms


def inverse_dynamics(model, q, qd, qdd, wrench=None, gravity=None):
    """tau (N, n) or (n,). ``wrench`` (6,) or (N, 6): [f; m] exerted by the environment on
    the tip frame origin, base coordinates. ``gravity``: override of model.gravity."""
    single, (q, qd, qdd) = as_batch(model, ("q", q), ("qd", qd), ("qdd", qdd))
    g = model.gravity if gravity is None else np.asarray(gravity, dtype=float)
    tau = _rnea(model, q, qd, qdd, g, _wrench_batch(wrench, q.shape[0]))
    return unbatch(single, tau)


def _wrench_batch(wrench, N):
    if wrench is None:
        return None
    w = np.asarray(wrench, dtype=float)
    if w.shape not in ((6,), (N, 6)) and not (w.ndim == 2 and w.shape == (1, 6)):
        raise ValueError(f"wrench has shape {w.shape}; expected (6,) or ({N}, 6) "
                         "ordered [fx, fy, fz, mx, my, mz]")
    if not np.all(np.isfinite(w)):
        raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
    return np.broadcast_to(w, (N, 6))


def _rnea(model, q, qd, qdd, g, w):
    N, n = q.shape
    R, p = joint_transforms(model, q)
    a, kind = model.axis, model.kind
    omega = np.zeros((N, 3))          # angular velocity of the previous body
    alpha = np.zeros((N, 3))          # its angular acceleration
    acc = np.broadcast_to(-g, (N, 3))  # linear acceleration of its origin; base: -g
    F = np.empty((N, n, 3))           # net force on body i (Newton)
    Nm = np.empty((N, n, 3))          # net moment about its center of mass (Euler)
    # --- outward recursion: body velocities and accelerations
    for i in range(n):
        # origin acceleration of body i, carried from body i-1: a + alpha x p + w x (w x p)
        acc = mtv(R[:, i], acc + np.cross(alpha, p[:, i]) + np.cross(omega, np.cross(omega, p[:, i])))
        omega, alpha = mtv(R[:, i], omega), mtv(R[:, i], alpha)
        qd_a, qdd_a = qd[:, i, None] * a[i], qdd[:, i, None] * a[i]
        if kind[i] == PRISMATIC:      # relative sliding: Coriolis 2 w x v_rel + a_rel
            acc = acc + 2.0 * np.cross(omega, qd_a) + qdd_a
        else:                         # relative spin: alpha += w x qd a + qdd a
            alpha = alpha + np.cross(omega, qd_a) + qdd_a
            omega = omega + qd_a
        c = model.com[i]
        acc_c = acc + np.cross(alpha, c) + np.cross(omega, np.cross(omega, c))
        I = model.inertia[i]
        F[:, i] = model.mass[i] * acc_c                                    # f = m a_c
        Nm[:, i] = alpha @ I.T + np.cross(omega, omega @ I.T)              # n = I alpha + w x I w
    # --- inward recursion: forces between bodies; tip load -w acts on the environment
    f, m = np.zeros((N, 3)), np.zeros((N, 3))
    if w is not None:
        R_tip = _tip_rotation(R)                 # base <- last body
        f = -mtv(R_tip, w[:, :3])
        m = -mtv(R_tip, w[:, 3:]) + np.cross(model.tip_p, f)   # moment about body origin
    tau = np.empty((N, n))
    for i in range(n - 1, -1, -1):
        if i < n - 1:   # carry the outboard joint's force into body i's frame
            f_out, m_out = mv(R[:, i + 1], f), mv(R[:, i + 1], m)
            m = m_out + np.cross(p[:, i + 1], f_out)
            f = f_out
        f = f + F[:, i]
        m = m + Nm[:, i] + np.cross(model.com[i], F[:, i])
        tau[:, i] = (f if kind[i] == PRISMATIC else m) @ a[i]              # tau_i = a_i . (f|n)_i
    return tau


def _tip_rotation(R):
    R0 = R[:, 0]
    for i in range(1, R.shape[1]):
        R0 = R0 @ R[:, i]
    return R0


def bias_torques(model, q, qd, wrench=None):
    """b(q, qd) - J^T w = inverse_dynamics(q, qd, 0, wrench)."""
    return inverse_dynamics(model, q, qd, None, wrench)


def gravity_torques(model, q):
    """Torques that hold the chain still: inverse_dynamics(q, 0, 0)."""
    return inverse_dynamics(model, q, None, None)
