"""A free-floating base: the chain on a body with six degrees of freedom (NumPy reference).

Coordinates (Pinocchio's free-flyer; docs/modelling.md): q = [x, y, z, qx, qy, qz, qw,
joints] (nq = n + 7), the base origin in the world and the base orientation as a unit
quaternion; v = [v_O; omega; qd] (nv = n + 6), the base origin's velocity and the base's
angular velocity, both in the base frame, then the joint rates; a = dv/dt (the base part
is the base's spatial acceleration in its own frame). Generalized forces tau = [f; n;
joint torques]: the force and moment on the base about its origin, base frame.

The algorithms are those of the fixed base with the base as body -1, a 6-DoF root
(Featherstone, *Rigid Body Dynamics Algorithms*, 2008, Ch. 9, floating bases; Angeles,
*Fundamentals of Robotic Mechanical Systems*, Sec. 7.5.2): Newton-Euler started from the
base's motion (``rnea._rnea``), composite bodies carried into the root (``crba.crba``),
articulated bodies through the root (``aba._aba``, FDfb). Internally spatial vectors are
angular first (docs/conventions.md); ``_v`` and ``_f`` reorder at the boundary. Gravity
``model.gravity`` is in the world frame and enters as the base acceleration -R^T g.
The tip ``wrench`` [f; m] acts on the tip frame origin, in WORLD coordinates.
"""
from types import SimpleNamespace

import numpy as np
from scipy.linalg import solve_triangular

from ._batch import mv, rigid_body_inertia, skew, unbatch
from .aba import _aba
from .crba import crba
from .kinematics import body_poses
from .noc import _T, _geometry, body_velocities, twist_shaping_dot
from .rnea import _rnea, _wrench_batch, rigid_wrench

LIN, ANG = slice(0, 3), slice(3, 6)       # the base's parts of v and tau (linear first)


# ------------------------------------------------------------------ states
def as_batch(model, q=None, rotation=True, **named):
    """(single, q, R, arrays): q (N, n+7) with a unit quaternion, R (N, 3, 3) the base's
    rotation (world <- base; None with ``rotation=False``), and each named state (N, n+6)
    (``tau`` may be (N, n): joint torques on a free base). ValueError naming the argument
    and the fix on a bad shape, a NaN/Inf or a quaternion of zero length."""
    n = model.dof
    single, out, N = True, {}, 1
    for name, x, width in [("q", q, n + 7)] + [(k, x, n + 6) for k, x in named.items()]:
        if x is None:
            out[name] = None
            continue
        a = np.asarray(x, dtype=float)
        if name == "tau" and a.shape[-1:] == (n,):             # joint torques: the base is free
            a = np.concatenate([np.zeros(a.shape[:-1] + (6,)), a], axis=-1)
        if a.ndim not in (1, 2) or a.shape[-1] != width:
            what = ("[x, y, z, qx, qy, qz, qw] and" if name == "q" else "[v_O (3), omega (3)] and")
            raise ValueError(f"{name} has shape {a.shape}; expected ({width},) or (N, {width}) for "
                             f"a floating base: {what} the {n} joints {list(model.joint_names)}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} has a NaN or Inf entry; states must be finite numbers")
        single = single and a.ndim == 1
        a = np.atleast_2d(a)
        N = max(N, a.shape[0])
        out[name] = a
    sizes = {a.shape[0] for a in out.values() if a is not None} - {1}
    if len(sizes) > 1:
        raise ValueError(f"batch sizes differ: {sorted(sizes)}; give states with the same N")
    out = {k: None if a is None else np.broadcast_to(a, (N, a.shape[1])) for k, a in out.items()}
    q = out.pop("q")
    if q is None:
        return single, None, None, out
    quat = q[:, 3:7]
    norm = np.linalg.norm(quat, axis=1)
    if np.any(norm < 1e-12):
        raise ValueError(f"q's quaternion (qx, qy, qz, qw) = {quat[np.argmin(norm)].tolist()} has "
                         "zero length; give the base's orientation as a unit quaternion, "
                         "e.g. [0, 0, 0, 1] for none")
    if not rotation:                                      # (the compiled kernels normalize)
        return single, q, None, out
    q = q.copy()
    q[:, 3:7] = quat / norm[:, None]                      # any length: the rotation it means
    return single, q, quaternion_matrix(q[:, 3:7]), out


