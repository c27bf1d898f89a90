"""Simulation on a group in the robot's chart (sim/group.py): a floating base's conservation
laws in zero gravity, unit quaternions, the node's integrator, refused options; and the same
steps on R^n (a fixed base's Euclidean chart) against sim/'s own integrators."""
import re

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.group import GroupStepIntegrator, run_on_group


@pytest.fixture(scope="module")
def satellite():
    return sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))


def pd_torque(robot):
    """A PD controller sweeping the joints (0.8 rad, 0.5 rad/s): the arm driven."""
    D = np.diag(robot.mass_matrix(robot.neutral()))[6:]

    def torque(t, q, v):
        return 4.0 * D * (0.8 * np.sin(0.5 * t + np.arange(robot.dof)) - q[7:]) - 2.8 * D * v[6:]
    return torque


def drift(x):
    return np.max(np.abs(x - x[0])) / np.max(np.abs(x[0]))


def test_a_driven_arm_keeps_the_total_momentum(satellite):
    v0 = np.r_[0.01, 0.0, -0.02, 0.01, -0.02, 0.015, np.full(7, 0.1)]
    res = sd.simulate(satellite, 10.0, satellite.neutral(), v0, torque=pd_torque(satellite),
                      method="DOP853", rtol=1e-12, atol=1e-12, dissipation=False)
    assert res.q.shape[1] == satellite.nq and res.qd.shape[1] == satellite.nv
    assert res.tau.shape[1] == satellite.dof and np.ptp(res.q[:, 7]) > 1.0   # it swept
    assert drift(satellite.centroidal_momentum(res.q, res.qd)) <= 1e-9
    assert np.max(np.abs(np.linalg.norm(res.q[:, 3:7], axis=1) - 1.0)) <= 1e-15
    assert res.relative_energy_error() <= 1e-9                   # E - E0 = work of the motors
    head, table = res.columns()
    assert len(head) == table.shape[1] and head[1:9] == ["q_base_x", "q_base_y", "q_base_z",
                                                         "q_base_qx", "q_base_qy", "q_base_qz",
                                                         "q_base_qw", "q_joint1"]
    assert head[1 + satellite.nq:1 + satellite.nq + 7] == ["qd_base_vx", "qd_base_vy",
                                                          "qd_base_vz", "qd_base_wx",
                                                          "qd_base_wy", "qd_base_wz",
                                                          "qd_joint1"]
    import matplotlib
    matplotlib.use("Agg")
    lines = res.plot(title="satellite").axes[0].lines          # the joints, not the pose
    assert [ln.get_label() for ln in lines] == satellite.joint_names
    np.testing.assert_array_equal(lines[0].get_ydata(), res.q[:, 7])


def test_a_free_tumble_keeps_kinetic_energy_and_momentum_across_charts(satellite):
    v0 = np.r_[0.1, -0.2, 0.05, 0.3, -0.5, 0.8, np.linspace(-0.5, 0.5, 7)]
    res = sd.simulate(satellite, 10.0, satellite.neutral(), v0, method="DOP853", rtol=1e-12,
                      atol=1e-12, dissipation=False)
    assert "charts of SE(3)" in res.stats.message and int(res.stats.message.split()[1]) >= 5
    assert drift(res.kinetic) <= 1e-9
    assert drift(satellite.centroidal_momentum(res.q, res.qd)) <= 1e-9


