"""Shape functions, point-to-point and via-point trajectories, batched torques, limits, and
the minimum-time maneuver of the reference chapter (shared/reference section E)."""
import dataclasses

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import trajectory as tj

Q0 = np.array([0.0, -1.5, 1.0, -1.0, 0.5, 0.0])
Q1 = Q0 + np.array([1.5, 0.8, -1.2, 0.7, -0.9, 2.0])


@pytest.mark.parametrize("name", list(tj.SHAPES))
def test_shape_functions(name):
    x = np.linspace(0, 1, 20001)
    s, s1, s2 = (tj.shape(name, x, d) for d in range(3))
    assert s[0] == 0 and abs(s[-1] - 1) < 1e-15 and abs(s1[0]) < 1e-15 and abs(s1[-1]) < 1e-12
    assert np.all(np.diff(s) >= 0)                                   # monotone: no overshoot
    h = x[1] - x[0]
    assert np.max(np.abs(np.gradient(s, h) - s1)[1:-1]) < 1e-6       # derivatives are consistent
    assert np.max(np.abs(np.gradient(s1, h) - s2)[1:-1]) < 1e-5
    if name != "cubic":                                              # zero end accelerations
        assert abs(s2[0]) < 1e-12 and abs(s2[-1]) < 1e-9
    with pytest.raises(ValueError, match="shape 'trapezoid' unknown"):
        tj.shape("trapezoid", 0.5)


def test_point_to_point_and_via_points():
    traj = tj.point_to_point(Q0, Q1, 2.0, "quintic")
    q, qd, qdd = traj(np.array([0.0, 1.0, 2.0]))
    np.testing.assert_allclose(q[0], Q0)
    np.testing.assert_allclose(q[2], Q1, atol=1e-14)
    np.testing.assert_allclose(q[1], (Q0 + Q1) / 2, atol=1e-14)
    np.testing.assert_allclose(qd[[0, 2]], 0, atol=1e-14)
    np.testing.assert_allclose(qd[1], 1.875 * (Q1 - Q0) / 2.0)      # s'(1/2) = 15/8
    assert traj(1.0)[0].shape == (6,) and traj(5.0)[0].tolist() == q[2].tolist()   # clamped
    pts = np.array([Q0, Q0 + 0.3, Q1, Q0])
    times = np.array([0.0, 0.7, 1.5, 3.0])
    via = tj.via_points(pts, times)
    q, qd, qdd = via(times)
    np.testing.assert_allclose(q, pts, atol=1e-14)
    np.testing.assert_allclose(qd[[0, -1]], 0, atol=1e-13)
    t = np.linspace(0, 3, 3001)
    q, qd, qdd = via(t)
    assert np.max(np.abs(np.diff(qdd, axis=0))) < 1e-1          # acceleration continuous
    with pytest.raises(ValueError, match="times must start at 0"):
        tj.via_points(pts, times[::-1])


def test_torques_in_one_batch_equal_single_calls():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=[1.0] * 6, coulomb=[2.0] * 6)
    traj = tj.point_to_point(Q0, Q1, 1.2, "cycloidal")
    t, tau = tj.torques(robot, traj, num=57, dissipation=True)
    assert tau.shape == (57, 6)
    for k in (0, 20, 56):
        q, qd, qdd = traj(t[k])
        expect = robot.inverse_dynamics(q, qd, qdd) - robot.dissipation.torque(qd)
        np.testing.assert_allclose(tau[k], expect, rtol=1e-13, atol=1e-12)


def test_check_limits():
    robot = sd.default_robot()
    slow = tj.check_limits(robot, tj.point_to_point(Q0, Q1, 5.0))
    assert slow.feasible and slow.effort_ratio.max() < 1 and slow.velocity_ratio.max() < 1
    fast = tj.check_limits(robot, tj.point_to_point(Q0, Q1, 0.2))
    assert not fast.feasible and "of joint" in fast.worst
    out = tj.check_limits(robot, tj.point_to_point(Q0, Q0 + np.r_[0, 0, 0, 0, 0, 7.0], 30.0))
    assert not out.feasible and not out.position_ok[5] and "leaves its range" in out.worst


def _peak(robot, T, dissipation):
    traj = tj.point_to_point(Q0, Q1, T, "cycloidal")
    return tj.check_limits(robot, traj, num=2001, dissipation=dissipation).effort_ratio.max()


@pytest.mark.parametrize("case", ["no gravity", "gravity", "gravity and dissipation"])
def test_minimum_time_hits_the_limit_and_no_shorter_time_is_feasible(case):
    gravity = case != "no gravity"
    robot = sd.default_robot(gravity=(0, 0, -9.81) if gravity else (0, 0, 0))
    dissipation = case.endswith("dissipation")
    if dissipation:
        robot.dissipation = robot.dissipation.override(viscous=[2.0] * 6, coulomb=[3.0] * 6)
    res = tj.minimum_time(robot, Q0, Q1, "cycloidal", gravity=gravity, dissipation=dissipation,
                          velocity=False)
    assert res.limit == "effort" and res.T == res.T_effort
    assert abs(_peak(robot, res.T, dissipation) - 1) <= 1e-6          # the worst joint at its limit
    for shorter in (1 - 1e-5, 0.99, 0.9, 0.5):
        assert _peak(robot, res.T * shorter, dissipation) > 1         # any shorter time violates
    assert _peak(robot, res.T * (1 + 1e-5), dissipation) <= 1
    if not gravity:                          # the 1/T^2 law of section E, closed form
        x = np.linspace(0, 1, 2001)
        dq = Q1 - Q0
        q = Q0 + tj.shape("cycloidal", x)[:, None] * dq
        f = robot.inverse_dynamics(q, tj.shape("cycloidal", x, 1)[:, None] * dq,
                                   tj.shape("cycloidal", x, 2)[:, None] * dq)
        F = np.abs(f).max(axis=0)
        assert res.T == pytest.approx(np.max(np.sqrt(F / robot.effort_limit)), rel=1e-12)
        t, tau = tj.torques(robot, tj.point_to_point(Q0, Q1, 2.0 * res.T, "cycloidal"), num=2001)
        np.testing.assert_allclose(tau, f / (2.0 * res.T) ** 2, rtol=1e-9, atol=1e-9 * np.abs(f).max())


def test_minimum_time_with_speed_limits_and_infeasible_cases():
    robot = sd.default_robot()
    res = tj.minimum_time(robot, Q0, Q1)                       # UR5e: wrists limited to pi rad/s
    assert res.limit == "velocity" and res.T == res.T_velocity > res.T_effort
    vmax = np.pi                                                # cycloidal: max s' = 2
    assert res.T == pytest.approx(2 * np.max(np.abs(Q1 - Q0)) / vmax, rel=1e-12)
    weak = sd.Robot(dataclasses.replace(robot.model, effort_limit=np.full(6, 5.0)))
    with pytest.raises(ValueError, match="no duration is feasible: holding joint 'shoulder_lift_joint'"):
        tj.minimum_time(weak, Q0, Q1)
