"""``sim.compiled_euler.simulate_fixed_step`` on every kind of robot: the same bits as
``sd.simulate`` and ``FixedStepIntegrator`` with semi-implicit Euler, in the robot's own
coordinates (a mimic chain's independent joints, a floating base's q (n+7) and v (n+6)); a
planar chain."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin import planar_3r_urdf
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.sim.compiled_euler import simulate_fixed_step
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

DT, STEPS = 1e-3, 40


def stepped(robot, q, v, tau, steps=STEPS, viscous=None):
    """The reference: FixedStepIntegrator, one step at a time, damping explicit."""
    integ = FixedStepIntegrator(robot, "semi_implicit_euler", DT, dissipation=False)
    Q, V = [q], [v]
    for _ in range(steps):
        t = tau if viscous is None else tau - viscous * V[-1][robot.nv - robot.dof:]
        q, v = integ.step(Q[-1], V[-1], t)
        Q.append(q)
        V.append(v)
    return np.array(Q), np.array(V)


def test_a_mimic_chain_runs_on_its_independent_joints():
    from test_mimic import mimic_chain
    robot = sd.load_urdf(mimic_chain())
    assert robot.dof == 2 and robot.model.dof == 4
    q0 = np.full(robot.dof, 0.2)
    q, qd = simulate_fixed_step(robot, q0, np.zeros(robot.dof), robot.gravity_torques(q0),
                                DT, STEPS)
    assert q.shape == qd.shape == (STEPS + 1, robot.dof)
    assert np.max(np.abs(q - 0.2)) < 1e-12             # held by its gravity torques
    # a moving run: the integrator's bits, explicit damping; implicit damping to round-off
    tau, beta, v0 = np.array([1.5, -2.0]), np.array([0.4, 0.7]), np.array([0.5, -0.3])
    q, qd = simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, viscous=beta,
                                implicit_damping=False)
    Q, V = stepped(robot, q0, v0, tau, viscous=beta)
    np.testing.assert_array_equal(q, Q)
    np.testing.assert_array_equal(qd, V)
    assert np.max(np.abs(q[-1] - q0)) > 1e-3             # it moved
    q, qd = simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, viscous=beta)
    x, v = q0, v0
    for k in range(STEPS):       # (M + dt diag(beta)) qdd = tau - beta qd - b
        A = robot.mass_matrix(x) + DT * np.diag(beta)
        v = v + DT * np.linalg.solve(A, tau - beta * v - robot.bias_torques(x, v))
        x = x + DT * v
    np.testing.assert_allclose(q[-1], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(qd[-1], v, rtol=0, atol=1e-10)


def test_a_planar_chain_gives_the_bits_of_simulate():
    robot = sd.load_urdf(planar_3r_urdf())
    q0, v0, tau = np.array([0.3, -0.4, 0.2]), np.array([0.1, 0.0, -0.2]), np.array([1.0, 0.5, -0.2])
    q, qd = simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, implicit_damping=False)
    res = sd.simulate(robot, STEPS * DT, q0, v0, torque=tau, method="semi_implicit_euler",
                      dt=DT, dissipation=False)
    np.testing.assert_array_equal(q, res.q)
    np.testing.assert_array_equal(qd, res.qd)
    Q, V = stepped(robot, q0, v0, tau)                   # the planar kernels: to round-off
    np.testing.assert_allclose(q, Q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(qd, V, rtol=0, atol=1e-11)


def test_a_floating_base_runs_in_its_own_coordinates():
    robot = sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))
    q0 = robot.neutral()
    v0 = np.r_[0.01, 0.0, -0.02, 0.3, -0.5, 0.8, np.full(robot.dof, 0.2)]
    tau = np.linspace(1.0, -1.0, robot.dof)
    q, v = simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, implicit_damping=False)
    assert q.shape == (STEPS + 1, robot.nq) and v.shape == (STEPS + 1, robot.nv)
    res = sd.simulate(robot, STEPS * DT, q0, v0, torque=tau, method="semi_implicit_euler",
                      dt=DT, dissipation=False)
    np.testing.assert_array_equal(q, res.q)
    np.testing.assert_array_equal(v, res.qd)
    beta = np.full(robot.dof, 0.5)
    q, v = simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, viscous=beta, implicit_damping=False)
    Q, V = stepped(robot, q0, v0, tau, viscous=beta)
    np.testing.assert_array_equal(q, Q)
    np.testing.assert_array_equal(v, V)
    with pytest.raises(ValueError, match=rf"q0 has shape \({robot.dof},\); expected .*\({robot.nq},\)"):
        simulate_fixed_step(robot, np.zeros(robot.dof), v0, tau, DT, STEPS)
    with pytest.raises(ValueError, match="implicit_damping=False"):
        simulate_fixed_step(robot, q0, v0, tau, DT, STEPS, viscous=beta)