def test_the_fixed_step_methods_and_the_node_integrator(satellite):
    v0 = np.r_[np.zeros(3), 0.3, -0.5, 0.8, np.full(7, 0.2)]
    tau = 0.5 * np.diag(satellite.mass_matrix(satellite.neutral()))[6:] * np.linspace(1.0, -1.0, 7)
    for method, dt, tol in (("rk4", 1e-2, 1e-5), ("semi_implicit_euler", 1e-3, 1e-2)):
        res = sd.simulate(satellite, 2.0, satellite.neutral(), v0, torque=tau, method=method,
                          dt=dt, dissipation=False)
        assert drift(satellite.centroidal_momentum(res.q, res.qd)) <= tol
        assert np.max(np.abs(np.linalg.norm(res.q[:, 3:7], axis=1) - 1.0)) <= 1e-15
        integ = FixedStepIntegrator(satellite, method, dt, dissipation=False)
        q, v = satellite.neutral(), v0
        for k in range(3):
            q, v = integ.step(q, v, tau)
            np.testing.assert_array_equal(q, res.q[k + 1])
            np.testing.assert_array_equal(v, res.qd[k + 1])


def test_what_a_floating_base_cannot_simulate_is_named(satellite):
    with pytest.raises(ValueError, match="base_motion is not available for a floating base"):
        sd.simulate(satellite, 1.0, base_motion=sd.BaseMotion((0, 0, 1.0)))
    with pytest.raises(ValueError, match=r"q0 has 7 values; give the base's pose"):
        sd.simulate(satellite, 1.0, np.zeros(7))
    with pytest.raises(ValueError, match="quaternion .* zero length"):
        sd.simulate(satellite, 1.0, np.zeros(satellite.nq))



def test_the_joint_servo_on_a_floating_base(satellite):
    """The implicit joint servo of semi-implicit Euler on a free-floating base (servo.py with
    the whole M). Stiff gains (Kp = 1e6, Kd = 1e4 at dt = 1 ms), where an explicit PD
    diverges at its first step, hold the joints at their targets; the torque reported is
    Kp (q* - q1) - Kd qd1 at the step's end, as servo.py defines it. The servo is
    internal: the total momentum stays zero to the method's first-order error (measured: 0.18 %
    of the arm's peak momentum after 1 s at dt = 1 ms, half that at 0.5 ms)."""
    from serial_dynamics.sim.servo import servo
    n = satellite.dof
    target = np.linspace(0.6, -0.6, n)
    explicit = FixedStepIntegrator(satellite, "semi_implicit_euler", 1e-3, dissipation=False)
    with pytest.raises(sd.SimulationError, match="diverged at t = 0.001 s"):
        explicit.step(satellite.neutral(), np.zeros(satellite.nv),
                      1e6 * (target - satellite.neutral()[7:]))

    def run(kp, kd, dt, seconds):
        integ = FixedStepIntegrator(satellite, "semi_implicit_euler", dt, dissipation=False)
        s, q, v, peak = servo(kp, kd, target, None, n), satellite.neutral(), np.zeros(13), 0.0
        for k in range(int(round(seconds / dt))):
            q1, v1 = integ.step(q, v, np.zeros(n), servo=s)
            if k == 0:
                np.testing.assert_allclose(integ.servo_torque,
                                           kp * (target - q1[7:]) - kd * v1[6:], rtol=1e-12)
            q, v = q1, v1
            if k % 10 == 0:                                   # the arm's own momentum
                arm = satellite.centroidal_momentum(q, np.r_[np.zeros(6), v[6:]])
                peak = max(peak, np.max(np.abs(arm)))
        assert abs(np.linalg.norm(q[3:7]) - 1.0) <= 1e-15
        return q, np.max(np.abs(satellite.centroidal_momentum(q, v))) / peak

    q, _ = run(1e6, 1e4, 1e-3, 0.5)
    np.testing.assert_allclose(q[7:], target, atol=1e-6)
    _, h1 = run(1e4, 200.0, 1e-3, 1.0)
    _, h2 = run(1e4, 200.0, 5e-4, 1.0)
    assert h1 <= 3e-3 and 1.7 <= h1 / h2 <= 2.3               # first order in dt
    with pytest.raises(ValueError, match=r"servo is integrated implicitly by \('semi_implic"):
        FixedStepIntegrator(satellite, "rk4", 1e-3).step(q, np.zeros(13), np.zeros(n),
                                                         servo=servo(1.0, 1.0, target, None, n))


