"""``Robot.frame_acceleration`` (the NumPy backend's: ``algorithms/task_space.py``; the
compiled one is ``core/kinematics.frame_acceleration``), ``operational_space_inertia`` and
``dynamically_consistent_inverse``, for every kind of robot and both backends.

- A chain (plain, armature, payload, planar): the recursion on the model; base axes.
- Mimic joints: the chain's recursion on every joint's state, q_all = G q + o,
  qd_all = G qd, qdd_all = G qdd, which ``Mimic.frame_acceleration`` gives it: with
  J_r = J_all G, J_r qdd + J-dot_r qd = J_all qdd_all + J-dot_all qd_all.
- A floating base: the recursion starts from the base's motion, v = [v_O; omega] and
  a = dv/dt in the base frame (Pinocchio's free-flyer, whose joint has no bias
  acceleration), so the base origin's classical acceleration is dv_O/dt + omega x v_O; the
  result is turned into world axes, as ``jacobian``.

Lambda and J-bar (Khatib 1987, eqs. 33 and 41) come from the robot's own ``mass_matrix`` and
``jacobian`` (armature and payload included; n + 6 columns on a floating base), solved here
in NumPy: Lambda = (J M^-1 J^T)^-1 and J-bar = M^-1 J^T Lambda. The damped form, for rows
that a configuration (or too few joints) cannot move: Lambda = (J M^-1 J^T + lambda^2 1)^-1,
a damped least-squares inverse (Nakamura and Hanafusa 1986; Wampler 1986), lambda in the
units of Lambda^-1's square root (1/sqrt(kg) for the linear rows).
"""
from __future__ import annotations

import numpy as np

from ..algorithms import floating as fb
from ..algorithms import task_space
from ..algorithms._batch import mv

# an undamped J M^-1 J^T whose reciprocal condition number is below this is refused
SINGULAR_RCOND = 1e-12


def frame_acceleration(robot, q, qd, qdd, link=None):
    """d/dt (J qd) = J qdd + J-dot qd, [linear; angular], as ``robot.jacobian``'s rows."""
    if qdd is None:
        qdd = np.zeros(np.shape(qd))
    if robot.is_floating:
        single, q, R, s = fb.as_batch(robot.model, q, qd=qd, qdd=qdd)
        v, a = s["qd"], s["qdd"]
        w0, v0 = v[:, 3:6], v[:, :3]
        base = (w0, a[:, 3:6], v0, a[:, :3] + np.cross(w0, v0))
        A = task_space.frame_acceleration(robot.model, q[:, 7:], v[:, 6:], a[:, 6:], link, base)
        A = np.concatenate([mv(R, A[:, :3]), mv(R, A[:, 3:])], axis=1)
        return A[0] if single else A
    return task_space.frame_acceleration(robot.model, q, qd, qdd, link)


def operational_space_inertia(robot, q, link=None, damping=0.0):
    """Lambda = (J M^-1 J^T + damping^2 1)^-1, 6 x 6 (or (N, 6, 6))."""
    M, J = robot.mass_matrix(q), robot.jacobian(q, link)
    return _lambda(M, J, damping, robot.tip_link if link is None else link)


def dynamically_consistent_inverse(robot, q, link=None, damping=0.0):
    """J-bar = M^-1 J^T Lambda, n x 6 (or (N, n, 6)); Lambda damped as given."""
    M, J = robot.mass_matrix(q), robot.jacobian(q, link)
    Lam = _lambda(M, J, damping, robot.tip_link if link is None else link)
    return _inverse_mass_jacobian(M, J) @ Lam          # Khatib 1987, eq. 41


def _inverse_mass_jacobian(M, J):
    """M^-1 J^T (..., n, 6) by a Cholesky solve (M is symmetric positive definite)."""
    return _cho_solve(np.linalg.cholesky(M), np.swapaxes(J, -1, -2))


def _cho_solve(L, B):
    """(L L^T)^-1 B over stacks."""
    y = np.linalg.solve(L, B)
    return np.linalg.solve(np.swapaxes(L, -1, -2), y)


def _lambda(M, J, damping, link):
    """Lambda (..., 6, 6) = (J M^-1 J^T + damping^2 1)^-1 (Khatib 1987, eq. 33; damped least
    squares). Undamped, a J M^-1 J^T that is singular (a link that cannot move along some
    row: too few joints, a singular configuration) is refused with a ValueError."""
    damping = float(damping)
    if not np.isfinite(damping) or damping < 0.0:
        raise ValueError(f"damping is {damping}; give a finite number >= 0")
    A = J @ _inverse_mass_jacobian(M, J)
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    if damping > 0.0:
        A = A + damping ** 2 * np.eye(A.shape[-1])
    else:
        s = np.linalg.svd(A, compute_uv=False)
        rcond = s[..., -1] / s[..., 0]
        if np.any(rcond < SINGULAR_RCOND):
            k = int(np.flatnonzero(np.atleast_1d(rcond) < SINGULAR_RCOND)[0])   # the first
            rank = int(np.sum(np.atleast_2d(s)[k] > SINGULAR_RCOND * np.atleast_2d(s)[k, 0]))
            raise ValueError(f"J M^-1 J^T of link {link!r} is singular (rank {rank} of 6"
                             + ("" if np.ndim(rcond) == 0 else f", state {k}") +
                             "): the link cannot accelerate along every task direction (too "
                             "few joints or a singular configuration); pass damping > 0 for "
                             "the damped form (J M^-1 J^T + damping^2 1)^-1")
    L = np.linalg.cholesky(A)
    eye = np.broadcast_to(np.eye(A.shape[-1]), A.shape)
    Lam = _cho_solve(L, eye)
    return 0.5 * (Lam + np.swapaxes(Lam, -1, -2))
