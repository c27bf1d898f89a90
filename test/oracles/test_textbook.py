"""Textbook oracles (shared/reference/textbook_examples.md, sections A and B).

A: planar 3R arm in a vertical plane, closed-form mass matrix, gravity and Coriolis terms.
B: spatial 3R arm with isotropic links at the posture of the example, no gravity.
"""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin import planar_3r_urdf, spatial_3r_urdf

G = 9.81


def assert_rel(actual, expected, rel, what=""):
    """max |actual - expected| <= rel * max |expected| (a relative error on the whole array)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    err = np.max(np.abs(actual - expected))
    scale = np.max(np.abs(expected))
    assert err <= rel * scale, f"{what}: error {err:.3g} > {rel:g} * {scale:.3g}"


# ---------------------------------------------------------------- A. planar 3R
def planar_oracle(a, m, I, th, thd):
    """(mass matrix, Coriolis/centrifugal v, gravity torques) of example A."""
    a1, a2, a3 = a
    m1, m2, m3 = m
    I1, I2, I3 = I
    t1, t2, t3 = th
    d1, d2, d3 = thd
    c1, c2, c3 = np.cos([t1, t2, t3])
    s2, s3 = np.sin(t2), np.sin(t3)
    c12, c23, c123 = np.cos(t1 + t2), np.cos(t2 + t3), np.cos(t1 + t2 + t3)
    s23 = np.sin(t2 + t3)
    I11 = (I1 + I2 + I3 + m1 * a1**2 / 4 + m2 * (a1**2 + a2**2 / 4 + a1 * a2 * c2)
           + m3 * (a1**2 + a2**2 + a3**2 / 4 + 2 * a1 * a2 * c2 + a1 * a3 * c23 + a2 * a3 * c3))
    I12 = I2 + I3 + 0.5 * (m2 * (a2**2 / 2 + a1 * a2 * c2)
                           + m3 * (2 * a2**2 + a3**2 / 2 + 2 * a1 * a2 * c2 + a1 * a3 * c23
                                   + 2 * a2 * a3 * c3))
    I13 = I3 + 0.5 * m3 * (a3**2 / 2 + a1 * a3 * c23 + a2 * a3 * c3)
    I22 = I2 + I3 + m2 * a2**2 / 4 + m3 * (a2**2 + a3**2 / 4 + a2 * a3 * c3)
    I23 = I3 + 0.5 * m3 * (a3**2 / 2 + a2 * a3 * c3)
    I33 = I3 + m3 * a3**2 / 4
    M = np.array([[I11, I12, I13], [I12, I22, I23], [I13, I23, I33]])
    g = np.array([
        0.5 * m1 * G * a1 * c1 + m2 * G * (a1 * c1 + 0.5 * a2 * c12)
        + m3 * G * (a1 * c1 + a2 * c12 + 0.5 * a3 * c123),
        0.5 * m2 * G * a2 * c12 + m3 * G * (a2 * c12 + 0.5 * a3 * c123),
        0.5 * m3 * G * a3 * c123,
    ])
    A = m2 * a1 * a2 * s2 + m3 * (2 * a1 * a2 * s2 + a1 * a3 * s23)
    B = m3 * (a1 * a3 * s23 + a2 * a3 * s3)
    D = m3 * a2 * a3 * s3
    v = np.array([
        -A * d1 * d2 - B * d1 * d3 - 0.5 * A * d2**2 - B * d2 * d3 - 0.5 * B * d3**2,
        0.5 * A * d1**2 - D * d1 * d3 - D * d2 * d3 - 0.5 * D * d3**2,
        0.5 * B * d1**2 + D * d1 * d2 + 0.5 * D * d2**2,
    ])
    return M, v, g


PLANAR_PARAMS = {
    "default": ((0.4, 0.3, 0.2), (3.0, 2.0, 1.0), None),
    "long": ((1.0, 0.7, 0.5), (5.0, 1.5, 0.8), (0.3, 0.1, 0.05)),
    "small": ((0.05, 0.12, 0.08), (0.2, 0.3, 0.1), (1e-4, 2e-4, 5e-5)),
    "heavy_tip": ((0.3, 0.3, 0.3), (1.0, 1.0, 10.0), (0.01, 0.01, 0.2)),
}


def _planar(name, backend="numba"):
    a, m, I = PLANAR_PARAMS[name]
    robot = sd.load_urdf(planar_3r_urdf(a, m, I), base_link="base_link")
    robot = sd.Robot(robot.model, backend=backend)
    if I is None:   # the generator's default: thin cylinders of radius 0.02
        I = np.asarray(m) * (3 * 0.02**2 + np.asarray(a) ** 2) / 12.0
    return robot, a, m, I


@pytest.fixture(params=[(p, b) for p in sorted(PLANAR_PARAMS) for b in ("numba", "numpy")],
                ids=lambda p: f"{p[0]}-{p[1]}", scope="module")
def planar(request):
    return _planar(*request.param)


def test_planar_setup_matches_the_example(planar):
    robot, a, _, _ = planar
    assert robot.dof == 3 and robot.joint_names == ["joint1", "joint2", "joint3"]
    # wall-mounted base: world gravity -Z is base -Y, the example's setting
    np.testing.assert_allclose(robot.gravity, [0.0, -G, 0.0], atol=1e-12)
    # tip at a1 + a2 + a3 along X when stretched, and at the closed-form position otherwise
    q = np.array([0.3, -1.1, 0.7])
    th = np.cumsum(q)
    tip = [np.dot(a, np.cos(th)), np.dot(a, np.sin(th)), 0.0]
    np.testing.assert_allclose(robot.forward_kinematics(q)[:3, 3], tip, atol=1e-14)


def test_planar_loaded_from_the_world_root_falls_the_same_way(planar):
    """From the URDF root ('world', arm plane vertical) the torques are the same; only the
    frame of poses changes (world Z is the arm's Y)."""
    robot, a, m, I = planar
    world = sd.load_urdf(planar_3r_urdf(a, m, I))
    assert world.base_link == "world"
    np.testing.assert_allclose(world.gravity, [0.0, 0.0, -G])
    rng = np.random.default_rng(9)
    q, qd, qdd = rng.uniform(-3, 3, (3, 3))
    assert_rel(world.inverse_dynamics(q, qd, qdd), robot.inverse_dynamics(q, qd, qdd), 1e-13, "tau")
    x = robot.forward_kinematics(q)[:3, 3]
    np.testing.assert_allclose(world.forward_kinematics(q)[:3, 3], [x[0], -x[2], x[1]], atol=1e-15)


def test_planar_mass_matrix(planar):
    robot, a, m, I = planar
    rng = np.random.default_rng(10)
    for q in rng.uniform(-np.pi, np.pi, (20, 3)):
        M, _, _ = planar_oracle(a, m, I, q, np.zeros(3))
        assert_rel(robot.mass_matrix(q), M, 1e-12, "mass matrix")


def test_planar_gravity(planar):
    robot, a, m, I = planar
    rng = np.random.default_rng(11)
    for q in rng.uniform(-np.pi, np.pi, (20, 3)):
        _, _, g = planar_oracle(a, m, I, q, np.zeros(3))
        assert_rel(robot.gravity_torques(q), g, 1e-12, "gravity torques")
    # stretched horizontally: every link's full moment arm
    _, _, g0 = planar_oracle(a, m, I, np.zeros(3), np.zeros(3))
    assert g0[2] == pytest.approx(0.5 * m[2] * G * a[2], rel=1e-15)
    assert_rel(robot.gravity_torques(np.zeros(3)), g0, 1e-12, "gravity, stretched")
    # hanging straight down: no gravity torque at all
    np.testing.assert_allclose(robot.gravity_torques([-np.pi / 2, 0, 0]), 0.0,
                               atol=1e-12 * np.max(np.abs(g0)))


def test_planar_coriolis(planar):
    robot, a, m, I = planar
    rng = np.random.default_rng(12)
    for _ in range(20):
        q, qd = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-3, 3, 3)
        _, v, g = planar_oracle(a, m, I, q, qd)
        assert_rel(robot.coriolis_matrix(q, qd) @ qd, v, 1e-12, "C qd")
        assert_rel(robot.bias_torques(q, qd), v + g, 1e-12, "bias torques")