def test_hard_stops_on_a_floating_base():
    """position_limits on a free-floating base: the UR5e's elbow driven into its stop (2 pi)
    in zero gravity. The plastic impact's impulse acts on the joints only, so the base's
    generalized momentum M[:6] v is kept through it (to round-off) while the elbow stops;
    in a run the elbow never passes its limit and RK4's energy balance closes with the
    stops' work counted as dissipated (measured 5e-9)."""
    from serial_dynamics.sim.stops import JointStops
    robot = sd.load_urdf(sd.builtin_path(), gravity=(0, 0, 0), floating_base=True)
    integ = FixedStepIntegrator(robot, "rk4", 1e-3, dissipation=False, position_limits=True)
    assert isinstance(integ.stops, JointStops)
    q, v = robot.random_state(4)
    q[9], v[8] = robot.upper[2] + 1e-6, 2.0                  # the elbow past its stop, outward
    q1, v1, dE = integ.stops.impact(q, v, True)
    assert q1[9] == robot.upper[2] and v1[8] == 0.0 and dE < 0.0
    np.testing.assert_array_equal(q1[:9], q[:9])
    M = robot.mass_matrix(q1)
    np.testing.assert_allclose(M[:6] @ v1, M[:6] @ v, rtol=0, atol=1e-12 * np.abs(M[:6] @ v).max())
    q0 = robot.neutral()
    q0[9] = 6.0
    res = sd.simulate(robot, 0.5, q0, None, torque=[0, 0, 5.0, 0, 0, 0], method="rk4", dt=1e-3,
                      position_limits=True, dissipation=False)
    assert res.q[:, 9].max() == robot.upper[2] and "reached a stop" in res.stats.message
    assert res.relative_energy_error() <= 1e-7
    with pytest.raises(ValueError, match="position_limits needs a fixed-step method"):
        sd.simulate(robot, 0.1, q0, method="DOP853", position_limits=True)


def test_the_implicit_midpoint_rule_on_a_floating_base(satellite):
    """implicit_midpoint in the chart at each step's start: a free tumble of 2 s against
    DOP853 at 1e-12, second order (the end pose's error quarters as dt halves: measured
    5.6e-4, 1.4e-4 rad), its kinetic energy kept to 1.1e-6 at 20 ms; the node's integrator
    takes the same steps."""
    v0 = np.r_[0.1, -0.2, 0.05, 0.3, -0.5, 0.8, np.linspace(-0.5, 0.5, 7)]
    ref = sd.simulate(satellite, 2.0, satellite.neutral(), v0, method="DOP853", rtol=1e-12,
                      atol=1e-12, dissipation=False)
    err = []
    for dt in (0.02, 0.01):
        res = sd.simulate(satellite, 2.0, satellite.neutral(), v0, method="implicit_midpoint",
                          dt=dt, dissipation=False)
        err.append(np.max(np.abs(res.q[-1] - ref.q[-1])))
        assert drift(res.kinetic) <= 2e-6 and res.relative_energy_error() <= 2e-6
        assert np.max(np.abs(np.linalg.norm(res.q[:, 3:7], axis=1) - 1.0)) <= 1e-15
    assert 3.5 <= err[0] / err[1] <= 4.5 and err[1] < 2e-4
    integ = FixedStepIntegrator(satellite, "implicit_midpoint", 0.01, dissipation=False)
    q, v = satellite.neutral(), v0
    for k in range(2):
        q, v = integ.step(q, v, np.zeros(satellite.dof))
        np.testing.assert_array_equal(q, res.q[k + 1])
        np.testing.assert_array_equal(v, res.qd[k + 1])


