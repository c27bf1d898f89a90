"""What the simulator node publishes, read from ``sim.Session`` without ROS: every joint
(mimic joints following their leaders, with no actuator), a floating base's pose and twist
at the same instant, and the /diagnostics entries of the session."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.sim.session import Session, has_base

from test_mimic import mimic_chain


def test_a_mimic_chain_reads_every_joint_with_no_effort_at_the_followers():
    robot = sd.load_urdf(mimic_chain())
    s = Session(robot, [0.3, -0.4], dissipation=False)
    s.command(np.arange(2), np.array([1.5, -2.0]))
    s.set_state(np.arange(2), None, np.array([0.2, 0.1]))
    s.step()
    k, q, v, tau, _, _ = s.snapshot()
    reading = s.joint_state()
    assert reading.k == k == 1 and reading.base is None
    assert s.joint_names == ["j1", "j2", "j3", "j4"] and not s.has_base
    # j3 = 1.5 q2 + 0.2, j4 = -0.7 q1 (and their rates without the offset)
    np.testing.assert_allclose(reading.position, [q[0], q[1], 1.5 * q[1] + 0.2, -0.7 * q[0]],
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(reading.velocity, [v[0], v[1], 1.5 * v[1], -0.7 * v[0]],
                               rtol=0, atol=1e-15)
    np.testing.assert_array_equal(reading.effort, [1.5, -2.0, 0.0, 0.0])


def test_a_floating_base_reads_its_pose_and_twist_beside_the_joints():
    sat = sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))
    pose = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0])
    s = Session(sat, np.zeros(sat.dof), base_pose=pose)
    assert has_base(sat) and s.has_base and not has_base(sd.default_robot())
    s.set_base_state(pose, np.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.25]))
    s.step()
    reading = s.joint_state()
    base_pose, twist = reading.base
    np.testing.assert_array_equal(base_pose, s.q[:7])
    np.testing.assert_array_equal(twist, s.qd[:6])
    np.testing.assert_array_equal(reading.position, s.q[7:])
    # 0.5 m/s along the base's x for 1 ms (the base turning at 0.25 rad/s: second order)
    assert base_pose[0] == pytest.approx(1.0005, rel=0, abs=1e-8)
    assert len(reading.effort) == sat.dof == len(s.joint_names)


def test_the_report_counts_divergences_the_push_and_the_servoed_joints():
    s = Session(sd.default_robot(), np.zeros(6))
    assert s.report() == [("divergence events", 0), ("external wrench", "none"),
                          ("servoed joints", 0)]
    s.push(np.array([0.0, 12.5, 0.0, -1e-5, 0.0, 3.0]))
    s.command(np.array([1, 4]), np.zeros(2), np.array([0.1, np.nan]), np.array([np.nan, 0.2]))
    s.divergences = 2
    assert s.report() == [("divergence events", 2), ("external wrench", "0 12.5 0 -1e-05 0 3"),
                          ("servoed joints", 2)]
