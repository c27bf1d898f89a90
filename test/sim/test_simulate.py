"""Simulator: API, inputs, methods and their orders, stick-slip friction, divergence.

The hard cases (energy over long horizons, stiff and ill-conditioned chains, long chain,
high-speed spin) are in test_simulate_hard.py.
"""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import chain_urdf, stiff_chain_urdf
from serial_dynamics.sim.driver import simulate as simulate_fn
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.methods import ADAPTIVE, FIXED_STEP, METHODS, SimulationError

FIRST_ORDER = ("semi_implicit_euler", "symplectic_euler")
from serial_dynamics.sim.result import SimulationResult

Q0 = np.array([0.3, -1.0, 0.8, -0.5, 0.4, 0.2])   # a generic UR5e posture


@pytest.fixture(scope="module")
def ur5e():
    return sd.default_robot()


def one_joint(friction=0.0, damping=0.0, axis="z", **kw):
    """A single rod on a joint; about z (the gravity axis) gravity exerts no torque."""
    return sd.load_urdf(chain_urdf(1, axes=(axis,), friction=friction, damping=damping, **kw))


def test_simulate_is_exposed_and_callable(ur5e):
    assert sd.simulate is simulate_fn or sd.simulate(ur5e, 0.01).q.shape[1] == 6
    res = sd.simulate(ur5e, 0.01)                      # works after the submodule import too
    assert isinstance(res, SimulationResult)


def test_result_fields(ur5e):
    res = sd.simulate(ur5e, 0.3, Q0, None, method="DOP853")
    K = res.t.size
    assert res.t[0] == 0.0 and res.t[-1] == pytest.approx(0.3, abs=1e-15)
    assert np.all(np.diff(res.t) > 0)
    for name in ("q", "qd", "qdd", "tau", "delta"):
        assert getattr(res, name).shape == (K, 6), name
    for name in ("kinetic", "potential", "energy", "work_actuators", "work_dissipation",
                 "work_external", "energy_dissipated", "energy_balance_error"):
        assert getattr(res, name).shape == (K,), name
    s = res.stats
    assert s.method == "DOP853" and s.steps > 5 and s.nfev > s.steps and s.wall_time > 0
    assert s.dynamics_states >= s.nfev - 3           # every RHS evaluated the dynamics
    np.testing.assert_array_equal(res.q[0], Q0)
    np.testing.assert_array_equal(res.qd[0], np.zeros(6))
    # the recorded accelerations satisfy the equations of motion at the recorded states
    np.testing.assert_allclose(ur5e.inverse_dynamics(res.q, res.qd, res.qdd),
                               res.tau + res.delta, atol=1e-9)
    head, table = res.columns()
    assert table.shape == (K, len(head)) and head[0] == "t"


def test_output_dt_grid(ur5e):
    res = sd.simulate(ur5e, 0.5, Q0, None, method="DOP853", rtol=1e-10, atol=1e-12,
                      output_dt=0.05)
    np.testing.assert_allclose(res.t, np.linspace(0, 0.5, 11), atol=1e-12)
    full = sd.simulate(ur5e, 0.5, Q0, None, method="DOP853", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res.q[-1], full.q[-1], atol=1e-12)
    fixed = sd.simulate(ur5e, 0.1, Q0, None, method="rk4", dt=1e-3, output_dt=0.01)
    np.testing.assert_allclose(fixed.t, np.linspace(0, 0.1, 11), atol=1e-12)


def test_rk45_rejections_are_counted_exactly(ur5e):
    """RK45 spends 6 evaluations per attempted step (FSAL) plus 2 to start."""
    res = sd.simulate(ur5e, 0.5, Q0, None, method="RK45", rtol=1e-8, atol=1e-10)
    s = res.stats
    assert s.rejected > 0
    assert s.nfev == 2 + 6 * (s.steps + s.rejected)


