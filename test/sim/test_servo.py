"""The implicit joint PD servo of ``FixedStepIntegrator.step(..., servo=...)``
(``sim/servo.py``).

Oracles: the linear recurrence of backward-Euler PD on a one-joint rotor (M constant, no
gravity), written out by hand here; the closed-form damped oscillator it converges to as
dt -> 0; the identity tau_s = Kp (q* - q1) + Kd (qd* - qd1) at the end of the step; the
same step with tau_s applied as a plain torque (the torque reported is the one applied);
an explicit PD at the same gains, which diverges.
"""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin import builtin_robot
from serial_dynamics.sim.fixed_step import SERVO_METHODS, FixedStepIntegrator
from serial_dynamics.sim.methods import SimulationError
from serial_dynamics.sim.servo import servo

IZZ = 0.5   # kg m^2: the rotor's inertia about its axis
ROTOR = ('<robot name="rotor"><link name="base"/><link name="disc"><inertial><mass value="2"/>'
         f'<inertia ixx="0.3" iyy="0.3" izz="{IZZ}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
         '<joint name="j" type="continuous"><parent link="base"/><child link="disc"/>'
         '<axis xyz="0 0 1"/></joint></robot>')
Q_TARGET = np.array([0.3, -1.0, 1.2, -0.5, 0.4, 0.2])


@pytest.fixture(scope="module")
def ur5e():
    return builtin_robot("ur5e")


@pytest.mark.parametrize("method", SERVO_METHODS)
def test_rotor_follows_the_backward_euler_recurrence(method):
    """One joint, M = IZZ, no gravity torque: each step must be the linear recurrence
    (M + dt Kd + dt^2 Kp) qd1 = M qd0 + dt (tau + Kp (q* - q0) + Kd qd*), q1 = q0 + dt qd1."""
    robot = sd.load_urdf(ROTOR)
    kp, kd, dt, tau, qt = 400.0, 3.0, 0.01, 0.7, 1.0
    integ = FixedStepIntegrator(robot, method, dt, False)
    s = servo(kp, kd, [qt])
    q, qd, qr, vr = np.zeros(1), np.zeros(1), 0.0, 0.0
    for _ in range(200):
        q, qd = integ.step(q, qd, np.array([tau]), servo=s)
        vr = (IZZ * vr + dt * (tau + kp * (qt - qr))) / (IZZ + dt * kd + dt * dt * kp)
        qr = qr + dt * vr
        assert q[0] == pytest.approx(qr, abs=1e-12)
        assert qd[0] == pytest.approx(vr, abs=1e-11)
    assert q[0] == pytest.approx(qt + tau / kp, abs=1e-4)        # the static offset tau / Kp


def test_rotor_converges_to_the_damped_oscillator():
    """As dt -> 0 the servo is the continuous PD: IZZ q'' + Kd q' + Kp (q - q*) = 0."""
    robot = sd.load_urdf(ROTOR)
    kp, kd, qt, dt, T = 200.0, 4.0, 0.5, 1e-4, 0.3
    integ = FixedStepIntegrator(robot, "semi_implicit_euler", dt, False)
    s = servo(kp, kd, [qt])
    q, qd = np.zeros(1), np.zeros(1)
    for _ in range(round(T / dt)):
        q, qd = integ.step(q, qd, np.zeros(1), servo=s)
    wn, zeta = np.sqrt(kp / IZZ), kd / (2 * np.sqrt(kp * IZZ))    # underdamped here
    wd = wn * np.sqrt(1 - zeta**2)
    exact = qt - qt * np.exp(-zeta * wn * T) * (np.cos(wd * T) + zeta * wn / wd * np.sin(wd * T))
    assert abs(exact - qt) > 0.05                                  # still moving: a real test
    assert q[0] == pytest.approx(exact, abs=2e-3 * qt)


@pytest.mark.parametrize("method", SERVO_METHODS)
def test_stiff_gains_stable_where_explicit_pd_diverges(ur5e, method):
    """UR5e at 1 ms, Kp = 1e5 N m/rad, Kd = 2e3 N m s/rad on every joint (omega_n dt >> 2 at
    the wrists): the implicit servo settles on the target; the same PD computed from the
    state at the start of the step blows up."""
    n, dt = ur5e.dof, 1e-3
    s = servo(1e5, 2e3, Q_TARGET)
    integ = FixedStepIntegrator(ur5e, method, dt, False)
    q, qd = np.zeros(n), np.zeros(n)
    for _ in range(1000):
        q, qd = integ.step(q, qd, ur5e.gravity_torques(q), servo=s)
    assert np.max(np.abs(q - Q_TARGET)) < 1e-9
    assert np.max(np.abs(qd)) < 1e-6
    explicit = FixedStepIntegrator(ur5e, method, dt, False)
    q, qd = np.zeros(n), np.zeros(n)
    with pytest.raises(SimulationError):
        for _ in range(1000):
            tau = ur5e.gravity_torques(q) + s.kp * (Q_TARGET - q) - s.kd * qd
            q, qd = explicit.step(q, qd, tau)


