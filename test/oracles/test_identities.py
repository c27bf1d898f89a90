"""Identities that hold on any robot (shared/reference/textbook_examples.md, section C).

Robots: the default UR5e, a Panda arm (example-robot-data), and synthetic chains with
prismatic joints. Each identity ties two independent computations together (Newton-Euler,
composite rigid bodies, the natural orthogonal complement, kinematics, finite differences).
"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.algorithms import kinematics, noc
from serial_dynamics.builtin.synthetic import chain_urdf


def _panda(tip):
    from pin_reference import erd   # skips when example-robot-data is absent
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd("panda_description/urdf/panda.urdf"), "panda_link0", tip)


ROBOTS = {
    "ur5e": lambda: sd.default_robot(),
    "panda": lambda: _panda("panda_link8"),
    "panda_finger": lambda: _panda("panda_leftfinger"),     # prismatic last joint
    "prismatic_chain": lambda: sd.load_urdf(chain_urdf(
        5, kinds=["prismatic", "revolute", "prismatic", "revolute", "revolute"],
        masses=[2.0, 1.5, 1.0, 0.7, 0.4], lengths=[0.3, 0.25, 0.2, 0.15, 0.1]),
        gravity=(0.5, -1.0, -9.81)),
    "spatial_chain": lambda: sd.load_urdf(chain_urdf(7, masses=np.linspace(3, 0.3, 7))),
}


BACKENDS = ("numba", "numpy")     # compiled kernels and the NumPy reference algorithms


@pytest.fixture(params=[(r, b) for r in sorted(ROBOTS) for b in BACKENDS],
                ids=lambda p: f"{p[0]}-{p[1]}", scope="module")
def robot(request):
    name, backend = request.param
    return sd.Robot(ROBOTS[name]().model, backend=backend)


def states(robot, count, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, qd = robot.random_state(rng, speed=1.5)
        yield q, qd, rng.uniform(-2.0, 2.0, robot.dof)


def rel_err(actual, expected):
    return np.max(np.abs(np.asarray(actual) - expected)) / np.max(np.abs(expected))


def vee(S):
    """Axial vector of the skew part of S."""
    return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def central(f, q, dq, h=1e-6):
    """d/dt f(q + t dq) at t = 0 by central differences."""
    return (f(q + h * dq) - f(q - h * dq)) / (2 * h)


# ---------------------------------------------------------------- NOC
def test_constraint_matrix_annihilates_twist_shaping(robot):
    m = robot.model
    for q, _, _ in states(robot, 4):
        K, T = noc.constraint_matrix(m, q), noc.twist_shaping(m, q)
        assert K.shape == T.shape[:1] * 2 and T.shape == (6 * robot.dof, robot.dof)
        assert np.linalg.matrix_rank(T) == robot.dof
        scale = np.linalg.norm(K) * np.linalg.norm(T)
        assert np.max(np.abs(K @ T)) <= 1e-14 * scale
        # and K is not trivially small: it constrains 6n - n directions of the twist space
        assert np.linalg.matrix_rank(K, tol=1e-10 * np.linalg.norm(K)) == 5 * robot.dof


def test_twist_shaping_gives_the_body_twists(robot):
    """t = T qd stacks [omega_i; cdot_i]: compare with finite differences of body rotations
    and centers of mass."""
    m = robot.model

    def rot(q):
        return kinematics.body_poses(m, q[None])[0][0]

    def com(q):
        R, o = (x[0] for x in kinematics.body_poses(m, q[None]))
        return o + np.einsum("nij,nj->ni", R, m.c)

    for q, qd, _ in states(robot, 3, seed=1):
        t = (noc.twist_shaping(m, q) @ qd).reshape(robot.dof, 6)
        Rdot, R = central(rot, q, qd), rot(q)
        omega = np.array([vee(Rdot[i] @ R[i].T) for i in range(robot.dof)])
        cdot = central(com, q, qd)
        assert rel_err(t[:, :3], omega) < 1e-7
        assert rel_err(t[:, 3:], cdot) < 1e-7


def test_mass_matrix_is_TtMT(robot):
    m = robot.model
    for q, _, _ in states(robot, 4, seed=2):
        T, M6 = noc.twist_shaping(m, q), noc.mass_matrix_6n(m, q)
        assert rel_err(T.T @ M6 @ T, robot.mass_matrix(q)) < 1e-12


def test_mass_matrix_columns_from_newton_euler(robot):
    """M e_j = ID(q, 0, e_j) - g(q): composite bodies against Newton-Euler."""
    for q, _, _ in states(robot, 3, seed=3):
        M = robot.mass_matrix(q)
        g = robot.gravity_torques(q)
        cols = np.array([robot.inverse_dynamics(q, np.zeros(robot.dof), e) - g
                         for e in np.eye(robot.dof)]).T
        assert rel_err(M, cols) < 1e-12
        np.testing.assert_array_equal(M, M.T)
        assert np.linalg.eigvalsh(M)[0] > 0


def test_twist_shaping_dot_by_finite_differences(robot):
    m = robot.model
    for q, qd, _ in states(robot, 3, seed=4):
        Td = noc.twist_shaping_dot(m, q, qd)
        assert rel_err(Td, central(lambda x: noc.twist_shaping(m, x), q, qd)) < 1e-7


def test_mdot_minus_2c_is_skew(robot):
    for q, qd, _ in states(robot, 4, seed=5):
        Mdot = central(robot.mass_matrix, q, qd, h=1e-5)
        C = robot.coriolis_matrix(q, qd)
        S = Mdot - 2 * C
        scale = np.max(np.abs(Mdot)) + np.max(np.abs(C))
        assert np.max(np.abs(S + S.T)) < 1e-8 * scale
        assert rel_err(C + C.T, Mdot) < 1e-7    # the same statement: Mdot = C + C^T
        # and C is not trivially symmetric-free: it carries the velocity terms
        assert np.max(np.abs(C)) > 1e-3 * np.max(np.abs(robot.mass_matrix(q))) * np.max(np.abs(qd))


def test_coriolis_plus_gravity_is_bias(robot):
    for q, qd, _ in states(robot, 4, seed=6):
        b = robot.bias_torques(q, qd)
        assert rel_err(robot.coriolis_matrix(q, qd) @ qd + robot.gravity_torques(q), b) < 1e-12
        assert rel_err(robot.inverse_dynamics(q, qd, np.zeros(robot.dof)), b) < 1e-15


def test_coriolis_matrix_pieces(robot):
    """C = T^T M Tdot + T^T W M T with the exported 6n x 6n pieces."""
    m = robot.model
    for q, qd, _ in states(robot, 2, seed=7):
        T, Td = noc.twist_shaping(m, q), noc.twist_shaping_dot(m, q, qd)
        M6, W = noc.mass_matrix_6n(m, q), noc.angular_velocity_matrix_6n(m, q, qd)
        assert rel_err(robot.coriolis_matrix(q, qd), T.T @ M6 @ Td + T.T @ W @ M6 @ T) < 1e-12


# ---------------------------------------------------------------- dynamics
@pytest.fixture(scope="module")
def lagrange(robot):
    """tau = M(q) qdd + C(q, qd) qd + g(q) - J(q)^T w by a route that shares no code with
    Newton-Euler's velocity terms: the NumPy reference's composite-rigid-body M, the natural
    orthogonal complement's C (reference code on either backend), the reference gravity
    torques and the kinematic Jacobian."""
    ref = sd.Robot(robot.model, backend="numpy")

    def tau(q, qd, qdd, w=None):
        out = (ref.mass_matrix(q) @ qdd + ref.coriolis_matrix(q, qd) @ qd
               + ref.gravity_torques(q))
        return out if w is None else out - ref.jacobian(q).T @ w
    return tau


@pytest.mark.parametrize("method", ["cholesky", "qr", "aba", "auto"])
def test_forward_inverse_identity(robot, lagrange, method):
    w = np.array([3.0, -2.0, 5.0, 0.4, -0.3, 0.2])
    for q, qd, qdd in states(robot, 5, seed=8):
        # the torques from the independent route, not from this robot's own Newton-Euler:
        # a forward route that shares a wrong velocity term with inverse dynamics would
        # otherwise take its own torques back exactly
        tau, tau_w = lagrange(q, qd, qdd), lagrange(q, qd, qdd, w)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) < 1e-12
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, wrench=w), tau_w) < 1e-12
        assert rel_err(robot.forward_dynamics(q, qd, tau, method=method), qdd) < 1e-9
        assert rel_err(robot.forward_dynamics(q, qd, tau_w, wrench=w, method=method), qdd) < 1e-9
        # the velocity terms weigh here: with their sign flipped qdd is off by 2 M^-1 C qd
        flip = 2 * np.linalg.solve(robot.mass_matrix(q), robot.coriolis_matrix(q, qd) @ qd)
        assert rel_err(qdd + flip, qdd) > 1e-3


def test_kinetic_energy_two_ways(robot):
    m = robot.model
    for q, qd, _ in states(robot, 4, seed=9):
        t = noc.twist_shaping(m, q) @ qd
        T1 = 0.5 * t @ noc.mass_matrix_6n(m, q) @ t
        T2 = 0.5 * qd @ robot.mass_matrix(q) @ qd
        assert robot.kinetic_energy(q, qd) == pytest.approx(T1, rel=1e-12)
        assert T1 == pytest.approx(T2, rel=1e-12) and T1 > 0


def test_gravity_is_gradient_of_potential(robot):
    for q, _, _ in states(robot, 3, seed=10):
        grad = np.array([central(robot.potential_energy, q, e, h=1e-6) for e in np.eye(robot.dof)])
        g = robot.gravity_torques(q)
        assert np.max(np.abs(grad - g)) < 1e-7 * max(np.max(np.abs(g)), 1.0)


def test_tip_wrench_is_minus_jacobian_transpose(robot):
    rng = np.random.default_rng(11)
    for q, qd, qdd in states(robot, 4, seed=11):
        w = rng.normal(size=6) * [20, 20, 20, 2, 2, 2]
        J = robot.jacobian(q)
        expected = robot.inverse_dynamics(q, qd, qdd) - J.T @ w
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, wrench=w), expected) < 1e-12
        assert rel_err(robot.bias_torques(q, qd, wrench=w), robot.bias_torques(q, qd) - J.T @ w) < 1e-12
        # a pure force along the tip's z axis does work only through the linear Jacobian
        f = np.r_[10 * robot.forward_kinematics(q)[:3, 2], 0, 0, 0]
        assert rel_err(robot.gravity_torques(q) - robot.inverse_dynamics(q, 0 * q, 0 * q, f),
                       J[:3].T @ f[:3]) < 1e-12


# ---------------------------------------------------------------- kinematics
def _links_to_check(robot):
    """The tip, a link in the middle of the chain, and the first moving link."""
    return [None, robot.link_names[robot.dof // 2], robot.link_names[0]]


def test_jacobian_by_finite_differences(robot):
    for link in _links_to_check(robot):
        for q, _, _ in states(robot, 2, seed=12):
            J = robot.jacobian(q, link=link)
            X = robot.forward_kinematics(q, link=link)
            Jfd = np.zeros_like(J)
            for j, e in enumerate(np.eye(robot.dof)):
                dX = central(lambda x: robot.forward_kinematics(x, link=link), q, e)
                Jfd[:3, j] = dX[:3, 3]
                Jfd[3:, j] = vee(dX[:3, :3] @ X[:3, :3].T)
            assert np.max(np.abs(J - Jfd)) < 1e-8 * max(np.max(np.abs(J)), 1.0), link


def test_intermediate_link_pose_ignores_outboard_joints(robot):
    q = robot.random_state(13)[0]
    link = robot.link_names[robot.dof // 2]
    k = robot.dof // 2
    q2 = q.copy()
    q2[k + 1:] += 0.7
    np.testing.assert_array_equal(robot.forward_kinematics(q, link), robot.forward_kinematics(q2, link))
    J = robot.jacobian(q, link)
    assert np.all(J[:, k + 1:] == 0) and np.any(J[:, k] != 0)


# ---------------------------------------------------------------- batches
def test_batch_equals_per_state(robot):
    N = 5
    rng = np.random.default_rng(14)
    q, qd = robot.random_state(rng, batch=N)
    qdd = rng.uniform(-2, 2, (N, robot.dof))
    w = rng.normal(size=(N, 6))
    tau = robot.inverse_dynamics(q, qd, qdd)
    calls = {
        "inverse_dynamics": (lambda *a: robot.inverse_dynamics(*a), (q, qd, qdd)),
        "inverse_dynamics_wrench": (lambda a, b, c, d: robot.inverse_dynamics(a, b, c, wrench=d),
                                    (q, qd, qdd, w)),
        "mass_matrix": (robot.mass_matrix, (q,)),
        "bias_torques": (robot.bias_torques, (q, qd)),
        "gravity_torques": (robot.gravity_torques, (q,)),
        "coriolis_matrix": (robot.coriolis_matrix, (q, qd)),
        "forward_cholesky": (lambda a, b, c: robot.forward_dynamics(a, b, c), (q, qd, tau)),
        "forward_qr": (lambda a, b, c: robot.forward_dynamics(a, b, c, method="qr"), (q, qd, tau)),
        "forward_aba": (lambda a, b, c: robot.forward_dynamics(a, b, c, method="aba"), (q, qd, tau)),
        "forward_wrench": (lambda a, b, c, d: robot.forward_dynamics(a, b, c, wrench=d),
                           (q, qd, tau, w)),
        "forward_kinematics": (robot.forward_kinematics, (q,)),
        "jacobian": (robot.jacobian, (q,)),
        "kinetic_energy": (robot.kinetic_energy, (q, qd)),
        "potential_energy": (robot.potential_energy, (q,)),
    }
    for name, (f, args) in calls.items():
        batched = f(*args)
        single = np.array([f(*(a[k] for a in args)) for k in range(N)])
        assert batched.shape == single.shape, name
        np.testing.assert_allclose(batched, single, rtol=1e-13, atol=1e-13 * np.max(np.abs(single)),
                                   err_msg=name)
    # a single state broadcasts against a batch, and a single wrench against a batch
    np.testing.assert_allclose(robot.inverse_dynamics(q[0], qd, qdd),
                               [robot.inverse_dynamics(q[0], qd[k], qdd[k]) for k in range(N)],
                               rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(robot.inverse_dynamics(q, qd, qdd, wrench=w[0]),
                               [robot.inverse_dynamics(q[k], qd[k], qdd[k], w[0]) for k in range(N)],
                               rtol=1e-13, atol=1e-12)