def test_planar_equations_of_motion(planar):
    robot, a, m, I = planar
    rng = np.random.default_rng(13)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-3, 3, 3), rng.uniform(-5, 5, 3)
        M, v, g = planar_oracle(a, m, I, q, qd)
        tau = M @ qdd + v + g
        assert_rel(robot.inverse_dynamics(q, qd, qdd), tau, 1e-12, "I qdd + v + g")
        for method in ("cholesky", "qr", "aba"):
            assert_rel(robot.forward_dynamics(q, qd, tau, method=method), qdd, 1e-10,
                       f"forward dynamics ({method})")


def test_planar_energy_is_lagrangian():
    """Kinetic energy 1/2 qd^T I qd with the oracle's I; potential energy rises with height."""
    robot, a, m, I = _planar("long")
    rng = np.random.default_rng(14)
    q, qd = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-2, 2, 3)
    M, _, _ = planar_oracle(a, m, I, q, qd)
    assert robot.kinetic_energy(q, qd) == pytest.approx(0.5 * qd @ M @ qd, rel=1e-13)
    th = np.cumsum(q)
    heights = [a[0] / 2 * np.sin(th[0]),
               a[0] * np.sin(th[0]) + a[1] / 2 * np.sin(th[1]),
               a[0] * np.sin(th[0]) + a[1] * np.sin(th[1]) + a[2] / 2 * np.sin(th[2])]
    assert robot.potential_energy(q) == pytest.approx(G * np.dot(m, heights), rel=1e-12)


