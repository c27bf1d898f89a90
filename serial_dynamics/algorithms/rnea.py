"""Inverse dynamics by the recursive Newton-Euler algorithm (RNEA), in 3-vectors.

Joint frames (see serial_dynamics/model/model.py and docs/conventions.md): every vector of body i
is in joint frame i, moments about its origin. Outward recursion for the angular velocity
omega, angular acceleration alpha and linear acceleration ``acc`` of the body origin; inward
recursion for the force f and moment n that body i-1 exerts on body i. This is Featherstone,
*Rigid Body Dynamics Algorithms* (2008), Table 5.1, written out in 3-vectors with the
classical acceleration of the origin (Sec. 2.11) in place of the spatial one (Luh, Walker &
Paul 1980). Gravity enters as the base acceleration acc_{-1} = -g (Sec. 5.3); a base with
known motion (``base_motion.BaseMotion``; Angeles, Sec. 7.5.2) starts the outward recursion
with its angular velocity omega_0, angular acceleration alpha_0 and the classical acceleration
of its origin, acc_{-1} = acc_0 - g. The armature I_a (reflected rotor inertia) adds I_a qdd.

Returns what the actuators must supply:  tau = M(q) qdd + b(q, qd) - J^T w.
"""
import numpy as np

from ._batch import as_batch, mtv, mv, unbatch
from .joint import joint_rate, project
from .kinematics import joint_transforms


def inverse_dynamics(model, q, qd, qdd, wrench=None, gravity=None, base_motion=None):
    """tau (N, n) or (n,). ``wrench`` (6,) or (N, 6): [f; m] exerted by the environment on
    the tip frame origin, base coordinates. ``gravity``: override of model.gravity.
    ``base_motion``: a ``BaseMotion`` (base frame), or None for a base at rest."""
    single, (q, qd, qdd) = as_batch(model, ("q", q), ("qd", qd), ("qdd", qdd))
    g = model.gravity if gravity is None else np.asarray(gravity, dtype=float)
    tau = _rnea(model, q, qd, qdd, g, _wrench_batch(wrench, q.shape[0]), base_motion)
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


def _rnea(model, q, qd, qdd, g, w, base=None, root=False):
    """tau (N, n); with ``root``, also (f, n): the force and moment the bodies hanging from
    the base receive from it, in the base frame about its origin (a floating base:
    ``floating.py``). A tree: body i's motion starts from its parent's, l = parent[i], and
    its joint wrench adds to l's (Featherstone 2008, Table 5.1)."""
    N, n = q.shape
    R, p = joint_transforms(model, q)
    omega = np.zeros((N, 3))            # angular velocity of the base
    alpha = np.zeros((N, 3))            # its angular acceleration
    acc = np.broadcast_to(-g, (N, 3))   # linear acceleration of its origin; base: -g
    if base is not None:                # a moving base: omega_0, alpha_0, acc_0 - g
        omega = np.broadcast_to(base.angular_velocity, (N, 3))
        alpha = np.broadcast_to(base.angular_acceleration, (N, 3))
        acc = np.broadcast_to(base.linear_acceleration - g, (N, 3))
    motion = [None] * n                 # omega, alpha, acc of each body
    fB = np.empty((N, n, 3))            # rate of change of momentum of body i: force
    nB = np.empty((N, n, 3))            # and moment about its origin
    # --- outward: velocities and accelerations
    for i in range(n):
        l = model.parent[i]
        m = into_body(R, p, i, *((omega, alpha, acc) if l < 0 else motion[l]))
        motion[i] = joint_rate(model.kind[i], *m, qd[:, i], qdd[:, i])
        fB[:, i], nB[:, i] = body_wrench(model, i, *motion[i])
    # --- inward: joint forces; the tip load -w acts on the environment
    carried = [None] * n                 # what the children (and the tip load) pass to body i
    into_base = None
    if w is not None:                    # -w in joint frame n-1, moment about its origin
        R_tip = _tip_rotation(model, R)  # base <- joint frame n-1
        f = -mtv(R_tip, w[:, :3])
        load = (f, -mtv(R_tip, w[:, 3:]) + np.cross(model.Xtip_p, f))
        if n:
            carried[n - 1] = load
        else:                            # a free body: its tip is on the base
            into_base = load
    tau = np.empty((N, n))
    for i in range(n - 1, -1, -1):
        f, nm = carried[i] or (0.0, 0.0)
        f, nm = f + fB[:, i], nm + nB[:, i]
        tau[:, i] = project(model.kind[i], nm, f)                   # tau_i = S_i^T (n; f)
        f = mv(R[:, i], f)               # into the parent's frame: f' = R f, n' = R n + p x f'
        nm = mv(R[:, i], nm) + np.cross(p[:, i], f)
        l = model.parent[i]
        if l >= 0:
            carried[l] = (f, nm) if carried[l] is None else (carried[l][0] + f, carried[l][1] + nm)
        elif root:
            into_base = (f, nm) if into_base is None else (into_base[0] + f, into_base[1] + nm)
    tau += model.armature * qdd        # + I_a qdd (the rotors' inertia, reflected), after the passes
    if root and into_base is None:     # a free body: nothing hangs from the base
        into_base = (np.zeros((N, 3)), np.zeros((N, 3)))
    return (tau, into_base) if root else tau


def into_body(R, p, i, omega, alpha, acc):
    """Outward recursion: body i-1's (omega, alpha, acc) at body i's origin, in joint frame
    i (acc + alpha x p + omega x (omega x p), then R_i^T)."""
    acc = acc + np.cross(alpha, p[:, i]) + np.cross(omega, np.cross(omega, p[:, i]))
    return mtv(R[:, i], omega), mtv(R[:, i], alpha), mtv(R[:, i], acc)


def body_wrench(model, i, omega, alpha, acc):
    """Newton-Euler about the body origin: (f, n) = (m acc + alpha x h + w x (w x h),
    I_O alpha + w x I_O w + h x acc)."""
    return rigid_wrench(model.mass[i], model.h[i], model.I_O[i], omega, alpha, acc)


def rigid_wrench(m, h, I_O, omega, alpha, acc):
    """``body_wrench`` of a body of mass m, first moment h, inertia I_O about its origin."""
    return (m * acc + np.cross(alpha, h) + np.cross(omega, np.cross(omega, h)),
            alpha @ I_O.T + np.cross(omega, omega @ I_O.T) + np.cross(h, acc))


def _tip_rotation(model, R):
    """R0 of the last joint frame (base <- joint frame n-1) from the joint rotations R."""
    if model.dof == 0:                   # a free body: the tip is on the base
        return np.broadcast_to(np.eye(3), (R.shape[0], 3, 3))
    path = model.ancestors(model.dof - 1)
    R0 = R[:, path[0]]
    for i in path[1:]:
        R0 = R0 @ R[:, i]
    return R0


def bias_torques(model, q, qd, wrench=None, base_motion=None):
    """b(q, qd) - J^T w = inverse_dynamics(q, qd, 0, wrench)."""
    return inverse_dynamics(model, q, qd, None, wrench, base_motion=base_motion)


def gravity_torques(model, q):
    """Torques that hold the chain still: inverse_dynamics(q, 0, 0)."""
    return inverse_dynamics(model, q, None, None)