def test_symplectic_euler_on_a_floating_base(satellite):
    """symplectic_euler in momentum form in the chart at each step's start: first order
    against DOP853 (the end pose's error halves with dt: measured 0.61, 0.30 rad on the
    satellite's light, whipping wrist), the world's linear momentum kept to round-off under
    joint torques (the chart's translation is a symmetry of the discrete Lagrangian), the
    energy balance first order, and the node's integrator the same bits. (Over 10 s at 2 ms
    its energy error stays in its band, 1.3e-4 in the first and the last second, where
    semi-implicit Euler's grows from 3.6e-4 to 2.0e-3: measured, not run here.)"""
    from serial_dynamics.algorithms.floating import quaternion_matrix
    v0 = np.r_[0.1, -0.2, 0.05, 0.3, -0.5, 0.8, np.linspace(-0.5, 0.5, 7)]
    tau = 0.5 * np.diag(satellite.mass_matrix(satellite.neutral()))[6:] * np.linspace(1, -1, 7)
    ref = sd.simulate(satellite, 0.4, satellite.neutral(), v0, torque=tau, method="DOP853",
                      rtol=1e-12, atol=1e-12, dissipation=False)
    err, balance = [], []
    for dt in (0.004, 0.002):
        res = sd.simulate(satellite, 0.4, satellite.neutral(), v0, torque=tau,
                          method="symplectic_euler", dt=dt, dissipation=False)
        err.append(np.max(np.abs(res.q[-1] - ref.q[-1])))
        balance.append(res.relative_energy_error())
        P = np.array([quaternion_matrix(q[None, 3:7])[0] @ (satellite.mass_matrix(q) @ v)[:3]
                      for q, v in zip(res.q, res.qd)])
        np.testing.assert_allclose(P, np.broadcast_to(P[0], P.shape), rtol=0, atol=1e-11)
    assert 1.7 <= err[0] / err[1] <= 2.3 and 1.7 <= balance[0] / balance[1] <= 2.5
    integ = FixedStepIntegrator(satellite, "symplectic_euler", 0.002, dissipation=False)
    q, v = satellite.neutral(), v0
    for k in range(2):
        q, v = integ.step(q, v, tau)
        np.testing.assert_array_equal(q, res.q[k + 1])
        np.testing.assert_array_equal(v, res.qd[k + 1])


def test_a_diverging_symplectic_step_is_a_simulation_error():
    """A step too long for the fixed point (10 ms on the satellite in gravity, driven): the
    run stops with SimulationError naming the fixed point, the time and advice, not a NaN
    error. Its iterates either overflow ("diverged") or wander without converging; which
    one depends on the last bits of the LAPACK solves (measured: overflow on the machines
    of earlier runs and here with ``OPENBLAS_CORETYPE=SkylakeX``; 50 iterations without
    convergence with the kernels OpenBLAS picks on an AMD EPYC of family 26, Zen 5), so
    both are accepted."""
    sat = sd.load_urdf(satellite_urdf())
    v0 = np.r_[0.1, -0.2, 0.05, 0.3, -0.5, 0.8, np.linspace(-0.5, 0.5, 7)]
    with np.errstate(all="ignore"), pytest.raises(sd.SimulationError) as err:
        sd.simulate(sat, 1.0, sat.neutral(), v0, torque=np.linspace(1.0, -1.0, 7),
                    method="symplectic_euler", dt=1e-2)
    assert re.search(r"fixed-point iteration (diverged|did not converge within 50 "
                     r"iterations) at t = \S+ s\. Try a smaller step", str(err.value)), err.value