def quaternion_matrix(quat):
    """R (N, 3, 3) of unit quaternions (N, 4) [x, y, z, w] (Hamilton; ROS order). One
    quaternion in Python floats: the same IEEE operations, so the same bits, without the
    cost of 30 operations on arrays of one element."""
    if quat.shape[0] == 1:
        x, y, z, w = quat[0].tolist()
        return np.array([[[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]])
    x, y, z, w = quat.T
    R = np.empty((quat.shape[0], 3, 3))
    R[:, 0] = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1)
    R[:, 1] = np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1)
    R[:, 2] = np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)
    return R


def _v(x):
    """[linear; angular] (Pinocchio) <-> [angular; linear] (Featherstone), last axis."""
    return np.concatenate([x[..., 3:6], x[..., 0:3]], axis=-1)


def base_inertia(model):
    """The base's 6x6 spatial inertia about its origin, angular first (eq. 2.63)."""
    return rigid_body_inertia(model.base_mass, model.base_h, model.base_I_O)


# ------------------------------------------------------------------ dynamics
def inverse_dynamics(model, q, v, a, wrench=None, gravity=None):
    """tau (N, n+6) or (n+6,): [base force; base moment] (base frame, about its origin) and
    the joint torques that give the accelerations ``a``; ``wrench`` (6,) or (N, 6) on the tip,
    world coordinates."""
    single, q, R, s = as_batch(model, q, v=v, a=a)
    N = q.shape[0]
    v = np.zeros((N, model.dof + 6)) if s["v"] is None else s["v"]
    a = np.zeros((N, model.dof + 6)) if s["a"] is None else s["a"]
    return unbatch(single, _rnea_fb(model, R, q, v, a, wrench, gravity))


def _rnea_fb(model, R, q, v, a, wrench, gravity):
    g = np.einsum("nji,j->ni", R, model.gravity if gravity is None else np.asarray(gravity, float))
    omega, alpha = v[:, 3:6], a[:, 3:6]
    acc = a[:, 0:3] + np.cross(omega, v[:, 0:3])    # classical from spatial (Featherstone 2.11)
    base = SimpleNamespace(angular_velocity=omega, angular_acceleration=alpha,
                           linear_acceleration=acc)
    w = _wrench_batch(wrench, q.shape[0])
    if w is not None:                               # world -> base coordinates
        w = np.concatenate([np.einsum("nji,nj->ni", R, w[:, :3]),
                            np.einsum("nji,nj->ni", R, w[:, 3:])], axis=1)
    tau, (f, n) = _rnea(model, q[:, 7:], v[:, 6:], a[:, 6:], g, w, base, root=True)
    f0, n0 = rigid_wrench(model.base_mass, model.base_h, model.base_I_O, omega, alpha, acc - g)
    return np.concatenate([f + f0, n + n0, tau], axis=1)


def mass_matrix(model, q):
    """M (n+6, n+6) or (N, n+6, n+6), in the order of v; it does not depend on the base pose."""
    single, q, _, _ = as_batch(model, q)
    return unbatch(single, mass_matrix_joints(model, q[:, 7:]))


def mass_matrix_joints(model, qj):
    """M (N, n+6, n+6) for joint positions qj (N, n): CRBA with a floating root."""
    N, n = qj.shape
    M_j, IC, F = crba(model, qj, base_inertia(model))
    M = np.empty((N, n + 6, n + 6))
    M[:, :6, :6] = _v(np.swapaxes(_v(IC), -1, -2))        # IC_-1, reordered both ways
    M[:, :6, 6:] = _v(np.swapaxes(F, -1, -2)).swapaxes(-1, -2)
    M[:, 6:, :6] = np.swapaxes(M[:, :6, 6:], -1, -2)
    M[:, 6:, 6:] = M_j
    return M


def bias(model, q, v, wrench=None):
    """b (n+6,) = inverse_dynamics(q, v, 0, wrench): Coriolis, centrifugal and gravity."""
    return inverse_dynamics(model, q, v, None, wrench)


