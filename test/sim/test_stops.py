"""Hard stops at the joint limits (``position_limits=True``, fixed-step methods).

A 3-joint chain in a vertical plane (axes y, gravity -z) with its middle joint limited to
[-0.4, 0.4] rad falls from q2 = 0.3: joint 2 swings onto its stops again and again.
Checked: the limits hold at every sample, the energy balance closes with the stops' work
counted in W_diss (at the accuracy the same method reaches without stops) and equal to
the losses of the impacts recomputed in closed form, the impulse obeys M (qd+ - qd-) =
S^T lambda with the stops pushing only, the real-time step (``FixedStepIntegrator.step``)
stops at every step as ``sd.simulate`` does, and a damped arm comes to rest on its stop.
"""
import re

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import chain_urdf
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

LIMITS = [(-3.0, 3.0), (-0.4, 0.4), (-3.0, 3.0)]
Q0 = np.array([0.0, 0.3, 0.0])


@pytest.fixture(scope="module")
def arm():
    return sd.load_urdf(chain_urdf(3, axes=("y",), limits=LIMITS))


# relative energy-balance error of each method on this run: without stops it is
# 3.7e-2 (semi-implicit Euler), 6.1e-8 (rk4), 7.1e-5 (implicit midpoint)
@pytest.mark.parametrize("method, energy_tol", [("semi_implicit_euler", 5e-2), ("rk4", 1e-7),
                                                ("implicit_midpoint", 1e-4)])
def test_limits_hold_and_the_energy_balance_closes(arm, method, energy_tol):
    free = sd.simulate(arm, 3.0, Q0, method=method, dt=1e-3)
    assert free.q[:, 1].min() < -0.45                    # without stops it swings past -0.4
    res = sd.simulate(arm, 3.0, Q0, method=method, dt=1e-3, position_limits=True)
    lo, hi = np.array(LIMITS).T
    assert np.all(res.q >= lo) and np.all(res.q <= hi)
    assert np.sum(res.q[:, 1] == -0.4) > 10 and np.sum(res.q[:, 1] == 0.4) > 10  # both stops
    assert "a joint reached a stop" in res.stats.message
    assert res.relative_energy_error() < energy_tol
    # no friction: W_diss is the stops' work alone; the loss of each impact, recomputed
    # below, sums to ~1.8 J of ~11 J kinetic energy
    impacts, lost = replay_impacts(arm, res, method)
    assert impacts == int(re.search(r"a joint reached a stop in (\d+) steps",
                                    res.stats.message)[1]) >= 5
    np.testing.assert_allclose(res.energy_dissipated[-1], lost, rtol=IMPACT_TOL[method])


# the replay of a step from a recorded state repeats it to round-off, except with the
# implicit midpoint rule: its Jacobian is reused over steps, so a step taken alone ends
# Newton at a slightly different point, within newton_tol = 1e-10 (measured 9e-12)
IMPACT_TOL = {"semi_implicit_euler": 1e-12, "rk4": 1e-12, "implicit_midpoint": 1e-9}


