"""The analytical Jacobians of the implicit methods (``sim/jacobians.py``): equal to
central differences of the state equations (the oracle) and to the finite-difference
route they replace, and the implicit methods reach the same solutions with fewer
dynamics evaluations."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import stiff_chain_urdf
from serial_dynamics.sim.adaptive import jacobians
from serial_dynamics.sim.equations import Equations, Inputs
from serial_dynamics.sim.jacobians import accel_jacobian

Q0 = np.array([0.3, -1.0, 0.8, -0.5, 0.4, 0.2])
QD0 = np.array([0.7, -0.4, 0.9, 1.2, -0.8, 0.5])       # every |qd| >> v_eps


def friction_ur5e():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(
        viscous=[0.8, 0.8, 0.5, 0.1, 0.1, 0.05], coulomb=[4, 4, 3, 0.6, 0.6, 0.2],
        stribeck=[2, 2, 1, 0.2, 0.2, 0.05], stribeck_rate=5.0)
    return robot


def cases():
    robot = friction_ur5e()
    Kp, Kd = np.array([40, 40, 30, 5, 5, 1.0]), np.array([4, 4, 3, 0.5, 0.5, 0.1])
    pd = lambda t, q, qd: robot.gravity_torques(q) + Kp * (Q0 - q) - Kd * qd  # noqa: E731
    w = np.array([5.0, -3.0, 10.0, 0.2, 0.1, -0.3])
    deck = sd.BaseMotion(angular_velocity=[0.2, 0.1, 0.0], angular_acceleration=[0, 0.3, 0],
                         linear_acceleration=[0.1, 0, 0.5])
    spring = lambda t, q, qd: np.r_[-20.0 * (q[:3] - Q0[:3]), 0, 0, 0]     # noqa: E731
    return {
        "friction, constant torque": (robot, Inputs(lambda t, q, qd: np.ones(6), None, None,
                                                    False)),
        "state feedback": (robot, Inputs(pd, None, None, True)),
        "wrench and base motion": (robot, Inputs(lambda t, q, qd: np.zeros(6),
                                                 lambda t, q, qd: w, lambda t: deck, False)),
        "state-dependent wrench": (robot, Inputs(lambda t, q, qd: np.zeros(6), spring, None,
                                                 True)),
    }


def rhs(eq, inputs, smooth, t, y):
    n = eq.n
    q, qd = y[:n], y[n:2 * n]
    tau, w = inputs(t, q, qd)
    qdd, delta = eq.accel(q, qd, tau, w, smooth=smooth)
    p = float(eq.ext_power(q, qd, w)) if w is not None else 0.0
    return np.concatenate([qd, qdd, [tau @ qd, delta @ qd, p]])


@pytest.mark.parametrize("case", list(cases()))
def test_adaptive_jacobian_equals_central_differences(case):
    robot, inputs = cases()[case]
    eq = Equations(robot, True, smoothing=1e-3)
    y = np.concatenate([Q0, QD0, np.zeros(3)])
    J, J_fd = (f(0.3, y) for f in jacobians(eq, inputs, True))
    h = 1e-6
    C = np.empty_like(J)
    for j in range(y.size):
        e = np.zeros(y.size)
        e[j] = h
        C[:, j] = (rhs(eq, inputs, True, 0.3, y + e) - rhs(eq, inputs, True, 0.3, y - e)) / (2 * h)
    scale = np.abs(C).max()
    np.testing.assert_allclose(J, C, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(J, J_fd, rtol=0, atol=1e-5 * scale)   # the route it replaces
    assert np.abs(J[6:12, :12]).max() > 1.0                           # not a zero matrix


def test_midpoint_jacobian_with_held_viscous_and_frozen_coulomb():
    """The Newton Jacobian of the implicit midpoint rule: d delta/d qd = -beta (Coulomb
    frozen over the step) against central differences of the accelerations."""
    robot, inputs = cases()["state feedback"]
    eq = Equations(robot, True)
    coulomb = -eq.diss.sliding_friction(QD0) * np.sign(QD0)

    def accel(q, qd):
        tau, w = inputs(0.1, q, qd)
        return eq.accel(q, qd, tau, w, None, np.sign(QD0), coulomb=coulomb)

    a, d = accel(Q0, QD0)
    tau, w = inputs(0.1, Q0, QD0)
    Aq, Av, _, _ = accel_jacobian(eq, inputs, 0.1, Q0, QD0, tau + d, w, -eq.beta)
    h = 1e-6
    Cq = np.array([(accel(Q0 + h * e, QD0)[0] - accel(Q0 - h * e, QD0)[0]) / (2 * h)
                   for e in np.eye(6)]).T
    Cv = np.array([(accel(Q0, QD0 + h * e)[0] - accel(Q0, QD0 - h * e)[0]) / (2 * h)
                   for e in np.eye(6)]).T
    np.testing.assert_allclose(Aq, Cq, rtol=0, atol=1e-6 * np.abs(Cq).max())
    np.testing.assert_allclose(Av, Cv, rtol=0, atol=1e-6 * np.abs(Cv).max())


@pytest.mark.parametrize("method, kw, tol", [
    ("Radau", dict(rtol=1e-7, atol=1e-9), 1e-8), ("BDF", dict(rtol=1e-7, atol=1e-9), 1e-6),
    ("LSODA", dict(rtol=1e-7, atol=1e-9), 1e-6), ("implicit_midpoint", dict(dt=1e-3), 1e-6)])
def test_stiff_chain_same_accuracy_fewer_dynamics_states(method, kw, tol):
    """The implicit methods with the analytical Jacobian: their accuracy on the stiff chain
    (against Radau at rtol 1e-11), the same solution as with finite differences (the
    Jacobian changes only the Newton iterates), and fewer dynamics states (a Jacobian:
    one derivative call instead of a batch of 2n + 1 states)."""
    robot = sd.load_urdf(stiff_chain_urdf())
    q0 = np.array([0.3, 0.8, -0.5, 0.6])
    ref = sd.simulate(robot, 0.5, q0, None, method="Radau", rtol=1e-11, atol=1e-13)
    out = {}
    for jac in ("analytical", "finite_differences"):
        res = sd.simulate(robot, 0.5, q0, None, method=method, jacobian=jac, **kw)
        err = np.abs(np.r_[res.q[-1] - ref.q[-1], res.qd[-1] - ref.qd[-1]]).max()
        assert err < tol, (jac, err)
        out[jac] = res
    a, f = out["analytical"], out["finite_differences"]
    np.testing.assert_allclose(a.q[-1], f.q[-1], rtol=0, atol=tol / 10)
    assert a.stats.njev >= 1
    assert a.stats.dynamics_states < f.stats.dynamics_states
    assert f.stats.dynamics_states - a.stats.dynamics_states >= 2 * 4 * a.stats.njev // 2


def test_unknown_jacobian_route_is_refused():
    robot = sd.default_robot()
    with pytest.raises(ValueError, match="jacobian 'exact' unknown"):
        sd.simulate(robot, 0.1, method="Radau", jacobian="exact")