def gravity_forces(model, q):
    """g (n+6,): the generalized forces that hold the whole robot still in gravity."""
    return inverse_dynamics(model, q, None, None)


def forward_dynamics(model, q, v, tau, wrench=None, method="aba"):
    """a (n+6,) or (N, n+6) for ``tau`` (n,) joint torques (the base is free) or (n+6,);
    ``method``: "aba" (articulated bodies through the floating root, FDfb) or "cholesky"
    (M a = tau - b, M = L L^T)."""
    single, q, R, s = as_batch(model, q, v=v, tau=tau)
    N = q.shape[0]
    v, tau = s["v"], s["tau"]
    if method == "cholesky":
        rhs = tau - _rnea_fb(model, R, q, v, np.zeros_like(v), wrench, None)
        L = np.linalg.cholesky(mass_matrix_joints(model, q[:, 7:]))
        y = solve_triangular(L, rhs[..., None], lower=True)
        return unbatch(single, solve_triangular(np.swapaxes(L, -1, -2), y, lower=False)[..., 0])
    if method != "aba":
        raise ValueError(f"floating-base forward-dynamics method {method!r} unknown; use "
                         "'aba' or 'cholesky'")
    g_b = np.einsum("nji,j->ni", R, model.gravity)
    w = _wrench_batch(wrench, N)
    if w is not None:                                     # world -> base coordinates
        w = np.concatenate([np.einsum("nji,nj->ni", R, w[:, :3]),
                            np.einsum("nji,nj->ni", R, w[:, 3:])], axis=1)
    qdd, a0 = _aba(model, q[:, 7:], v[:, 6:], tau[:, 6:], g_b, w,
                   root=(base_inertia(model), _v(v[:, :6]), _v(tau[:, :6])))
    a0 = a0 + np.concatenate([np.zeros((N, 3)), g_b], axis=1)     # a_-1 = a'_-1 + (0, g)
    return unbatch(single, np.concatenate([_v(a0), qdd], axis=1))


# ------------------------------------------------------------------ kinematics, momentum
def body_frames(model, q, R):
    """Poses of the base and the joint frames in the world: (R_w (N, n, 3, 3), o_w (N, n, 3))."""
    R0, o = body_poses(model, q[:, 7:])
    return R[:, None] @ R0, q[:, None, :3] + np.einsum("nij,nkj->nki", R, o)


def center_of_mass(model, q):
    """c (3,) or (N, 3): the center of mass of the base and the chain, world frame."""
    single, q, R, _ = as_batch(model, q)
    return unbatch(single, _com(model, q, R))


def _com(model, q, R):
    R0, o = body_poses(model, q[:, 7:])
    c = model.base_h + np.einsum("i,nik->nk", model.mass, o + mv(R0, model.c))   # sum m c
    return q[:, :3] + mv(R, c / (model.base_mass + model.mass.sum()))


def centroidal_momentum(model, q, v):
    """h (6,) or (N, 6): [linear momentum; angular momentum about the center of mass],
    world axes. The base rows of M v are the momentum about the base origin in the base
    frame (the base's columns of every body's Jacobian are the same rigid motion)."""
    single, q, R, s = as_batch(model, q, v=v)
    hb = np.einsum("nij,nj->ni", mass_matrix_joints(model, q[:, 7:])[:, :6], s["v"])
    P, L = mv(R, hb[:, :3]), mv(R, hb[:, 3:])             # world axes, about the base origin
    r = _com(model, q, R) - q[:, :3]                      # base origin -> center of mass
    return unbatch(single, np.concatenate([P, L - np.cross(r, P)], axis=1))


def kinetic_energy(model, q, v):
    """T = 1/2 v^T M v (J)."""
    single, q, _, s = as_batch(model, q, v=v)
    M = mass_matrix_joints(model, q[:, 7:])
    return unbatch(single, 0.5 * np.einsum("ni,nij,nj->n", s["v"], M, s["v"]))


def potential_energy(model, q):
    """V = -m_total g . c (J), zero with the center of mass at the world origin."""
    single, q, R, _ = as_batch(model, q)
    m = model.base_mass + model.mass.sum()
    return unbatch(single, -m * _com(model, q, R) @ model.gravity)


