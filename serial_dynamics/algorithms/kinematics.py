"""Forward kinematics: joint transforms, body poses, frame poses and Jacobians.

Bodies are in joint frames (see serial_dynamics/model/model.py and docs/conventions.md); poses of
named links and Jacobians are returned in the base frame and do not depend on that choice.
"""
import numpy as np

from ..model.links import resolve_link
from ._batch import as_batch, mv, unbatch
from .joint import transform, world_column


def joint_transforms(model, q):
    """Body i in its parent body (N, n, 3, 3), (N, n, 3) for q (N, n) (Featherstone Table 4.1)."""
    N, n = q.shape
    R, p = np.empty((N, n, 3, 3)), np.empty((N, n, 3))
    for i in range(n):
        R[:, i], p[:, i] = transform(model.kind[i], model.Xtree_R[i], model.Xtree_p[i], q[:, i])
    return R, p


def body_poses(model, q):
    """Joint frames of the first k bodies in the base frame: R0 (N, k, 3, 3) and origins
    o (N, k, 3); q: (N, k), k <= n (a prefix of the bodies, which holds each one's parents)."""
    R, p = joint_transforms(model, q)
    R0, o = np.empty_like(R), np.empty_like(p)
    for i in range(q.shape[1]):
        l = model.parent[i]
        if l < 0:
            R0[:, i], o[:, i] = R[:, i], p[:, i]
        else:
            R0[:, i] = R0[:, l] @ R[:, i]                # R0_i = R0_l R_i, l = parent[i]
            o[:, i] = o[:, l] + mv(R0[:, l], p[:, i])    # o_i = o_l + R0_l p_i
    return R0, o


def frame_of(model, link):
    """(body, R, p): ``link``'s placement in joint frame ``body`` (-1: base); ``None``: the tip."""
    return model.jframes[resolve_link(model, link)]


def _frame_pose(model, q, link):
    body, Rf, pf = frame_of(model, link)
    N = q.shape[0]
    if body < 0:
        return body, np.broadcast_to(Rf, (N, 3, 3)).copy(), np.broadcast_to(pf, (N, 3)).copy()
    R0, o = body_poses(model, q[:, : body + 1])
    return body, R0[:, body] @ Rf, o[:, body] + mv(R0[:, body], pf)


def forward_kinematics(model, q, link=None):
    """Homogeneous transform(s) of ``link`` (default: the tip) in the base frame."""
    single, (q,) = as_batch(model, ("q", q))
    _, R, p = _frame_pose(model, q, link)
    X = np.zeros((q.shape[0], 4, 4))
    X[:, :3, :3], X[:, :3, 3], X[:, 3, 3] = R, p, 1.0
    return unbatch(single, X)


def jacobian(model, q, link=None):
    """Geometric Jacobian (N, 6, n) of ``link``'s origin, [linear; angular], base frame.

    Column j of a joint between the base and the link (zero for the others), with z_j = R0_j e_z the joint axis: revolute [z_j x (o - o_j); z_j],
    prismatic [z_j; 0].
    """
    single, (q,) = as_batch(model, ("q", q))
    body, _, o = _frame_pose(model, q, link)
    N, n = q.shape
    J = np.zeros((N, 6, n))
    if body >= 0:
        R0, o_j = body_poses(model, q[:, : body + 1])
        for j in model.ancestors(body):                  # the joints that move it
            J[:, :3, j], J[:, 3:, j] = world_column(model.kind[j], R0[:, j, :, 2], o - o_j[:, j])
    return unbatch(single, J)
