"""The dynamics node's request rules in plain Python (ros/requests.py, no node): joint
names in any order give the same bits as the robot's order, empty arrays are zeros, a zero
tip wrench is none, forward dynamics inverts inverse dynamics with the dissipation
compensated, and every refusal names its field."""
import array
import subprocess
import sys
from types import SimpleNamespace as Msg

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.ros import requests
from serial_dynamics.ros.throttle import Rejected

ROBOT = sd.default_robot()
ROBOT.dissipation = ROBOT.dissipation.override(viscous={"elbow_joint": 0.5},
                                               coulomb={"wrist_1_joint": 2.0})
ZERO = Msg(force=Msg(x=0.0, y=0.0, z=0.0), torque=Msg(x=0.0, y=0.0, z=0.0))


def wrench(w):
    return Msg(force=Msg(x=w[0], y=w[1], z=w[2]), torque=Msg(x=w[3], y=w[4], z=w[5]))


def test_any_joint_order_and_empty_fields_give_the_same_bits():
    q, qd = ROBOT.random_state(3)
    qdd = np.linspace(-1, 1, 6)
    perm = [3, 0, 5, 1, 4, 2]
    names = [ROBOT.joint_names[i] for i in perm]
    shuffled = requests.answer_inverse_dynamics(ROBOT, Msg(
        joint_names=names, positions=q[perm].tolist(), velocities=qd[perm].tolist(),
        accelerations=qdd[perm].tolist(), tip_wrench=ZERO))
    assert shuffled["efforts"].tolist() == ROBOT.inverse_dynamics(q, qd, qdd).tolist()
    assert shuffled["joint_names"] == ROBOT.joint_names
    in_order = requests.answer_inverse_dynamics(ROBOT, Msg(
        joint_names=list(ROBOT.joint_names), positions=array.array("d", q),
        velocities=array.array("d", qd), accelerations=array.array("d", qdd), tip_wrench=ZERO))
    assert in_order["efforts"].typecode == "d"       # what the message field holds
    assert in_order["efforts"].tolist() == shuffled["efforts"].tolist()
    empty = requests.answer_inverse_dynamics(ROBOT, Msg(
        joint_names=[], positions=q.tolist(), velocities=[], accelerations=[], tip_wrench=ZERO))
    assert empty["efforts"].tolist() == ROBOT.gravity_torques(q).tolist()
    fd = requests.answer_forward_dynamics(ROBOT, Msg(
        joint_names=[], positions=q.tolist(), velocities=[], efforts=[], tip_wrench=ZERO))
    assert fd["accelerations"].tolist() == ROBOT.forward_dynamics(q, np.zeros(6), np.zeros(6)).tolist()