def test_torque_forms_agree(ur5e):
    tau = np.array([5.0, -20.0, 8.0, 1.0, -0.5, 0.2])
    kw = dict(method="DOP853", rtol=1e-10, atol=1e-12)
    ref = sd.simulate(ur5e, 0.2, Q0, None, tau, **kw)
    for form in (np.tile(tau, (7, 1)), (np.array([0.0, 0.1, 0.3]), np.tile(tau, (3, 1))),
                 lambda t, q, qd: tau):
        res = sd.simulate(ur5e, 0.2, Q0, None, form, **kw)
        np.testing.assert_allclose(res.q[-1], ref.q[-1], atol=1e-10)
        np.testing.assert_allclose(res.tau, np.tile(tau, (res.t.size, 1)))
    # (K, n) samples are interpolated linearly over [0, duration]
    ramp = np.outer(np.linspace(0, 1, 11), tau)
    res = sd.simulate(ur5e, 0.2, Q0, None, ramp, output_dt=0.02, **kw)
    np.testing.assert_allclose(res.tau, np.outer(res.t / 0.2, tau), atol=1e-12)


def test_closed_loop_controller(ur5e):
    """A PD controller with gravity compensation, closed around the simulator, settles."""
    target = np.array([0.5, -1.2, 1.0, -1.4, -1.5, 0.3])
    Kp, Kd = np.array([400, 400, 300, 50, 50, 2.0]), np.array([40, 40, 30, 5, 5, 0.05])

    def pd(t, q, qd):
        return ur5e.gravity_torques(q) + Kp * (target - q) - Kd * qd

    for method, kw, balance in (("Radau", dict(rtol=1e-6), 1e-7),
                                ("rk4", dict(dt=1e-3), 3e-2),   # the wrist loop is fast
                                ("implicit_midpoint", dict(dt=2e-3), 3e-2)):
        res = sd.simulate(ur5e, 4.0, Q0, None, pd, method=method, **kw)
        assert np.max(np.abs(res.q[-1] - target)) < 1e-4, method
        assert np.max(np.abs(res.qd[-1])) < 1e-3, method
        # the controller takes out the energy it puts in: E(T) - E(0) = W_act
        assert abs(res.energy_balance_error[-1]) < balance * res.energy_scale(), method


@pytest.fixture(scope="module")
def swing_reference(ur5e):
    return sd.simulate(ur5e, 0.3, Q0, None, method="DOP853", rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("method,kw,bound", [
    ("DOP853", dict(rtol=1e-10, atol=1e-12), 1e-8),
    ("RK45", dict(rtol=1e-8, atol=1e-10), 1e-6),
    ("Radau", dict(rtol=1e-8, atol=1e-10), 1e-6),
    ("BDF", dict(rtol=1e-8, atol=1e-10), 1e-5),
    ("LSODA", dict(rtol=1e-8, atol=1e-10), 1e-5),
    ("semi_implicit_euler", dict(dt=1e-4), 5e-3),
    ("rk4", dict(dt=1e-3), 1e-7),
    ("implicit_midpoint", dict(dt=1e-3), 1e-4),
])
def test_every_method_reaches_the_reference(ur5e, swing_reference, method, kw, bound):
    res = sd.simulate(ur5e, 0.3, Q0, None, method=method, **kw)
    err = np.max(np.abs(np.r_[res.q[-1] - swing_reference.q[-1],
                              res.qd[-1] - swing_reference.qd[-1]]))
    assert err < bound, (method, err)
    if method in ("Radau", "BDF"):
        assert res.stats.njev >= 1


@pytest.mark.parametrize("method,order", [("semi_implicit_euler", 1), ("rk4", 4),
                                          ("implicit_midpoint", 2)])
def test_fixed_step_orders(ur5e, swing_reference, method, order):
    """Halving dt divides the final-state error by 2^order."""
    errs = []
    for dt in (4e-3, 2e-3, 1e-3):
        res = sd.simulate(ur5e, 0.3, Q0, None, method=method, dt=dt)
        errs.append(np.max(np.abs(res.q[-1] - swing_reference.q[-1])))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(rates - order) < 0.3), (method, errs, rates)