def replay_impacts(arm, res, method):
    """The impacts of a run with stops on joint 2 only, recomputed independently of
    ``JointStops``: each recorded state is stepped without stops; where joint 2 ends
    beyond a limit, it is put back on it and stopped in a plastic impact at it, in closed
    form: qd+ = qd- - M^-1 e_2 qd-_2 / (M^-1)_22 (the impulse lambda e_2 that brings qd_2 to
    0), which takes the kinetic energy 1/2 (qd+ - qd-)^T M (qd+ - qd-) (Carnot). Checks each
    post-impact state against the run. A joint at rest on a stop is held there while its
    free acceleration points outward (the stop pushes), else let go. Returns (impacts, the
    energy E- - E+ they took, kinetic and potential, the position reset included)."""
    free = FixedStepIntegrator(arm, method, 1e-3)
    lo, hi = np.array(LIMITS).T
    tol = IMPACT_TOL[method]
    E = lambda q, qd: arm.kinetic_energy(q, qd) + arm.potential_energy(q)   # noqa: E731
    impacts, lost = 0, 0.0
    for k in range(res.t.size - 1):
        q, qd = res.q[k], res.qd[k]
        if abs(q[1]) == 0.4 and qd[1] == 0.0:     # at rest on a stop: held while the
            if arm.forward_dynamics(q, qd, np.zeros(3))[1] * q[1] > 0:    # stop pushes
                assert res.q[k + 1, 1] == q[1] and res.qd[k + 1, 1] == 0.0
                continue
        qm, qdm = free.step(q, qd, np.zeros(3))
        assert np.all(np.abs(qm[[0, 2]]) < 3.0)       # only joint 2 reaches a stop
        if abs(qm[1]) <= 0.4:
            np.testing.assert_allclose(res.q[k + 1], qm, rtol=0, atol=tol)
            continue
        impacts += 1
        qp = np.clip(qm, lo, hi)
        M = arm.mass_matrix(qp)
        Minv = np.linalg.inv(M)
        assert qdm[1] * np.sign(qm[1]) > 0                 # it was moving outward
        qdp = qdm - Minv[:, 1] * qdm[1] / Minv[1, 1]
        assert abs(qdp[1]) < 1e-12
        dv = qdp - qdm
        assert arm.kinetic_energy(qp, qdm) - arm.kinetic_energy(qp, qdp) == pytest.approx(
            0.5 * dv @ M @ dv, rel=1e-12)
        np.testing.assert_array_equal(res.q[k + 1, 1], qp[1])          # on the stop
        np.testing.assert_allclose(res.q[k + 1], qp, rtol=0, atol=tol)
        np.testing.assert_allclose(res.qd[k + 1], qdp, rtol=0, atol=10 * tol)
        lost += E(qm, qdm) - E(qp, qdp)
    return impacts, lost


