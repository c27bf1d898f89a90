"""The momentum observer against simulated motion with a known tip wrench (sd.simulate with
``wrench=``: tau_ext = J^T w), against its own discrete filter (the Tustin lag of the known
tau_ext), and the tip-wrench least squares against known wrenches."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.observers import MomentumObserver, tip_jacobian, tip_wrench

from test_mimic import mimic_chain          # a chain with mimic joints (reduced coordinates)

ROBOT = sd.default_robot()
Q0 = np.array([0.3, -1.2, 1.4, -1.6, -1.5, 0.4])
W = np.array([20.0, -15.0, 30.0, 1.0, -2.0, 0.5])     # on the tip, base frame
T_STEP = 0.2                                          # s, the wrench is applied from here
PHASE = np.arange(6.0)


def tracking(robot):
    """A computed-torque controller on a slow sinusoid about Q0 (the arm keeps moving)."""
    def torque(t, q, qd):
        s, c = np.sin(2 * t + PHASE), np.cos(2 * t + PHASE)
        return robot.inverse_dynamics(q, qd, -0.8 * s + 100 * (Q0 + 0.2 * s - q)
                                      + 20 * (0.4 * c - qd))
    return torque


def run(robot=ROBOT, duration=0.8, dissipation=False):
    """rk4 at 1 ms (the output: every step) with the wrench stepping on at T_STEP."""
    step = lambda t, q, qd: W if t >= T_STEP - 1e-9 else np.zeros(6)   # noqa: E731
    return sd.simulate(robot, duration, Q0, np.zeros(6), tracking(robot), method="rk4",
                       dt=1e-3, wrench=step, dissipation=dissipation)


@pytest.fixture(scope="module")
def res():
    return run()


def observe(robot, res, gain, idx=None, dissipation=False):
    obs = MomentumObserver(robot, gain, dissipation=dissipation)
    idx = np.arange(res.t.size) if idx is None else idx
    return np.array([obs.update(res.t[k], res.q[k], res.qd[k], res.tau[k]) for k in idx])


def known(robot, res, idx=None):
    """tau_ext = J^T w at the samples (0 before the step)."""
    idx = np.arange(res.t.size) if idx is None else idx
    J = robot.jacobian(res.q[idx])
    return np.einsum("kij,i->kj", J, W) * (res.t[idx] >= T_STEP - 1e-9)[:, None]


def lag(u, t, K):
    """The observer's discrete lag applied to u: r_k = e^{-K dt} r_{k-1} + (1 - e^{-K dt})
    (u_{k-1} + u_k) / 2 (the exact lag of the interval's mean, trapezoid)."""
    r = np.zeros_like(u)
    for k in range(1, len(t)):
        d = np.exp(-K * (t[k] - t[k - 1]))
        r[k] = d * r[k - 1] + (1 - d) * 0.5 * (u[k] + u[k - 1])
    return r


def rel(a, b):
    return np.linalg.norm(a - b, axis=-1) / np.linalg.norm(b, axis=-1)


def test_c_transpose_qd_is_the_kinetic_energy_gradient():
    q, qd = ROBOT.random_state(5)
    np.testing.assert_allclose(ROBOT.kinetic_energy_gradient(q, qd),
                               ROBOT.coriolis_matrix(q, qd).T @ qd, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("gain", [200.0, 400.0])
def test_estimate_converges_to_the_known_wrench_torques_within_2_percent(res, gain):
    r, u = observe(ROBOT, res, gain), known(ROBOT, res)
    before = res.t < T_STEP - 1e-9
    assert np.max(np.abs(r[before])) < 2e-3 * np.max(np.abs(u))     # no wrench: ~0
    after = res.t >= T_STEP + 6 / gain                               # after 6 time constants
    assert after.sum() > 200
    assert np.max(rel(r[after], u[after])) < 0.02
    # and it is the lag of tau_ext, up to the integration error of the samples (away from
    # the step, which falls inside a sample interval: the transient differs by O(K dt))
    smooth = before | (res.t >= T_STEP + 5 / gain)
    assert np.max(np.abs(r - lag(u, res.t, gain))[smooth]) < 1e-3 * np.max(np.abs(u))


def test_detection_delay_is_the_first_order_lag_of_the_step(res):
    K, r, u = 100.0, observe(ROBOT, res, 100.0), known(ROBOT, res)
    thr = 0.5 * np.abs(u[res.t >= T_STEP - 1e-9][0])                 # half the step, per joint
    first = lambda x: res.t[np.flatnonzero(np.any(np.abs(x) > thr, axis=1))[0]]  # noqa: E731
    delay = first(r) - T_STEP
    assert abs(delay - (first(lag(u, res.t, K)) - T_STEP)) <= 1.01e-3   # same sample, or next
    assert abs(delay - np.log(2) / K) <= 1.5e-3          # continuous lag: 1 - e^{-K t} = 1/2
    assert delay > 0


def test_constant_external_torque_on_a_still_arm_is_the_closed_form_lag():
    """Held still (qd = 0) against a constant external torque u: tau = g(q) - u, and for any
    sample times r(t_k) = (1 - e^{-K (t_k - t_0)}) u exactly: no overshoot even at K dt = 20."""
    u = np.array([3.0, -2.0, 1.5, 0.5, -0.25, 0.1])
    t = np.cumsum([0.0, 0.001, 0.02, 0.0005, 0.01, 0.2, 0.003])
    for K in (5.0, 100.0):
        obs = MomentumObserver(ROBOT, K)
        r = np.array([obs.update(tk, Q0, np.zeros(6), ROBOT.gravity_torques(Q0) - u) for tk in t])
        np.testing.assert_allclose(r, (1 - np.exp(-K * (t - t[0])))[:, None] * u,
                                   rtol=1e-9, atol=1e-9)


def test_irregular_samples(res):
    rng = np.random.default_rng(3)
    idx = np.sort(rng.choice(np.arange(1, res.t.size), size=300, replace=False))
    idx = np.r_[0, idx]                                  # gaps of 1 to ~10 ms
    r, u = observe(ROBOT, res, 100.0, idx), known(ROBOT, res, idx)
    after = res.t[idx] >= T_STEP + 0.15
    assert np.max(np.abs(r - lag(u, res.t[idx], 100.0))[after]) < 2e-3 * np.max(np.abs(u))
    assert np.max(rel(r[after], u[after])) < 0.02


def test_friction_is_subtracted_only_when_asked():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=[4.0, 4.0, 2.0, 0.1, 0.02, 0.001])
    res = run(robot, 0.6, dissipation=True)
    u, after = known(robot, res), res.t >= T_STEP + 0.1
    with_model = observe(robot, res, 100.0, dissipation=True)
    without = observe(robot, res, 100.0, dissipation=False)
    assert np.max(rel(with_model[after], u[after])) < 0.02
    # without it, the friction torque delta(qd) is seen as external: r -> tau_ext + delta
    delta = robot.dissipation_torques(res.qd)
    assert np.max(rel(without[after], u[after])) > 0.05
    assert np.max(np.abs(without - with_model - lag(delta, res.t, 100.0))[after]) \
        < 2e-3 * np.max(np.abs(u))


def test_bad_input_is_refused_and_leaves_the_observer_unchanged():
    obs = MomentumObserver(ROBOT, 10.0)
    z = np.zeros(6)
    obs.update(0.0, Q0, z, ROBOT.gravity_torques(Q0))
    before = (obs.t, obs.r.copy())
    for args, text in [((0.0, Q0, z, z), "does not come after"),
                       ((-1.0, Q0, z, z), "does not come after"),
                       ((0.1, Q0[:5], z, z), "q has shape"),
                       ((0.1, Q0, z, [0, 0, np.nan, 0, 0, 0]), "tau has a NaN"),
                       ((np.inf, Q0, z, z), "finite time")]:
        with pytest.raises(ValueError, match=text):
            obs.update(*args)
    assert (obs.t, obs.r.tolist()) == (before[0], before[1].tolist())
    # a robot held still by its gravity torques: nothing external
    np.testing.assert_allclose(obs.update(0.01, Q0, z, ROBOT.gravity_torques(Q0)), 0, atol=1e-9)
    obs.reset()
    assert obs.t is None
    np.testing.assert_array_equal(obs.update(0.0, Q0, z, z), z)    # restarts at r = 0
    for gain in (0.0, -1.0, [1.0, 2.0], np.nan):
        with pytest.raises(ValueError, match="gain"):
            MomentumObserver(ROBOT, gain)
    np.testing.assert_array_equal(MomentumObserver(ROBOT, [1, 2, 3, 4, 5, 6]).gain, np.arange(1, 7))


@pytest.mark.parametrize("name", ["ur5e", "planar_3r", "spatial_3r", "mimic"])
def test_tip_jacobian_from_inverse_dynamics_is_the_kinematic_one(name):
    robot = sd.load_urdf(mimic_chain()) if name == "mimic" else sd.builtin_robot(name)
    for q in robot.random_state(7, batch=5)[0]:
        np.testing.assert_allclose(tip_jacobian(robot, q), robot.jacobian(q), rtol=0, atol=1e-12)


def test_tip_wrench_recovers_a_known_wrench_and_reports_conditioning():
    obs = MomentumObserver(ROBOT, 10.0)
    w, cond = obs.wrench(Q0, ROBOT.jacobian(Q0).T @ W)
    np.testing.assert_allclose(w, W, rtol=1e-9, atol=1e-9)
    s = np.linalg.svd(ROBOT.jacobian(Q0), compute_uv=False)
    assert cond == pytest.approx(s[0] / s[-1], rel=1e-12) and 1 < cond < 1e3
    # the zero pose of the UR5e is singular: w still explains tau_ext in least squares
    q = np.zeros(6)
    tau = ROBOT.jacobian(q).T @ W
    w, cond = tip_wrench(ROBOT, q, tau)
    assert cond == np.inf
    np.testing.assert_allclose(ROBOT.jacobian(q).T @ w, tau, atol=1e-9)
    assert np.linalg.norm(w) <= np.linalg.norm(W)                    # the minimum-norm one


def test_tip_wrench_of_a_short_chain_is_the_minimum_norm_solution():
    robot = sd.builtin_robot("planar_3r")
    q = np.array([0.3, 0.7, -0.4])
    J = robot.jacobian(q)
    tau = J.T @ W
    w, cond = tip_wrench(robot, q, tau)
    np.testing.assert_allclose(J.T @ w, tau, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(w, np.linalg.pinv(J.T) @ tau, rtol=1e-10, atol=1e-10)
    s = np.linalg.svd(J, compute_uv=False)
    assert cond == pytest.approx(s[0] / s[-1], rel=1e-12)
