"""Joint dissipation models (shared/reference/textbook_examples.md, section D)."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import Dissipation
from serial_dynamics.builtin.synthetic import chain_urdf

NAMES = ("j1", "j2", "j3")


def model(viscous=0.0, coulomb=0.0, stribeck=0.0, rate=0.0):
    per = lambda v: np.broadcast_to(np.asarray(v, float), (3,)).copy()  # noqa: E731
    return Dissipation(NAMES, per(viscous), per(coulomb), per(stribeck), per(rate))


SPEEDS = np.array([-3.0, -0.4, -1e-3, 0.0, 2e-3, 0.05, 0.7, 5.0])


def test_viscous():
    beta = np.array([0.5, 1.2, 3.0])
    d = model(viscous=beta)
    for v in SPEEDS:
        qd = np.array([v, -2 * v, 0.5 * v])
        np.testing.assert_allclose(d.torque(qd), -beta * qd, rtol=1e-15)
        assert d.function(qd) == pytest.approx(0.5 * np.sum(beta * qd**2), rel=1e-15, abs=0)


def test_coulomb():
    tc = np.array([0.3, 1.0, 2.5])
    d = model(coulomb=tc)
    for v in SPEEDS:
        qd = np.array([v, -v, 3 * v])
        np.testing.assert_allclose(d.torque(qd), -tc * np.sign(qd), rtol=1e-15)
        assert d.function(qd) == pytest.approx(np.sum(tc * np.abs(qd)), rel=1e-15, abs=0)
    np.testing.assert_array_equal(d.torque(np.zeros(3)), 0.0)   # sgn(0) = 0


def test_coulomb_with_low_speed_rise():
    tc, eps, gam = np.array([0.3, 1.0, 2.0]), np.array([0.2, 0.5, 1.5]), np.array([10.0, 2.0, 50.0])
    d = model(coulomb=tc, stribeck=eps, rate=gam)
    for v in SPEEDS:
        qd = np.array([v, 2 * v, -v])
        s = np.abs(qd)
        expected = -(tc + eps * np.exp(-gam * s)) * np.sign(qd)
        np.testing.assert_allclose(d.torque(qd), expected, rtol=1e-15)
        Delta = np.sum(tc * s + eps / gam * (1 - np.exp(-gam * s)))
        assert d.function(qd) == pytest.approx(Delta, rel=1e-14, abs=1e-300)
    # at a crawl the torque approaches the breakaway torque tau_c + eps; fast, only tau_c
    np.testing.assert_allclose(-d.torque(np.full(3, 1e-9)), tc + eps, rtol=1e-7)
    np.testing.assert_allclose(-d.torque(np.full(3, 100.0)), tc, rtol=1e-12)
    np.testing.assert_allclose(d.static_friction, tc + eps)


def test_all_terms_add():
    d = model(viscous=[0.5, 0, 1], coulomb=[0.3, 1, 0], stribeck=[0.2, 0.1, 0.4], rate=[5, 1, 3])
    qd = np.array([0.8, -0.3, 0.05])
    s = np.abs(qd)
    expected = -np.array([0.5, 0, 1]) * qd - (np.array([0.3, 1, 0]) + np.array([0.2, 0.1, 0.4])
                                              * np.exp(-np.array([5, 1, 3]) * s)) * np.sign(qd)
    np.testing.assert_allclose(d.torque(qd), expected, rtol=1e-15)


@pytest.mark.parametrize("coefs", [
    dict(viscous=[0.5, 1.2, 3.0]),
    dict(coulomb=[0.3, 1.0, 2.5]),
    dict(coulomb=[0.3, 1.0, 2.0], stribeck=[0.2, 0.5, 1.5], rate=[10.0, 2.0, 50.0]),
    dict(viscous=0.4, coulomb=0.2, stribeck=0.6, rate=0.0),          # the gamma = 0 limit
])
def test_torque_is_minus_gradient_of_dissipation_function(coefs):
    d = model(**coefs)
    rng = np.random.default_rng(0)
    h = 1e-6
    for _ in range(10):
        qd = rng.uniform(0.01, 3.0, 3) * rng.choice([-1, 1], 3)        # away from qd = 0
        grad = np.array([(d.function(qd + h * e) - d.function(qd - h * e)) / (2 * h)
                         for e in np.eye(3)])
        np.testing.assert_allclose(d.torque(qd), -grad, rtol=1e-7, atol=1e-9)


def test_dissipation_is_dissipative():
    d = model(viscous=[0.5, 0, 1], coulomb=[0.3, 1, 0], stribeck=[0.2, 0.1, 0.4], rate=[5, 1, 0])
    qd = np.random.default_rng(1).normal(size=(50, 3))
    assert np.all(np.sum(d.torque(qd) * qd, axis=1) < 0)         # power delta . qd < 0
    assert np.all(d.function(qd) > 0) and d.function(np.zeros(3)) == 0


def test_gamma_to_zero_limit():
    """gamma -> 0: Delta -> (tau_c + eps) |qd|, delta -> -(tau_c + eps) sgn(qd), continuously."""
    qd = np.array([0.4, -1.3, 2.0])
    at_zero = model(coulomb=0.3, stribeck=0.5, rate=0.0)
    np.testing.assert_allclose(at_zero.function(qd), 0.8 * np.sum(np.abs(qd)), rtol=1e-15)
    np.testing.assert_allclose(at_zero.torque(qd), -0.8 * np.sign(qd), rtol=1e-15)
    for gamma in (1e-3, 1e-6, 1e-9):
        near = model(coulomb=0.3, stribeck=0.5, rate=gamma)
        # Delta(gamma) - Delta(0) = -eps gamma qd^2 / 2 + O(gamma^2)
        assert near.function(qd) == pytest.approx(at_zero.function(qd)
                                                  - 0.5 * 0.5 * gamma * np.sum(qd**2), rel=1e-6)
        np.testing.assert_allclose(near.torque(qd), at_zero.torque(qd), rtol=3 * gamma)
    assert np.isfinite(at_zero.function(np.zeros(3)))


def test_batch():
    d = model(viscous=0.5, coulomb=0.3, stribeck=0.2, rate=4.0)
    qd = np.random.default_rng(2).normal(size=(6, 3))
    np.testing.assert_allclose(d.torque(qd), [d.torque(x) for x in qd], rtol=1e-15)
    np.testing.assert_allclose(d.function(qd), [d.function(x) for x in qd], rtol=1e-15)
    np.testing.assert_allclose(d.smooth_torque(qd), [d.smooth_torque(x) for x in qd], rtol=1e-15)


def test_smooth_torque():
    d = model(viscous=0.4, coulomb=[0.3, 1.0, 2.0], stribeck=[0.2, 0.0, 1.0], rate=[5, 1, 20])
    v_eps = 1e-3
    tau_s = d.static_friction
    for v in (0.003, 0.01, 0.05, 1.0):
        for sign in (-1, 1):
            qd = np.full(3, sign * v)
            err = np.abs(d.smooth_torque(qd, v_eps) - d.torque(qd))
            kinetic = np.abs(d.torque(qd) + 0.4 * qd)                   # tau_c + eps e^(-gamma |qd|)
            bound = np.exp(-2 * v / v_eps)
            roundoff = 1e-15 * np.abs(d.torque(qd))                     # 1 - tanh cancels
            assert np.all(err <= 2 * tau_s * bound + roundoff)
            assert np.all(err >= 2 * kinetic * bound / (1 + bound) - roundoff)   # and is tight
    np.testing.assert_array_equal(d.smooth_torque(np.zeros(3)), 0.0)
    # continuous and odd through zero, with the regularization width v_eps
    x = np.linspace(-5e-3, 5e-3, 201)
    t = np.array([d.smooth_torque(np.full(3, v), v_eps) for v in x])
    assert np.max(np.abs(np.diff(t, axis=0))) < 0.1 * np.max(tau_s)
    np.testing.assert_allclose(t, -t[::-1], atol=1e-15)
    np.testing.assert_allclose(d.smooth_torque(np.full(3, 1e-7), v_eps), -(tau_s) * np.tanh(1e-4)
                               - 0.4e-7, rtol=1e-6)


# ---------------------------------------------------------------- from the URDF, overrides
@pytest.fixture()
def robot():
    return sd.load_urdf(chain_urdf(3, damping=[0.1, 0.2, 0.3], friction=[1.0, 0.0, 0.5]))


def test_defaults_from_urdf_dynamics(robot):
    d = robot.dissipation
    assert d.joint_names == ("joint1", "joint2", "joint3")
    np.testing.assert_array_equal(d.viscous, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(d.coulomb, [1.0, 0.0, 0.5])
    np.testing.assert_array_equal(d.stribeck, 0.0)
    assert d.enabled
    qd = np.array([0.5, -2.0, -0.1])
    np.testing.assert_allclose(robot.dissipation_torques(qd),
                               [-0.05 - 1.0, 0.4, 0.03 + 0.5], rtol=1e-15)
    # rigid-body methods never include it
    q = np.zeros(3)
    np.testing.assert_allclose(robot.forward_dynamics(q, qd, robot.inverse_dynamics(q, qd, q)), q,
                               atol=1e-12)


def test_no_dynamics_tag_means_no_dissipation():
    r = sd.default_robot()
    assert not r.dissipation.enabled
    np.testing.assert_array_equal(r.dissipation_torques(np.ones(6)), 0.0)
    assert not Dissipation.none(NAMES).enabled


def test_override_by_name_and_scalar(robot):
    d0 = robot.dissipation
    d = d0.override(coulomb={"joint2": 2.0}, viscous=0.7,
                    stribeck={"joint1": 0.4, "joint3": 0.1}, stribeck_rate=8.0)
    np.testing.assert_array_equal(d.coulomb, [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(d.viscous, [0.7, 0.7, 0.7])
    np.testing.assert_array_equal(d.stribeck, [0.4, 0.0, 0.1])
    np.testing.assert_array_equal(d.stribeck_rate, [8.0, 8.0, 8.0])
    np.testing.assert_array_equal(d0.coulomb, [1.0, 0.0, 0.5])       # the original is untouched
    np.testing.assert_array_equal(d.override(viscous=[1, 2, 3]).viscous, [1, 2, 3])
    robot.dissipation = d
    qd = np.array([0.2, 0.3, -0.4])
    expected = -0.7 * qd - (np.array([1.0, 2.0, 0.5]) + np.array([0.4, 0, 0.1])
                            * np.exp(-8.0 * np.abs(qd))) * np.sign(qd)
    np.testing.assert_allclose(robot.dissipation_torques(qd), expected, rtol=1e-15)
    with pytest.raises(AttributeError):
        d.viscous = np.ones(3)                                       # frozen
    with pytest.raises(ValueError):
        d.viscous[0] = 5.0                                           # read-only arrays


@pytest.mark.parametrize("kwargs, culprit", [
    (dict(friction=1.0), "'friction'"),
    (dict(coulomb={"elbow": 1.0}), "'elbow'"),
    (dict(coulomb={"joint2": -1.0}), "'joint2'"),
    (dict(viscous={"joint3": np.nan}), "'joint3'"),
    (dict(viscous=-0.1), "'joint1'"),
    (dict(stribeck_rate=np.inf), "'joint1'"),
    (dict(viscous=[1.0, 2.0]), "viscous"),
])
def test_bad_override(robot, kwargs, culprit):
    with pytest.raises(ValueError) as info:
        robot.dissipation.override(**kwargs)
    assert culprit in str(info.value)


def test_bad_dissipation_models(robot):
    with pytest.raises(ValueError, match="coulomb has 2 values"):
        Dissipation(NAMES, np.zeros(3), np.zeros(2), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="stribeck of joint 'j2'"):
        Dissipation(NAMES, np.zeros(3), np.zeros(3), [0, -1, 0], np.zeros(3))
    with pytest.raises(ValueError, match="joint1"):
        robot.dissipation = model(viscous=1.0)                       # other joints
    with pytest.raises(ValueError):
        robot.dissipation = {"viscous": 1.0}