@pytest.mark.parametrize("method", SERVO_METHODS)
def test_reported_torque_is_the_applied_torque(ur5e, method):
    """From a moving state: tau_s = Kp (q* - q1) + Kd (qd* - v) at the end of the step (v
    the velocity of the position update, = qd1 for semi-implicit Euler), and a step
    without servo under tau + tau_s lands on the same state."""
    n, dt = ur5e.dof, 1e-3
    rng = np.random.default_rng(11)
    q0, qd0, tau = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-5, 5, n)
    qdt = np.array([np.nan, 0.5, np.nan, np.nan, -0.2, np.nan])
    s = servo([3e4, 2e4, 1e4, 5e3, 5e3, 5e3], 300.0, Q_TARGET, qdt)
    integ = FixedStepIntegrator(ur5e, method, dt, True)
    q1, qd1 = integ.step(q0, qd0, tau, servo=s)
    tau_s = integ.servo_torque
    v = (q1 - q0) / dt
    qd_star = np.where(np.isnan(qdt), 0.0, qdt)
    assert np.allclose(tau_s, s.kp * (Q_TARGET - q1) + s.kd * (qd_star - v), rtol=1e-9, atol=1e-7)
    if method == "semi_implicit_euler":
        assert np.allclose(v, qd1, rtol=0, atol=1e-12)
    q2, qd2 = FixedStepIntegrator(ur5e, method, dt, True).step(q0, qd0, tau + tau_s)
    assert np.allclose(q2, q1, rtol=0, atol=1e-12)
    assert np.allclose(qd2, qd1, rtol=0, atol=1e-9)
    assert np.max(np.abs(tau_s)) > 100.0        # the servo did act


def test_masks_and_velocity_targets(ur5e):
    """NaN targets: a joint with neither target gets no servo torque; a velocity target
    alone is reached (Kd only); a position-targeted joint settles on its target."""
    n = ur5e.dof
    qt = np.array([0.2, np.nan, np.nan, np.nan, np.nan, np.nan])
    vt = np.array([np.nan, np.nan, np.nan, np.nan, np.nan, 0.8])
    s = servo(1e4, 500.0, qt, vt)
    assert np.array_equal(s.kp, [1e4, 0, 0, 0, 0, 0])
    assert np.array_equal(s.kd, [500.0, 0, 0, 0, 0, 500.0])
    integ = FixedStepIntegrator(ur5e, "semi_implicit_euler", 1e-3, False)
    q, qd = np.zeros(n), np.zeros(n)
    for _ in range(1000):
        q, qd = integ.step(q, qd, ur5e.gravity_torques(q), servo=s)
        assert np.all(integ.servo_torque[1:5] == 0.0)
    assert q[0] == pytest.approx(0.2, abs=1e-3)
    assert qd[5] == pytest.approx(0.8, abs=1e-3)


def test_servo_with_coulomb_friction_and_stops_is_stable(ur5e):
    """The general path (stick-slip friction): the servo torque, solved by backward Euler
    from the free acceleration and held over the step, is still stable at stiff gains and
    brings the arm onto the target (static friction below Kp x the error)."""
    n = ur5e.dof
    diss = ur5e.dissipation.override(viscous=0.5, coulomb=1.0)
    for method in SERVO_METHODS:
        integ = FixedStepIntegrator(ur5e, method, 1e-3, diss)
        s = servo(1e5, 2e3, Q_TARGET)
        q, qd = np.zeros(n), np.zeros(n)
        for _ in range(1500):
            q, qd = integ.step(q, qd, ur5e.gravity_torques(q), servo=s)
        assert np.max(np.abs(q - Q_TARGET)) < 1e-4, method


def test_errors():
    robot = sd.load_urdf(ROTOR)
    with pytest.raises(ValueError, match="semi_implicit_euler"):
        FixedStepIntegrator(robot, "rk4", 1e-3).step(np.zeros(1), np.zeros(1), np.zeros(1),
                                                     servo=servo(1.0, 1.0, [0.0]))
    with pytest.raises(ValueError, match="kp"):
        servo(-1.0, 1.0, [0.0])
    with pytest.raises(ValueError, match="kd"):
        servo(1.0, [1.0, 2.0], [0.0])
    with pytest.raises(ValueError, match="q_target"):
        servo(1.0, 1.0, [0.0, 1.0], n=1)