def test_forward_inverts_inverse_with_the_wrench_and_the_dissipation_compensated():
    q, qd = ROBOT.random_state(4)
    qdd, w = np.linspace(2, -1, 6), [5.0, -3.0, 8.0, 0.5, 0.0, -1.0]
    tau = requests.answer_inverse_dynamics(ROBOT, Msg(
        joint_names=[], positions=q, velocities=qd, accelerations=qdd, tip_wrench=wrench(w)),
        compensate=True)["efforts"]
    np.testing.assert_allclose(tau, ROBOT.inverse_dynamics(q, qd, qdd, w)
                               - ROBOT.dissipation_torques(qd), rtol=1e-13)
    back = requests.answer_forward_dynamics(ROBOT, Msg(
        joint_names=[], positions=q, velocities=qd, efforts=tau, tip_wrench=wrench(w)),
        compensate=True)["accelerations"]
    np.testing.assert_allclose(back, qdd, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("fields, field", [
    (dict(joint_names=["a"] * 6), "joint_names"),
    (dict(joint_names=ROBOT.joint_names[:3] + ["nose"]), "joint_names"),
    (dict(joint_names=ROBOT.joint_names[:3]), "positions"),     # 6 positions for 3 names
    (dict(positions=[0.0] * 7), "positions"),
    (dict(velocities=[0.0, float("nan")] * 3), "velocities"),
    (dict(accelerations=[1.0]), "accelerations"),
    (dict(tip_wrench=wrench([0, 0, float("nan"), 0, 0, 0])), "tip_wrench"),
])
def test_refusals_name_the_field(fields, field):
    msg = Msg(**{**dict(joint_names=[], positions=[0.0] * 6, velocities=[], accelerations=[],
                        tip_wrench=ZERO), **fields})
    with pytest.raises(Rejected, match=field) as refused:
        requests.answer_inverse_dynamics(ROBOT, msg)
    assert refused.value.cause == field


def test_a_subset_of_the_joints_in_any_order_the_rest_at_zero():
    """Issue 25: a tree's services take any of its joints; those not named are at zero, and
    the answer lists every joint. Here two of a two-arm robot's joints, named backwards."""
    from test_trees import two_arms
    robot = sd.load_urdf(two_arms())
    names = ["r_elbow", "l_shoulder"]
    q = np.zeros(robot.dof)
    q[[robot.joint_names.index(x) for x in names]] = [0.7, -0.4]
    ans = requests.answer_inverse_dynamics(robot, Msg(
        joint_names=names, positions=[0.7, -0.4], velocities=[], accelerations=[1.0, 2.0],
        tip_wrench=ZERO))
    qdd = np.zeros(robot.dof)
    qdd[[robot.joint_names.index(x) for x in names]] = [1.0, 2.0]
    assert ans["joint_names"] == robot.joint_names
    assert ans["efforts"].tolist() == robot.inverse_dynamics(q, np.zeros(robot.dof), qdd).tolist()
    M = requests.answer_mass_matrix(robot, Msg(joint_names=names, positions=[0.7, -0.4]))
    assert M["mass_matrix"].tolist() == robot.mass_matrix(q).ravel().tolist()


def test_the_request_rules_import_no_ros():
    code = ("import sys, serial_dynamics.ros.requests\n"
            "bad = sorted(m for m in sys.modules if m.startswith(('rclpy', 'rcl_')) or '_msgs' in m)\n"
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_topic_pair_torques_one_point_and_many_with_the_tip_wrench_in_either_frame():
    q, qd = ROBOT.random_state(5, batch=4)
    qdd = np.linspace(-1, 1, 24).reshape(4, 6)
    w = np.array([4.0, -2.0, 7.0, 0.3, -0.1, 0.2])
    R = ROBOT.forward_kinematics(q)[:, :3, :3]
    in_base = np.hstack([R @ w[:3], R @ w[3:]])
    many = requests.torques(ROBOT, q, qd, qdd, w, in_tip=True)
    np.testing.assert_array_equal(many, ROBOT.inverse_dynamics(q, qd, qdd, in_base))
    one = requests.torques(ROBOT, q[:1], qd[:1], qdd[:1], w, in_tip=True)
    assert one.shape == (1, 6)
    np.testing.assert_array_equal(one[0], ROBOT.inverse_dynamics(q[0], qd[0], qdd[0], in_base[0]))
    compensated = requests.torques(ROBOT, q, qd, qdd, w, compensate=True)
    np.testing.assert_array_equal(compensated, ROBOT.inverse_dynamics(q, qd, qdd, w)
                                  - ROBOT.dissipation_torques(qd))
    with pytest.raises(Rejected) as refused:
        requests.torques(ROBOT, q[:1], qd[:1], np.full((1, 6), 1e308))     # overflows
    assert refused.value.cause == "result NaN/Inf"


def test_the_answer_is_written_into_the_request():
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    msg = JointTrajectory(joint_names=list(reversed(ROBOT.joint_names)), points=[
        JointTrajectoryPoint(positions=[0.0] * 6) for _ in range(2)])
    msg.header.frame_id, msg.points[1].time_from_start.sec = "request 7", 3
    q = np.arange(12.0).reshape(2, 6)
    out = requests.fill_trajectory(msg, ROBOT, q, q + 1, q + 2, q + 3)
    assert out is msg and msg.header.frame_id == "request 7" and list(out.joint_names) == \
        ROBOT.joint_names and out.points[1].time_from_start.sec == 3
    assert [list(getattr(out.points[1], f)) for f in ("positions", "velocities",
            "accelerations", "effort")] == [(q[1] + k).tolist() for k in range(4)]


def test_latency_windows():
    now = [10.0]
    lat = requests.Latency(clock=lambda: now[0])
    for s in (0.001, 0.003, 0.002):
        lat.add(s)
    now[0] = 12.0
    assert lat.take() == (1.5, 2.0, 3.0)
    now[0] = 13.0
    assert lat.take() == (0.0, 0.0, 0.0)