@pytest.mark.parametrize("case", ["falling_arm", "ur5e_wrist_3"])
def test_real_time_steps_stop_at_every_step_as_simulate_does(arm, case):
    """``FixedStepIntegrator.step``, the simulator node's call, takes a fast path (one
    forward-dynamics call) for semi-implicit Euler without Coulomb friction, as here. With
    stops, every step must still end within the limits, and equal the steps of
    ``sd.simulate`` (the general step): the arm falling onto joint 2's stops, and the
    UR5e's wrist_3 driven at +2 N m into its limit 2 pi (it gets there at ~290 rad/s;
    one unstopped step would carry it ~0.3 rad beyond)."""
    if case == "falling_arm":
        robot, q0, tau, T = arm, Q0, np.zeros(3), 3.0
    else:
        robot = sd.default_robot()
        q0 = np.array([0.0, -1.571, 1.571, -1.571, -1.571, 0.0])
        tau = robot.gravity_torques(q0) + [0, 0, 0, 0, 0, 2.0]
        T = 0.3
    integ = FixedStepIntegrator(robot, "semi_implicit_euler", 1e-3, position_limits=True)
    q, qd = q0.copy(), np.zeros(robot.dof)
    Q, QD = [q], [qd]
    for k in range(round(T / 1e-3)):
        q, qd = integ.step(q, qd, tau, t=k * 1e-3)
        Q.append(q)
        QD.append(qd)
    Q, QD = np.array(Q), np.array(QD)
    lo, hi = robot.lower, robot.upper
    assert np.all(Q >= lo) and np.all(Q <= hi)                 # at every step
    ref = sd.simulate(robot, T, q0, None, tau, method="semi_implicit_euler", dt=1e-3,
                      position_limits=True)
    assert ref.t.size == len(Q)
    np.testing.assert_allclose(Q, ref.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(QD, ref.qd, rtol=0, atol=1e-10)
    assert integ.impacts >= 1 and np.any((Q == lo) | (Q == hi))   # the stops were reached
    if case == "ur5e_wrist_3":
        on = Q[:, 5] == hi[5]
        assert on[-1] and np.all(QD[on, 5] == 0.0) and np.max(QD[:, 5]) > 100.0


def test_impulse_acts_at_the_stopped_joints_only_and_pushes(arm):
    integ = FixedStepIntegrator(arm, "rk4", 1e-3, position_limits=True)
    rng = np.random.default_rng(3)
    lo, hi = np.array(LIMITS).T
    released = 0
    for _ in range(200):
        q = rng.uniform(lo, hi)
        q[1] = rng.choice([-0.41, 0.41])                 # joint 2 beyond a stop
        if rng.random() < 0.5:
            q[0] = rng.choice([-3.01, 3.01])             # and sometimes joint 1 too
        qd = rng.normal(size=3) * 3
        side = np.sign(q) * (np.abs(q) > np.array([3.0, 0.4, 3.0]))
        q1, qd1, dE = integ.stops.impact(q, qd, True)
        assert np.array_equal(q1, np.clip(q, lo, hi))
        M = arm.mass_matrix(q1)
        lam = M @ (qd1 - qd)                             # generalized impulse
        stopped = (side != 0) & (qd1 == 0.0) & (qd != 0.0)       # stopped by the impact
        released += int(np.sum((side != 0) & (qd * side > 0) & ~stopped))
        assert np.allclose(lam[~stopped], 0.0, atol=1e-12 * (1 + np.abs(M @ qd).max()))
        assert np.all(lam[stopped] * side[stopped] <= 1e-12)     # a stop pushes inward
        assert np.all(qd1 * side <= 0.0)                  # nothing leaves through a stop
        T0, T1 = arm.kinetic_energy(q1, qd), arm.kinetic_energy(q1, qd1)
        assert T1 <= T0 + 1e-12                          # a plastic impact only takes energy
        E_before = arm.kinetic_energy(q, qd) + arm.potential_energy(q)
        E_after = arm.kinetic_energy(q1, qd1) + arm.potential_energy(q1)
        assert dE == pytest.approx(E_after - E_before, abs=1e-12)
    assert released > 0                                  # the pull test was exercised


def test_a_damped_arm_comes_to_rest_on_its_stops():
    # joints 1 and 2 cannot swing down past 0.2 and 0.4 rad; link 3 hangs free. Rest:
    # q1 = 0.2 and q2 = 0.4 on their stops, link 3 vertical: q1 + q2 + q3 = pi/2
    limits = [(-0.2, 0.2), (-0.4, 0.4), (-3.0, 3.0)]
    damped = sd.load_urdf(chain_urdf(3, axes=("y",), limits=limits, damping=0.5))
    res = sd.simulate(damped, 10.0, np.zeros(3), method="semi_implicit_euler", dt=1e-3,
                      position_limits=True, output_dt=0.1)
    assert np.all(res.q[-20:, :2] == [0.2, 0.4])         # on the stops for the last 2 s
    assert res.q[-1, 2] == pytest.approx(np.pi / 2 - 0.6, abs=1e-3)
    assert np.max(np.abs(res.qd[-1])) < 1e-3
    g = damped.gravity_torques(res.q[-1])                # the torque that would hold it:
    assert np.all(g[:2] < 0)                             # gravity pushes both into the stops


def test_continuous_joints_and_the_default_have_no_stops(arm):
    assert not FixedStepIntegrator(sd.builtin_robot("planar_3r"), position_limits=True).stops
    res = sd.simulate(arm, 1.0, Q0, method="rk4", dt=1e-3)
    assert res.q[:, 1].min() < -0.4                      # off by default in sd.simulate


def test_adaptive_methods_and_starts_beyond_a_stop_are_refused(arm):
    with pytest.raises(ValueError, match=r"position_limits needs a fixed-step method .*'DOP853'"):
        sd.simulate(arm, 1.0, Q0, method="DOP853", position_limits=True)
    with pytest.raises(ValueError, match=r"q0: joint2 = 0.5 is outside its limits \[-0.4, 0.4\]"):
        sd.simulate(arm, 1.0, [0.0, 0.5, 0.0], method="rk4", position_limits=True)