def test_fixed_step_integrator_matches_simulate(ur5e):
    tau = np.array([3.0, -10.0, 2.0, 0.5, 0.1, -0.1])
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=0.3)
    for method in FIXED_STEP:
        integ = FixedStepIntegrator(robot, method, 1e-3)
        q, qd = Q0.copy(), np.zeros(6)
        for _ in range(50):
            q, qd = integ.step(q, qd, tau)
        res = sd.simulate(robot, 0.05, Q0, None, tau, method=method, dt=1e-3)
        np.testing.assert_allclose(q, res.q[-1], atol=1e-13, err_msg=method)
        np.testing.assert_allclose(qd, res.qd[-1], atol=1e-12, err_msg=method)


def test_wrench_acts_as_jacobian_transpose_torques(ur5e):
    """A wrench on the tip equals the joint torques J(q)^T w."""
    w = np.array([5.0, -3.0, 10.0, 0.2, 0.1, -0.3])
    a = FixedStepIntegrator(ur5e, "semi_implicit_euler", 1e-3).step(Q0, np.zeros(6),
                                                                      np.zeros(6), w)
    b = FixedStepIntegrator(ur5e, "semi_implicit_euler", 1e-3).step(
        Q0, np.zeros(6), ur5e.jacobian(Q0).T @ w)
    np.testing.assert_allclose(a[1], b[1], atol=1e-12)
    for method in ("rk4", "implicit_midpoint", "DOP853"):
        a = sd.simulate(ur5e, 0.05, Q0, None, method=method, wrench=w)
        b = sd.simulate(ur5e, 0.05, Q0, None, lambda t, q, qd: ur5e.jacobian(q).T @ w,
                        method=method)
        np.testing.assert_allclose(a.q[-1], b.q[-1], atol=1e-12, err_msg=method)
        np.testing.assert_allclose(a.work_external, b.work_actuators, atol=1e-12)


def test_external_work_enters_the_energy_balance(ur5e):
    w = np.array([0.0, 20.0, 0.0, 0.0, 0.0, 1.0])
    res = sd.simulate(ur5e, 0.5, Q0, None, method="DOP853", rtol=1e-11, atol=1e-12, wrench=w)
    assert abs(res.work_external[-1]) > 1.0
    assert res.relative_energy_error() < 1e-8


