"""Articulated-body algorithm: the NumPy reference (algorithms/aba.py) against the Cholesky
route, the compiled ABA against the NumPy ABA, and both against Pinocchio's aba."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import Robot
from serial_dynamics.algorithms import aba, forward
from serial_dynamics.builtin.synthetic import chain_urdf

EPS = np.finfo(float).eps


def rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


CHAINS = {
    "ur5e": lambda: sd.default_robot(),
    "planar_3r": lambda: sd.builtin_robot("planar_3r"),
    "spatial_3r": lambda: sd.builtin_robot("spatial_3r"),
    "prismatic": lambda: sd.load_urdf(chain_urdf(7, kinds=["prismatic", "revolute", "revolute"] * 2 + ["prismatic"])),
    "chain_25": lambda: sd.load_urdf(chain_urdf(25, masses=np.linspace(2, 0.2, 25))),
}


@pytest.fixture(scope="module", params=list(CHAINS))
def robot(request):
    return CHAINS[request.param]()


@pytest.mark.parametrize("batch", [None, 6])
def test_numpy_aba_equals_cholesky(robot, batch):
    rng = np.random.default_rng(0)
    q, qd = robot.random_state(rng, batch=batch, speed=2.0)
    tau = rng.normal(size=q.shape) * 10
    w = rng.normal(size=6)
    for wrench in (None, w):
        a = aba.forward_dynamics(robot.model, q, qd, tau, wrench)
        c = forward.forward_dynamics(robot.model, q, qd, tau, wrench)
        kappa = np.linalg.cond(robot.mass_matrix(q if batch is None else q[0]))
        assert a.shape == c.shape
        assert rel(a, c) <= max(1e-12, 10 * kappa * EPS)


def test_compiled_aba_equals_numpy_aba(robot):
    ref = Robot(robot.model, backend="numpy")
    rng = np.random.default_rng(1)
    q, qd = robot.random_state(rng, batch=5)
    tau = rng.normal(size=q.shape)
    w = rng.normal(size=(5, 6))
    kappa = np.linalg.cond(robot.mass_matrix(q[0]))
    for wrench in (None, w):
        got = robot.forward_dynamics(q, qd, tau, wrench, method="aba")
        assert rel(got, ref.forward_dynamics(q, qd, tau, wrench, method="aba")) <= max(1e-12, 10 * kappa * EPS)
        # and the reference's inverse dynamics takes it back (not the compiled one: it
        # shares the compiled spatial code, and with it any error in the velocity terms)
        assert rel(ref.inverse_dynamics(q, qd, got, wrench), tau) <= 1e-12


def test_aba_and_cholesky_agree_on_long_chains():
    """The two compiled routes on the chains of the scaling benchmark (n up to 200), and
    the backward error of each against the NumPy reference's M and b."""
    for n in (50, 200):
        robot = sd.load_urdf(chain_urdf(n, kinds=(["revolute"] * 9 + ["prismatic"]) * (n // 10)))
        rng = np.random.default_rng(n)
        q, qd = robot.random_state(rng, batch=3)
        tau = rng.normal(size=q.shape)
        a = robot.forward_dynamics(q, qd, tau, method="aba")
        c = robot.forward_dynamics(q, qd, tau, method="cholesky")
        kappa = max(np.linalg.cond(robot.mass_matrix(x)) for x in q)
        assert rel(a, c) <= 10 * kappa * EPS
        ref = Robot(robot.model, backend="numpy")
        M, b = ref.mass_matrix(q), ref.bias_torques(q, qd)
        for x in (a, c):          # backward error of each: M qdd + b - tau, relative to its terms
            res = np.einsum("nij,nj->ni", M, x) + b - tau
            assert np.max(np.abs(res)) <= 1e-12 * np.max(np.abs(np.einsum("nij,nj->ni", M, x)))


def test_spatial_helpers():
    rng = np.random.default_rng(2)
    c = rng.normal(size=3)
    A = rng.normal(size=(3, 3))
    Ic = A @ A.T
    I6 = aba.spatial_inertia(2.5, c, Ic)
    assert np.allclose(I6, I6.T) and np.min(np.linalg.eigvalsh(I6)) > 0
    # kinetic energy of a pure translation v is m v^2 / 2
    v = np.r_[0, 0, 0, rng.normal(size=3)]
    assert np.isclose(v @ I6 @ v, 2.5 * v[3:] @ v[3:])
    # X(R, p) then X(R^T, -R^T p) is the identity
    from serial_dynamics.algorithms._batch import rotation_about
    R = rotation_about(np.array([0, 0.6, 0.8]), np.array([0.7]))[0]
    p = rng.normal(size=3)
    X = aba.motion_transform(R, p)
    Xi = aba.motion_transform(R.T, -R.T @ p)
    assert np.allclose(Xi @ X, np.eye(6))


@pytest.mark.parametrize("rel_path, tip", [("panda_description/urdf/panda.urdf", "panda_link8"),
                                           ("ur_description/urdf/ur5_robot.urdf", "tool0")])
def test_against_pinocchio_aba(rel_path, tip):
    from pin_reference import PinReference, erd, load
    path = erd(rel_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load(path, None, tip)
    pin_ref = PinReference(robot, path)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd = robot.random_state(rng, speed=2.0)
        tau = rng.normal(size=robot.dof) * 20
        expect = pin_ref.aba(q, qd, tau)
        kappa = np.linalg.cond(robot.mass_matrix(q))
        for method in ("aba", "cholesky"):
            assert rel(robot.forward_dynamics(q, qd, tau, method=method), expect) <= max(1e-12, 10 * kappa * EPS)
        assert rel(aba.forward_dynamics(robot.model, q, qd, tau), expect) <= max(1e-12, 10 * kappa * EPS)
