"""Task-space kinematics: the acceleration of a link's frame and J-dot qd (the reference of
``core/kinematics.frame_acceleration``). The operational-space inertia Lambda and the
dynamically consistent inverse J-bar, from any backend's M and J, are ``robot/task_space.py``.

For ``link`` on body b, the classical acceleration of its origin p and
the angular acceleration of its body, in base axes, from the outward recursion over the
joints j on its path from the base (0..b in a chain; b's ancestors in a tree) (point kinematics of rigid bodies; Angeles,
*Fundamentals of Robotic Mechanical Systems*, Sec. 7.3; Siciliano et al. 2009, Sec. 3.1),
with z_j the axis of joint j (fixed in its parent body), r = o_j - o_{j-1} (j-1: the
previous joint on the path):

    omega_j = omega_{j-1} + z_j qd_j                        (revolute)
    alpha_j = alpha_{j-1} + z_j qdd_j + (omega_{j-1} x z_j) qd_j
    a_j     = a_{j-1} + alpha_{j-1} x r + omega_{j-1} x (omega_{j-1} x r)
              [+ z_j qdd_j + 2 (omega_{j-1} x z_j) qd_j      (prismatic)]

and finally a_p = a_b + alpha_b x r + omega_b x (omega_b x r), r = p - o_b. It is
d/dt (J qd) = J qdd + J-dot qd: Pinocchio's getFrameClassicalAcceleration in
LOCAL_WORLD_ALIGNED, expressed in base axes. The base may move (``base``: its angular
velocity and acceleration and its origin's velocity and classical acceleration, base axes):
a floating base starts the recursion there. Gravity plays no part (kinematics only).
"""
import numpy as np

from ._batch import as_batch, mv, unbatch
from .joint import world_joint_rate
from .kinematics import body_poses, frame_of


def frame_acceleration(model, q, qd, qdd, link=None, base=None):
    """(N, 6) or (6,): [classical linear acceleration of ``link``'s origin; angular
    acceleration of its body], base axes (see the module docstring). ``base``: None (the
    base at rest) or (omega, alpha, v, a), each (N, 3), of the base, base axes."""
    single, (q, qd, qdd) = as_batch(model, ("q", q), ("qd", qd), ("qdd", qdd))
    body, _, pf = frame_of(model, link)
    N = q.shape[0]
    w, dw, v, a = (np.zeros((N, 3)) for _ in range(4)) if base is None else \
        (np.array(np.broadcast_to(x, (N, 3)), dtype=float) for x in base)
    o_prev = np.zeros((N, 3))
    p = np.broadcast_to(pf, (N, 3))
    if body >= 0:
        R0, o = body_poses(model, q[:, : body + 1])
        for j in model.ancestors(body):              # the joints from the base to the link
            z, r = R0[:, j, :, 2], o[:, j] - o_prev
            a = a + np.cross(dw, r) + np.cross(w, np.cross(w, r))
            v = v + np.cross(w, r)
            w, dw, v, a = world_joint_rate(model.kind[j], w, dw, v, a, z, qd[:, j], qdd[:, j])
            o_prev = o[:, j]
        p = o[:, body] + mv(R0[:, body], pf)
    r = p - o_prev
    a = a + np.cross(dw, r) + np.cross(w, np.cross(w, r))
    return unbatch(single, np.concatenate([a, dw], axis=1))