def test_bad_arguments(ur5e):
    with pytest.raises(ValueError, match="unknown"):
        sd.simulate(ur5e, 1.0, method="euler")
    with pytest.raises(ValueError, match="dt"):
        sd.simulate(ur5e, 1.0, method="RK45", dt=1e-3)
    with pytest.raises(ValueError, match="rtol"):
        sd.simulate(ur5e, 1.0, method="rk4", rtol=1e-6)
    with pytest.raises(ValueError, match="q0 has 5 values"):
        sd.simulate(ur5e, 1.0, np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        sd.simulate(ur5e, 1.0, np.full(6, np.nan))
    with pytest.raises(ValueError, match="torque has shape"):
        sd.simulate(ur5e, 1.0, torque=np.zeros(4))
    with pytest.raises(ValueError, match="duration"):
        sd.simulate(ur5e, -1.0)
    with pytest.raises(ValueError, match="fixed-step method"):
        FixedStepIntegrator(ur5e, "DOP853")
    assert set(METHODS) == set(ADAPTIVE) | set(FIXED_STEP)


# ----------------------------------------------------------------------------- friction
@pytest.mark.parametrize("method", FIXED_STEP)
def test_stick_below_static_friction(method):
    """Applied torque below static friction: the joint never moves, no chattering."""
    robot = one_joint(friction=2.0)
    res = sd.simulate(robot, 1.0, None, None, [1.9], method=method, dt=1e-3)
    assert np.max(np.abs(res.qd)) < 1e-6
    assert np.all(res.qd == 0.0) and np.all(res.q == 0.0)
    np.testing.assert_allclose(res.delta[:, 0], -1.9)        # friction holds the torque
    assert res.energy_dissipated[-1] == 0.0


@pytest.mark.parametrize("method", FIXED_STEP)
def test_slip_above_static_friction(method):
    """Above static friction the joint accelerates with the net torque tau - tau_c."""
    robot = one_joint(friction=2.0)
    inertia = robot.mass_matrix(np.zeros(1))[0, 0]
    res = sd.simulate(robot, 1.0, None, None, [3.0], method=method, dt=1e-3)
    a = (3.0 - 2.0) / inertia
    np.testing.assert_allclose(res.qd[:, 0], a * res.t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res.q[-1, 0], 0.5 * a, rtol=2e-3 if method in
                               FIRST_ORDER else 1e-10)
    np.testing.assert_allclose(res.delta[1:, 0], -2.0)


@pytest.mark.parametrize("method", FIXED_STEP)
def test_stribeck_breakaway(method):
    """tau_c = 1, eps = 0.5: 1.4 N m sticks (static 1.5); 1.6 N m breaks away and then
    slides against tau_c + eps e^(-gamma |qd|), which fades toward tau_c."""
    from scipy.integrate import solve_ivp
    robot = one_joint(friction=1.0)
    robot.dissipation = robot.dissipation.override(stribeck=0.5, stribeck_rate=20.0)
    inertia = robot.mass_matrix(np.zeros(1))[0, 0]
    stuck = sd.simulate(robot, 0.5, None, None, [1.4], method=method, dt=1e-3)
    # held by static friction: at rest, exactly, with the friction torque that balances
    # the applied one (-1.4 N m, within tau_c + eps = 1.5; breaking away on tau_c = 1
    # alone would record the kinetic friction -1.5 and qdd = -0.1 / I = -3.3 rad/s^2)
    assert np.all(stuck.qd == 0.0) and np.all(stuck.q == 0.0)
    np.testing.assert_array_equal(stuck.qdd, 0.0)
    np.testing.assert_allclose(stuck.delta[:, 0], -1.4, rtol=0, atol=1e-12)
    assert stuck.energy_dissipated[-1] == 0.0
    res = sd.simulate(robot, 0.5, None, None, [1.6], method=method, dt=1e-4)
    ref = solve_ivp(lambda t, v: (1.6 - 1.0 - 0.5 * np.exp(-20 * v)) / inertia, (0, 0.5), [0.0],
                    rtol=1e-12, atol=1e-14)
    tol = 2e-3 if method in FIRST_ORDER else 1e-6
    np.testing.assert_allclose(res.qd[-1, 0], ref.y[0, -1], rtol=tol)


@pytest.mark.parametrize("method", FIXED_STEP)
def test_stribeck_holds_a_reaction_between_coulomb_and_static_friction(method):
    """Two joints about z (no gravity torque): joint 1 has tau_c = 1, eps = 0.6 (static
    friction 1.6 N m), joint 2 none and is driven by 0.5 sin(6 t). With joint 1 held,
    joint 2 is a lone rod on its axis, and the torque that holds joint 1 (the reaction
    M_12 qdd_2 + b_1) reaches 1.44 N m: above tau_c, within the static friction. So joint 1
    never moves and joint 2 moves exactly as the one-joint model of its rod."""
    two = sd.load_urdf(chain_urdf(2, axes=("z", "z"), masses=(2.0, 1.0)))
    two.dissipation = two.dissipation.override(coulomb=[1.0, 0.0], stribeck=[0.6, 0.0],
                                               stribeck_rate=[20.0, 0.0])
    one = sd.load_urdf(chain_urdf(1, axes=("z",), masses=(1.0,)))     # link 2 alone

    def drive(t, q, qd):
        return np.array([0.0, 0.5 * np.sin(6 * t)])

    res = sd.simulate(two, 1.0, None, None, drive, method=method, dt=1e-3)
    ref = sd.simulate(one, 1.0, None, None, lambda t, q, qd: drive(t, q, qd)[1:],
                      method=method, dt=1e-3)
    assert np.all(res.q[:, 0] == 0.0) and np.all(res.qd[:, 0] == 0.0)
    np.testing.assert_array_equal(res.qdd[:, 0], 0.0)
    # joint 2 as with joint 1 locked (same steps on the same one-joint ODE: to round-off)
    np.testing.assert_allclose(res.q[:, 1], ref.q[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(res.qd[:, 1], ref.qd[:, 0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(res.qdd[:, 1], ref.qdd[:, 0], rtol=0, atol=1e-9)
    assert res.q[-1, 1] > 2.5                                   # it did move (2.9 rad)
    # the holding torque, in closed form for two rods of 0.3 m on parallel axes (joint 1
    # at rest): h_1 = M_12 qdd_2 + b_1, M_12 = I_2 + m_2 l_1 (l_2 / 2) cos q_2,
    # b_1 = -m_2 l_1 (l_2 / 2) sin q_2 qd_2^2, I_2 = m_2 (3 r^2 + l_2^2) / 12 + m_2 l_2^2 / 4
    q2, qd2, qdd2 = ref.q[:, 0], ref.qd[:, 0], ref.qdd[:, 0]
    I2, c = (3 * 0.02**2 + 0.3**2) / 12 + 0.3**2 / 4, 0.3 * 0.15
    h1 = (I2 + c * np.cos(q2)) * qdd2 - c * np.sin(q2) * qd2**2
    np.testing.assert_allclose(res.delta[:, 0], h1, rtol=0, atol=1e-9)
    assert 1.0 < np.max(np.abs(h1)) < 1.6                    # between tau_c and tau_c + eps
    assert np.sum(np.abs(h1) > 1.0) > 50
    np.testing.assert_array_equal(res.delta[:, 1], 0.0)


@pytest.mark.parametrize("method", FIXED_STEP)
def test_sliding_joint_stops_and_stays(method):
    """From 1 rad/s with no torque, Coulomb friction stops the joint at t = I qd0 / tau_c
    (within a step) and it then stays at exactly zero speed."""
    robot = one_joint(friction=0.5)
    inertia = robot.mass_matrix(np.zeros(1))[0, 0]
    dt = 1e-3
    res = sd.simulate(robot, 0.5, None, [1.0], method=method, dt=dt)
    t_stop = inertia * 1.0 / 0.5
    moving = res.t[res.qd[:, 0] != 0.0]
    assert t_stop - dt <= moving.max() <= t_stop + dt
    assert np.all(res.qd[res.t > t_stop + dt, 0] == 0.0)
    assert np.all(res.qd[:, 0] >= 0.0)                      # never reverses
    rtol = 3e-2 if method in FIRST_ORDER else 5e-3    # first order: dt / t_stop
    np.testing.assert_allclose(res.q[-1, 0], 0.5 * inertia / 0.5, rtol=rtol)
    # all the kinetic energy went into friction
    np.testing.assert_allclose(res.energy_dissipated[-1], 0.5 * inertia, rtol=rtol)


def test_ramp_breaks_away_on_time():
    """tau(t) = 4 t against static friction 2: the joint starts moving at t = 0.5 s."""
    robot = one_joint(friction=2.0)
    for method in FIXED_STEP:
        res = sd.simulate(robot, 1.0, None, None, lambda t, q, qd: [4.0 * t], method=method,
                          dt=1e-3)
        first = res.t[np.flatnonzero(res.qd[:, 0] > 0)[0]]
        assert 0.5 <= first <= 0.5 + 2e-3, (method, first)


def test_pendulum_held_by_friction():
    """A rod on a horizontal axis: friction above its gravity torque holds it."""
    robot = one_joint(friction=0.0, axis="y")
    g_torque = abs(robot.gravity_torques(np.array([0.3]))[0])
    for tau_s, moves in ((1.05 * g_torque, False), (0.95 * g_torque, True)):
        robot.dissipation = robot.dissipation.override(coulomb=tau_s)
        res = sd.simulate(robot, 0.5, [0.3], None, method="semi_implicit_euler", dt=1e-3)
        assert bool(np.any(res.qd != 0.0)) == moves


@pytest.mark.parametrize("method", FIXED_STEP)
def test_stuck_joint_holds_the_reaction(method):
    """Two joints about z: joint 1 with static friction 5 N m stays stuck while joint 2 is
    driven; the friction torque on joint 1 is what inverse dynamics says holds it."""
    robot = sd.load_urdf(chain_urdf(2, axes=("z", "z"), masses=(2.0, 1.0)))
    robot.dissipation = robot.dissipation.override(coulomb=[5.0, 0.0])

    def drive(t, q, qd):
        return np.array([0.0, 0.8 * np.sin(6 * t)])

    res = sd.simulate(robot, 1.0, None, None, drive, method=method, dt=1e-3)
    assert np.all(res.qd[:, 0] == 0.0) and np.all(res.q[:, 0] == 0.0)
    assert np.max(np.abs(res.qd[:, 1])) > 0.5
    np.testing.assert_array_equal(res.qdd[:, 0], 0.0)
    held = robot.inverse_dynamics(res.q, res.qd, res.qdd) - res.tau
    np.testing.assert_allclose(res.delta, held, atol=1e-10)
    assert 0.1 < np.max(np.abs(res.delta[:, 0])) <= 5.0


def test_adaptive_methods_regularize_coulomb():
    """Adaptive methods use delta = -tau_s tanh(qd / v_eps): below breakaway the joint
    creeps at v_eps atanh(tau / tau_s); above, it accelerates with tau - tau_c."""
    robot = one_joint(friction=2.0)
    inertia = robot.mass_matrix(np.zeros(1))[0, 0]
    v_eps = 1e-3
    for method in ("Radau", "LSODA"):
        res = sd.simulate(robot, 0.5, None, None, [1.0], method=method, rtol=1e-8, atol=1e-12,
                          friction_smoothing=v_eps)
        np.testing.assert_allclose(res.qd[-1, 0], v_eps * np.arctanh(0.5), rtol=1e-4)
        res = sd.simulate(robot, 0.5, None, None, [3.0], method=method, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(res.qd[-1, 0], 1.0 / inertia * 0.5, rtol=1e-3)


# ----------------------------------------------------------------------------- divergence
def test_explicit_step_too_large_on_stiff_chain_raises():
    robot = sd.load_urdf(stiff_chain_urdf())
    q0 = np.array([0.3, 0.8, -0.5, 0.6])
    with pytest.raises(SimulationError) as info:
        sd.simulate(robot, 0.5, q0, method="semi_implicit_euler", dt=1e-3)
    err = info.value
    assert 0 < err.t < 0.5 and err.joint in robot.joint_names and err.reason == "speed"
    msg = str(err)
    assert f"t = {err.t:.6g} s" in msg and repr(err.joint) in msg
    assert "smaller step" in msg and "implicit_midpoint" in msg
    with pytest.raises(SimulationError):   # the real-time integrator reports it too
        integ = FixedStepIntegrator(robot, "semi_implicit_euler", 1e-3)
        q, qd = q0, np.zeros(4)
        for _ in range(500):
            q, qd = integ.step(q, qd, np.zeros(4))


def test_nan_from_the_controller_raises(ur5e):
    def bad(t, q, qd):
        return np.array([0, 0, np.nan if t > 0.1 else 0.0, 0, 0, 0])
    for method in ("DOP853", "rk4"):
        with pytest.raises(SimulationError, match="elbow_joint") as info:
            sd.simulate(ur5e, 0.3, Q0, None, bad, method=method)
        assert info.value.t > 0.1 and info.value.reason == "input"


def test_energy_growth_without_input_raises():
    """Semi-implicit Euler with viscous damping beyond its stability limit (beta dt / I =
    2.1) multiplies the speed by -1.1 a step: caught as energy growth long before the speed
    bound."""
    probe = one_joint()
    inertia = probe.mass_matrix(np.zeros(1))[0, 0]
    dt = 1e-3
    robot = one_joint(damping=2.1 * inertia / dt)
    with pytest.raises(SimulationError, match="energy grew") as info:
        sd.simulate(robot, 1.0, None, [1.0], method="semi_implicit_euler", dt=dt)
    assert info.value.reason == "energy" and info.value.t < 0.1
    assert "implicit_midpoint" in str(info.value)
    # the implicit method is stable there and loses energy as it should
    res = sd.simulate(robot, 0.2, None, [1.0], method="implicit_midpoint", dt=dt)
    assert res.energy[-1] < res.energy[0]


# ----------------------------------------------------------------------------- progress, CLI
def test_progress_callback(ur5e):
    seen = []
    sd.simulate(ur5e, 0.2, Q0, method="rk4", progress=seen.append)
    sd.simulate(ur5e, 0.2, Q0, method="RK45", progress=seen.append)
    assert seen and all(0 < f <= 1 + 1e-12 for f in seen) and seen[-1] == pytest.approx(1)


def test_cli_simulate(tmp_path, capsys):
    from serial_dynamics.cli import main
    png, csv = tmp_path / "run.png", tmp_path / "run.csv"
    assert main(["simulate", "--duration", "0.2", "--q0", "0.3,-1,0.8,-0.5,0.4,0.2",
                 "--plot", str(png), "--csv", str(csv), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "energy: E(0)" in out and "RHS" not in out and "right-hand-side" in out
    assert png.stat().st_size > 20000
    data = np.genfromtxt(csv, delimiter=",", names=True)
    assert data["t"][-1] == pytest.approx(0.2) and data.size == 201   # every 1 ms (T / 200)
    np.testing.assert_allclose(data["energy"], data["kinetic"] + data["potential"])
    assert abs(data["energy"][-1] - data["energy"][0]) < 1e-4
    assert main(["simulate", "--method", "rk4", "--rtol", "1e-6", "--quiet"]) == 2
    assert main(["simulate", "--q0", "1,2", "--quiet"]) == 2
    stiff = tmp_path / "stiff.urdf"
    stiff.write_text(stiff_chain_urdf())
    assert main(["simulate", str(stiff), "--q0", "0.3,0.8,-0.5,0.6", "--method",
                 "semi_implicit_euler", "--quiet"]) == 3
    assert "implicit_midpoint" in capsys.readouterr().err


def test_compiled_loop_equals_step_by_step(ur5e):
    """semi_implicit_euler with torques known in advance runs one compiled loop; it must
    give the same motion, torques and work as the step-by-step integrator (reference
    backend), to round-off."""
    robot = sd.Robot(ur5e.model, ur5e.dissipation.override(viscous=0.05))
    reference = sd.Robot(robot.model, robot.dissipation, backend="numpy")
    samples = np.outer(np.cos(np.linspace(0, 3, 5)), np.linspace(1, 3, 6))   # (K, n) over [0, T]
    kw = dict(method="semi_implicit_euler", dt=1e-3, output_dt=0.01)
    fast = sd.simulate(robot, 0.5, Q0, None, samples, **kw)
    slow = sd.simulate(reference, 0.5, Q0, None, samples, **kw)
    assert "compiled" in fast.stats.message and "compiled" not in slow.stats.message
    np.testing.assert_allclose(fast.t, slow.t, rtol=0, atol=1e-15)
    for name in ("q", "qd", "qdd", "tau", "delta", "work_actuators", "work_dissipation"):
        a, b = getattr(fast, name), getattr(slow, name)
        assert np.max(np.abs(a - b)) <= 1e-9 * max(1.0, np.max(np.abs(b))), name


def test_offline_demo_conserves_energy(capsys):
    """The demo without rclpy: a 1 s free swing of the UR5e; its energy must be conserved."""
    import argparse
    import re

    from serial_dynamics import cli
    assert cli.cmd_offline_demo(argparse.Namespace(urdf=None, base_link=None, tip_link=None)) == 0
    drift = float(re.search(r"energy drift over the swing: (\S+) J", capsys.readouterr().out)[1])
    assert drift < 1e-7
