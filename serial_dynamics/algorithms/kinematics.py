"""Forward kinematics: body poses, frame poses and Jacobians in the base frame."""
import numpy as np

from ..model import PRISMATIC
from ._batch import as_batch, mv, rotation_about, unbatch


def joint_transforms(model, q):
    """Per-joint (R, p): body i's rotation and origin in body i-1's frame. q: (N, n)."""
    N, n = q.shape
    R = np.empty((N, n, 3, 3))
    p = np.empty((N, n, 3))
    for i in range(n):
        if model.kind[i] == PRISMATIC:   # X = (R0, p0) * (1, a q)
            R[:, i] = model.R_parent[i]
            p[:, i] = model.p_parent[i] + np.outer(q[:, i], model.R_parent[i] @ model.axis[i])
        else:                            # X = (R0, p0) * (Rot(a, q), 0)
            R[:, i] = model.R_parent[i] @ rotation_about(model.axis[i], q[:, i])
            p[:, i] = model.p_parent[i]
    return R, p


def body_poses(model, q):
    """Body rotations (N, k, 3, 3) and origins (N, k, 3) in the base frame of the first k
    bodies; q: (N, k), k <= n (a prefix of the chain)."""
    R, p = joint_transforms(model, q)
    R0, p0 = np.empty_like(R), np.empty_like(p)
    R0[:, 0], p0[:, 0] = R[:, 0], p[:, 0]
    for i in range(1, q.shape[1]):
        R0[:, i] = R0[:, i - 1] @ R[:, i]
        p0[:, i] = p0[:, i - 1] + mv(R0[:, i - 1], p[:, i])
    return R0, p0


def frame_of(model, link):
    """(body, R, p) of a link of the model; ``None`` means the tip frame."""
    if link is None:
        link = model.tip_link
    try:
        return model.frames[link]
    except KeyError:
        raise ValueError(f"link {link!r} is not in the model; known links: "
                         f"{sorted(model.frames)}") from None


def _frame_pose(model, q, link):
    body, Rf, pf = frame_of(model, link)
    N = q.shape[0]
    if body < 0:
        return body, np.broadcast_to(Rf, (N, 3, 3)).copy(), np.broadcast_to(pf, (N, 3)).copy()
    R0, p0 = body_poses(model, q[:, : body + 1])
    return body, R0[:, body] @ Rf, p0[:, body] + mv(R0[:, body], pf)


def forward_kinematics(model, q, link=None):
    """Homogeneous transform(s) of ``link`` (default: the tip) in the base frame."""
    single, (q,) = as_batch(model, ("q", q))
    _, R, p = _frame_pose(model, q, link)
    X = np.zeros((q.shape[0], 4, 4))
    X[:, :3, :3], X[:, :3, 3], X[:, 3, 3] = R, p, 1.0
    return unbatch(single, X)


def jacobian(model, q, link=None):
    """Geometric Jacobian (N, 6, n) of ``link``'s origin, [linear; angular], base frame.

    Column j: revolute  [z_j x (o - o_j); z_j],  prismatic [z_j; 0].
    """
    single, (q,) = as_batch(model, ("q", q))
    body, _, o = _frame_pose(model, q, link)
    N, n = q.shape
    J = np.zeros((N, 6, n))
    if body >= 0:
        R0, p0 = body_poses(model, q[:, : body + 1])
        for j in range(body + 1):
            z = mv(R0[:, j], model.axis[j])
            if model.kind[j] == PRISMATIC:
                J[:, :3, j] = z
            else:
                J[:, :3, j] = np.cross(z, o - p0[:, j])
                J[:, 3:, j] = z
    return unbatch(single, J)