# ------------------------------------------------------------------ SE(3)
def integrate(model, q, v, dt):
    """q (+) v dt: the base moved by the exponential map of its body twist v_b dt on SE(3)
    (Murray, Li & Sastry 1994, eq. 2.36: R_new = R exp([w dt]x), p_new = p + R V(w dt) v dt),
    the quaternion multiplied by that of the turn, the joints by qd dt."""
    single, q, R, s = as_batch(model, q, v=v)
    dt = np.asarray(dt, dtype=float).reshape(-1, 1)
    u, w = s["v"][:, :3] * dt, s["v"][:, 3:6] * dt        # the step's body twist
    th = np.linalg.norm(w, axis=1)[:, None]
    small = th < 1e-6                                      # Taylor series below (error < 1e-18)
    ths = np.where(small, 1.0, th)
    B = np.where(small, 0.5 - th**2 / 24, (1 - np.cos(ths)) / ths**2)           # (1 - cos t)/t^2
    C = np.where(small, 1 / 6 - th**2 / 120, (ths - np.sin(ths)) / ths**3)      # (t - sin t)/t^3
    W = skew(w)
    V = np.eye(3) + B[..., None] * W + C[..., None] * (W @ W)
    out = q.copy()
    out[:, :3] = q[:, :3] + mv(R, mv(V, u))
    half = 0.5 * th
    dq = np.concatenate([w * np.where(small, 0.5 - th**2 / 48, np.sin(half) / ths), np.cos(half)],
                        axis=1)                           # the turn's quaternion [x, y, z, w]
    out[:, 3:7] = _normalized(quaternion_product(q[:, 3:7], dq))
    out[:, 7:] = q[:, 7:] + s["v"][:, 6:] * dt
    return unbatch(single, out)


def quaternion_product(a, b):
    """a b, quaternions (N, 4) [x, y, z, w] (Hamilton)."""
    av, aw, bv, bw = a[:, :3], a[:, 3:], b[:, :3], b[:, 3:]
    return np.concatenate([aw * bv + bw * av + np.cross(av, bv),
                           aw * bw - np.sum(av * bv, axis=1, keepdims=True)], axis=1)


def _normalized(quat):
    return quat / np.linalg.norm(quat, axis=1, keepdims=True)


def random_state(model, rng=None, batch=None, speed=1.0, reach=1.0):
    """(q, v): the base within +-reach (m) of the origin, a uniformly random unit quaternion
    (a normalized Gaussian 4-vector), joints within their limits (+-pi where unlimited),
    every velocity in +-speed."""
    rng = np.random.default_rng(rng)
    N = 1 if batch is None else batch
    lo = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, np.pi)
    q = np.concatenate([rng.uniform(-reach, reach, (N, 3)), _normalized(rng.normal(size=(N, 4))),
                        rng.uniform(lo, hi, (N, model.dof))], axis=1)
    v = rng.uniform(-speed, speed, (N, model.dof + 6))
    return (q[0], v[0]) if batch is None else (q, v)


# ------------------------------------------------------------------ natural orthogonal complement
def twist_shaping(model, q):
    """T (N, 6(n+1), n+6): the twists t_i = [omega_i; cdot_i] of the base (i = 0) and the
    bodies, base axes, from the textbook's generalized speeds [omega_0; cdot_0; qd] (Angeles
    eq. 7.87-7.89): the 6x6 identity block for the base, t_i = [omega_0; cdot_0 + omega_0 x
    (c_i - c_0)] + (the fixed-base columns) for body i."""
    single, q, _, _ = as_batch(model, q)
    N, n = q.shape[0], model.dof
    _, o, z, c = _geometry(model, q[:, 7:])
    T = np.zeros((N, n + 1, 6, n + 6))
    T[:, :, :3, :3] = np.eye(3)
    T[:, :, 3:, 3:6] = np.eye(3)
    T[:, 1:, 3:, :3] = -skew(c - model.base_com)              # cdot_i += omega_0 x (c_i - c_0)
    T[:, 1:, :, 6:] = _T(model, o, z, c).reshape(N, n, 6, n)
    return unbatch(single, T.reshape(N, 6 * (n + 1), n + 6))