# ---------------------------------------------------------------- B. spatial 3R
SPATIAL_PARAMS = [(0.5, 2.0, 0.05), (1.0, 1.0, 0.1), (0.2, 7.5, 0.003)]


def _spatial(a, m, I, backend):
    model = sd.load_urdf(spatial_3r_urdf(a, m, I), gravity=(0, 0, 0)).model
    return sd.Robot(model, backend=backend)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("a, m, I", SPATIAL_PARAMS)
def test_spatial_mass_matrix(a, m, I, backend):
    robot = _spatial(a, m, I, backend)
    expected = 0.25 * m * a**2 * np.array([[11, 4, 0], [4, 7, 0], [0, 0, 1]]) + I * np.diag([3, 2, 1])
    assert_rel(robot.mass_matrix(np.zeros(3)), expected, 1e-13, "mass matrix")


@pytest.mark.parametrize("a, m, I", SPATIAL_PARAMS)
@pytest.mark.parametrize("p", [1.0, -0.7, 2.5])
@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_spatial_coriolis_torques(a, m, I, p, backend):
    robot = _spatial(a, m, I, backend)
    q, qd = np.zeros(3), p * np.ones(3)
    # erratum: the chapter prints tau1 = p^2 (a^2 m / 2 - I); the correct value is p^2 (a^2 m - I)
    expected = p**2 * np.array([a**2 * m - I, I - 0.25 * a**2 * m, a**2 * m - I])
    assert_rel(robot.inverse_dynamics(q, qd, np.zeros(3)), expected, 1e-13, "tau")
    assert_rel(robot.coriolis_matrix(q, qd) @ qd, expected, 1e-13, "C qd")
    assert_rel(robot.bias_torques(q, qd), expected, 1e-13, "bias")
    printed = p**2 * (0.5 * a**2 * m - I)
    assert abs(robot.inverse_dynamics(q, qd, np.zeros(3))[0] - printed) > 0.4 * p**2 * a**2 * m


def test_spatial_posture_is_the_example():
    """At q = 0 the joint axes and origins are those of the example (a = 0.5)."""
    a = 0.5
    robot = sd.load_urdf(spatial_3r_urdf(a, 2.0, 0.05), gravity=(0, 0, 0))
    J = robot.jacobian(np.zeros(3), link="link3")
    np.testing.assert_allclose(J[3:], np.eye(3)[:, [2, 1, 0]], atol=1e-15)   # e1=k, e2=j, e3=i
    origins = [robot.forward_kinematics(np.zeros(3), link=f"link{i}")[:3, 3] for i in (1, 2, 3)]
    np.testing.assert_allclose(origins, [[0, 0, 0], [-a, 0, 0], [-a, a, -a]], atol=1e-15)
