"""The glue behind ``Robot.frame_acceleration`` (the NumPy backend's; the compiled one is
``core/kinematics.frame_acceleration``), ``operational_space_inertia`` and
``dynamically_consistent_inverse`` for every kind of robot (the algorithms:
``algorithms/task_space.py``).

- A chain (plain, armature, payload, planar): the recursion on the model; base axes.
- Mimic joints: the chain's recursion on every joint's state, q_all = G q + o,
  qd_all = G qd, qdd_all = G qdd, which ``Mimic.frame_acceleration`` gives it: with
  J_r = J_all G, J_r qdd + J-dot_r qd = J_all qdd_all + J-dot_all qd_all.
- A floating base: the recursion starts from the base's motion, v = [v_O; omega] and
  a = dv/dt in the base frame (Pinocchio's free-flyer, whose joint has no bias
  acceleration), so the base origin's classical acceleration is dv_O/dt + omega x v_O; the
  result is turned into world axes, as ``jacobian``.

Lambda and J-bar come from the robot's own ``mass_matrix`` and ``jacobian`` (armature and
payload included; n + 6 columns on a floating base).
"""
from __future__ import annotations

import numpy as np

from ..algorithms import floating as fb
from ..algorithms import task_space
from ..algorithms._batch import mv


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


def _M_J(robot, q, link):
    return robot.mass_matrix(q), robot.jacobian(q, link)


def operational_space_inertia(robot, q, link=None, damping=0.0):
    """Lambda = (J M^-1 J^T + damping^2 1)^-1, 6 x 6 (or (N, 6, 6))."""
    M, J = _M_J(robot, q, link)
    return task_space.operational_space_inertia(M, J, damping,
                                                robot.tip_link if link is None else link)


def dynamically_consistent_inverse(robot, q, link=None, damping=0.0):
    """J-bar = M^-1 J^T Lambda, n x 6 (or (N, n, 6)); Lambda damped as given."""
    M, J = _M_J(robot, q, link)
    Lam = task_space.operational_space_inertia(M, J, damping,
                                               robot.tip_link if link is None else link)
    return task_space.dynamically_consistent_inverse(M, J, Lam)