def test_a_floating_base_with_mimic_joints_by_every_fixed_step_method():
    """A floating base with a mimic joint (q = [pose; independent joints]) in zero gravity:
    dT/dq (what symplectic Euler reads) against central differences along q's tangent,
    and every fixed-step method on the reduced coordinates: symplectic Euler keeps the
    world's linear momentum to round-off, the others to their order (0.3 s at 1 ms,
    measured: semi-implicit Euler 5.5e-4, RK4 1.6e-13, the implicit midpoint rule 6.8e-8
    relative); the energy balance closes to each method's error (largest: semi-implicit
    Euler's 2.9e-4)."""
    from serial_dynamics.builtin.synthetic import mimic_chain_urdf
    robot = sd.load_urdf(mimic_chain_urdf(4, follower=2), floating_base=True, gravity=(0, 0, 0))
    assert robot.is_floating and robot.model.has_mimic_joints and robot.nv == robot.dof + 6
    q, v = robot.random_state(3)
    grad, h = robot.kinetic_energy_gradient(q, v), 1e-6
    for k, e in enumerate(np.eye(robot.nv)):
        num = (robot.kinetic_energy(robot.integrate(q, e, h), v)
               - robot.kinetic_energy(robot.integrate(q, e, -h), v)) / (2 * h)
        assert abs(grad[k] - num) <= 1e-7 * max(1.0, abs(num)), k
    assert not grad[:6].any() and np.abs(grad[6:]).max() > 1e-3
    for method, tol in (("symplectic_euler", 1e-12), ("semi_implicit_euler", 2e-3),
                        ("rk4", 1e-11), ("implicit_midpoint", 3e-7)):
        res = sd.simulate(robot, 0.3, q, v, method=method, dt=1e-3, dissipation=False)
        linear = robot.centroidal_momentum(res.q, res.qd)[:, :3]
        assert drift(linear) <= tol, method
        assert res.relative_energy_error() <= 1e-3, method


def test_the_group_steps_ask_only_the_chart():
    """sim/group.py on a fixed-base arm, whose chart is R^n (q = phi, C = 1): nothing in it
    asks what the chart is, so its steps are those of sim/'s integrators for R^n. RK4 and
    semi-implicit Euler take the same operations (the same bits after 200 steps);
    symplectic Euler (momentum form, a fixed point) and the implicit midpoint rule (Newton
    with differences against the analytical Jacobian) agree to their tolerances; DOP853 in
    one chart agrees with sim/adaptive.py to its tolerance."""
    ur5e = sd.default_robot()
    assert isinstance(FixedStepIntegrator(ur5e), FixedStepIntegrator)
    assert isinstance(FixedStepIntegrator(sd.load_urdf(satellite_urdf())), GroupStepIntegrator)
    q0, v0 = ur5e.random_state(3)
    tau = ur5e.gravity_torques(q0) + np.linspace(-0.2, 0.2, 6)
    for method, steps, tol in (("rk4", 200, 0.0), ("semi_implicit_euler", 200, 0.0),
                               ("symplectic_euler", 200, 1e-10), ("implicit_midpoint", 20, 1e-8)):
        a = FixedStepIntegrator(ur5e, method, 1e-3, dissipation=False)
        b = GroupStepIntegrator(ur5e, method, 1e-3, dissipation=False)
        qa, va, qb, vb = q0, v0, q0, v0
        for _ in range(steps):
            qa, va = a.step(qa, va, tau)
            qb, vb = b.step(qb, vb, tau)
        assert np.max(np.abs(np.r_[qa - qb, va - vb])) <= tol, method
    ref = sd.simulate(ur5e, 0.5, q0, v0, torque=tau, method="DOP853", rtol=1e-11, atol=1e-11,
                      dissipation=False)
    res = run_on_group(ur5e, 0.5, q0, v0, ref_inputs(tau), "DOP853", rtol=1e-11, atol=1e-11,
                       dt=None, max_step=np.inf, first_step=None, dissipation=False,
                       output_dt=None, check_energy=False, bar=lambda t: None)
    assert res.stats.message == "ok; 1 chart of R^n"
    np.testing.assert_allclose(res.q[-1], ref.q[-1], atol=1e-8)
    np.testing.assert_allclose(res.qd[-1], ref.qd[-1], atol=1e-8)


def ref_inputs(tau):
    from serial_dynamics.sim.equations import Inputs
    return Inputs(lambda t, q, qd: tau, None, None, False)