def coriolis_matrix(model, q, v):
    """C (n+6, n+6) or (N, ...) with C v = b(q, v) - g(q) and dM/dt - 2 C skew-symmetric:
    C = T^T M_b (dT/dt) + T^T W M_b T (Angeles & Lee 1988, the NOC; ``noc.py``) with T the
    twists of the base and the bodies from v (``twist_shaping`` times ``speeds_from_v``) in
    an inertial frame that coincides with the base frame at this instant: dT/dt is the
    joints' rate of change of T in base axes plus the turn of those axes, omega x T; W holds
    [omega_i]x of each body's absolute angular velocity."""
    single, q, _, s = as_batch(model, q, v=v)
    N, n = q.shape[0], model.dof
    v = np.zeros((N, n + 6)) if s["v"] is None else s["v"]
    S = speeds_from_v(model)
    T = twist_shaping(model, q).reshape(N, n + 1, 6, n + 6) @ S
    _, o, z, c = _geometry(model, q[:, 7:])
    w_rel, o_rel = body_velocities(model, o, z, v[:, 6:])      # the joints' part, base axes
    Td = np.zeros((N, n + 1, 6, n + 6))                         # dT/dt in base axes
    Td[:, 1:, 3:, :3] = -skew(o_rel + np.cross(w_rel, c - o))   # d/dt -[c_i - c_0]x
    Td[:, 1:, :, 6:] = twist_shaping_dot(model, q[:, 7:], v[:, 6:]).reshape(N, n, 6, n)
    Td = Td @ S
    wb = v[:, None, 3:6]                                        # the base frame turns
    Td[:, :, :3] += np.cross(wb[..., None, :], T[:, :, :3], axisb=-2, axisc=-2)
    Td[:, :, 3:] += np.cross(wb[..., None, :], T[:, :, 3:], axisb=-2, axisc=-2)
    omega = np.concatenate([v[:, None, 3:6], v[:, None, 3:6] + w_rel], axis=1)   # absolute
    Mb = _diagonal_blocks(mass_blocks(model, q), n + 1)         # diag(I_k, m_k 1)
    MT = np.einsum("nkab,nkbj->nkaj", Mb, T)                    # M_b T, body by body
    W = np.zeros((N, n + 1, 6, 6))
    W[:, :, :3, :3] = skew(omega)
    C = (np.einsum("nkai,nkaj->nij", T, np.einsum("nkab,nkbj->nkaj", Mb, Td))
         + np.einsum("nkai,nkab,nkbj->nij", T, W, MT))
    return unbatch(single, C)


def _diagonal_blocks(M, k):
    """(N, k, 6, 6): the diagonal 6x6 blocks of M (N, 6k, 6k)."""
    N = M.shape[0]
    idx = np.arange(k)
    return M.reshape(N, k, 6, k, 6)[:, idx, :, idx, :].swapaxes(0, 1)


def speeds_from_v(model):
    """C (n+6, n+6): the textbook's [omega_0; cdot_0; qd] = C v (base frame): omega_0 = omega,
    cdot_0 = v_O + omega x c_0; so M = C^T (T^T M_blocks T) C."""
    n = model.dof
    C = np.eye(n + 6)
    C[:6, :6] = 0.0
    C[:3, 3:6] = np.eye(3)
    C[3:6, 0:3] = np.eye(3)
    C[3:6, 3:6] = -skew(model.base_com)
    return C


def mass_blocks(model, q):
    """diag(I_i, m_i 1) (N, 6(n+1), 6(n+1)) of the base and the bodies, base axes, inertias
    about the centers of mass."""
    single, q, _, _ = as_batch(model, q)
    N, n = q.shape[0], model.dof
    R0 = body_poses(model, q[:, 7:])[0]
    I = np.concatenate([np.broadcast_to(model.base_inertia, (N, 1, 3, 3)),
                        R0 @ model.I_c @ np.swapaxes(R0, -1, -2)], axis=1)
    m = np.concatenate([[model.base_mass], model.mass])
    Mb = np.zeros((N, 6 * (n + 1), 6 * (n + 1)))
    for i in range(n + 1):
        Mb[:, 6 * i:6 * i + 3, 6 * i:6 * i + 3] = I[:, i]
        Mb[:, 6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = m[i] * np.eye(3)
    return unbatch(single, Mb)
