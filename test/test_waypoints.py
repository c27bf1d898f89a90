"""Waypoint sampling (what the computed-torque controller node and the demo use)."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.trajectory import Waypoints, pick_and_place

rng = np.random.default_rng(5)
T = np.array([0.0, 0.4, 1.0, 1.7])
Q, QD, QDD = rng.normal(size=(3, 4, 2))


@pytest.mark.parametrize("kind", ["linear", "cubic", "quintic"])
def test_waypoints_are_met_and_derivatives_are_consistent(kind):
    traj = Waypoints(T, Q, None if kind == "linear" else QD, QDD if kind == "quintic" else None)
    q, qd, qdd = traj.sample(T[:-1])
    np.testing.assert_allclose(q, Q[:-1], atol=1e-12)
    if kind != "linear":
        np.testing.assert_allclose(qd, QD[:-1], atol=1e-12)
    if kind == "quintic":
        np.testing.assert_allclose(qdd, QDD[:-1], atol=1e-9)
    # qd and qdd are the time derivatives of q and qd (central differences, inside segments)
    t = np.array([0.1, 0.3, 0.55, 0.9, 1.2, 1.6])
    h = 1e-6
    qp, qdp, _ = traj.sample(t + h)
    qm, qdm, _ = traj.sample(t - h)
    q, qd, qdd = traj.sample(t)
    np.testing.assert_allclose((qp - qm) / (2 * h), qd, atol=1e-6)
    if kind != "linear":
        np.testing.assert_allclose((qdp - qdm) / (2 * h), qdd, atol=1e-5)


def test_before_and_after_and_scalar_time():
    traj = Waypoints(T, Q, QD, QDD)
    q, qd, qdd = traj.sample(-1.0)
    assert q.shape == (2,) and np.array_equal(q, Q[0]) and np.array_equal(qd, QD[0])
    q, qd, qdd = traj.sample(5.0)
    assert np.array_equal(q, Q[-1]) and not qd.any() and not qdd.any()   # holds, at rest
    with pytest.raises(ValueError):
        Waypoints([0.0, 0.0], Q[:2])


def test_pick_and_place_is_within_the_ur5e_limits():
    robot = sd.default_robot()
    traj = pick_and_place(robot)
    t = np.linspace(0, traj.duration, 2001)
    q, qd, qdd = traj.sample(t)
    assert np.all(q >= robot.lower) and np.all(q <= robot.upper)
    assert np.all(np.abs(qd) <= robot.velocity_limit)
    tau = robot.inverse_dynamics(q, qd, qdd)
    assert np.all(np.abs(tau) <= 0.5 * robot.effort_limit)       # ample margin for feedback
    other = pick_and_place(sd.builtin_robot("planar_3r"))
    assert other.q.shape == (len(traj.t), 3)
