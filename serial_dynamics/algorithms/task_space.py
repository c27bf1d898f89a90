"""Task-space dynamics: the acceleration of a link's frame, J-dot qd, the operational-space
inertia Lambda and the dynamically consistent inverse J-bar.

Frame acceleration. For ``link`` on body b, the classical acceleration of its origin p and
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

Lambda and J-bar (Khatib 1987, eqs. 33 and 41): Lambda = (J M^-1 J^T)^-1 and
J-bar = M^-1 J^T Lambda. The damped form, for rows that a configuration (or too few
joints) cannot move: Lambda = (J M^-1 J^T + lambda^2 1)^-1, a damped least-squares
inverse (Nakamura and Hanafusa 1986; Wampler 1986), lambda in the units of Lambda^-1's
square root (1/sqrt(kg) for the linear rows).
"""
import numpy as np

from ._batch import as_batch, mv, unbatch
from .joint import world_joint_rate
from .kinematics import body_poses, frame_of

# an undamped J M^-1 J^T whose reciprocal condition number is below this is refused
SINGULAR_RCOND = 1e-12


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


def inverse_mass_jacobian(M, J):
    """M^-1 J^T (..., n, 6) by a Cholesky solve (M is symmetric positive definite)."""
    L = np.linalg.cholesky(M)
    Jt = np.swapaxes(J, -1, -2)
    return _cho_solve(L, Jt)


def _cho_solve(L, B):
    """(L L^T)^-1 B over stacks."""
    y = np.linalg.solve(L, B)
    return np.linalg.solve(np.swapaxes(L, -1, -2), y)


def operational_space_inertia(M, J, damping=0.0, link="tip"):
    """Lambda (..., 6, 6) = (J M^-1 J^T + damping^2 1)^-1 (Khatib 1987, eq. 33; damped least
    squares). Undamped, a J M^-1 J^T that is singular (a link that cannot move along some
    row: too few joints, a singular configuration) is refused with a ValueError."""
    damping = float(damping)
    if not np.isfinite(damping) or damping < 0.0:
        raise ValueError(f"damping is {damping}; give a finite number >= 0")
    A = J @ inverse_mass_jacobian(M, J)
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


def dynamically_consistent_inverse(M, J, Lambda):
    """J-bar (..., n, 6) = M^-1 J^T Lambda (Khatib 1987, eq. 41)."""
    return inverse_mass_jacobian(M, J) @ Lambda
