"""The computed-torque controller in its own process, fed joint states by this test, its
effort_commands checked against the control law evaluated with the library:

    tau = robot.inverse_dynamics(q, qd, qdd_d + Kp (q_d - q) + Kd (qd_d - qd))

Every check below uses a reference that does not move (a held point, a trajectory over
long ago, one not started yet), so the expected torque is exact and independent of time.
"""
import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd

from conftest import Latest, wait_for_log

ROBOT = sd.default_robot()
KP = np.array([100.0, 110.0, 120.0, 130.0, 140.0, 150.0])
KD = 20.0
NAMES = ROBOT.joint_names


class Ctl:
    def __init__(self, ros):
        self.ros = ros
        self.proc = ros.start("computed_torque_controller", {"kp": KP.tolist(), "kd": [KD]},
                              ros_args=["-r", "__ns:=/ctl"])
        self.states = ros.node.create_publisher(JointState, "/ctl/joint_states", 10)
        self.traj = ros.node.create_publisher(JointTrajectory, "/ctl/desired_trajectory", 10)
        self.efforts = Latest(ros, Float64MultiArray, "/ctl/effort_commands")
        ros.wait_matched(self.states, self.traj, what="the controller")

    def state(self, q, qd, names=NAMES, extra=()):
        pos = dict(zip(NAMES, q))
        vel = dict(zip(NAMES, qd))
        msg = JointState(name=list(names) + [e[0] for e in extra])
        msg.position = [pos[n] for n in names] + [e[1] for e in extra]
        msg.velocity = [vel[n] for n in names] + [e[2] for e in extra]
        self.states.publish(msg)

    def expect(self, q, qd, q_ref):
        tau = ROBOT.inverse_dynamics(q, qd, KP * (np.asarray(q_ref) - q) - KD * np.asarray(qd))
        return self.efforts.wait(lambda m: np.allclose(m.data, tau, rtol=1e-12, atol=1e-9),
                                 what=f"effort {tau}")


@pytest.fixture(scope="module")
def ctl(ros):
    c = Ctl(ros)
    yield c
    c.efforts.destroy()
    c.proc.stop()


def trajectory(points, stamp_sec=0, names=NAMES):
    msg = JointTrajectory(joint_names=list(names))
    msg.header.stamp.sec = stamp_sec
    msg.points = [JointTrajectoryPoint(positions=list(q), time_from_start=Duration(sec=t))
                  for t, q in points]
    return msg


Q1, QD1 = ROBOT.random_state(11)
Q2, QD2 = ROBOT.random_state(12)
Q3 = ROBOT.random_state(13)[0]
Q4 = ROBOT.random_state(14)[0]


def test_control_law_holds_the_first_state_then_follows_a_point(ctl):
    ctl.state(Q1, QD1)
    ctl.expect(Q1, QD1, Q1)                     # holds where the arm was first seen
    order = [NAMES[i] for i in (3, 0, 5, 1, 4, 2)]
    ctl.state(Q2, QD2, names=order, extra=[("gripper_finger", 0.01, 0.0)])
    ctl.expect(Q2, QD2, Q1)                     # any order; other joints ignored
    ctl.traj.publish(trajectory([(0, Q3)]))     # one point at t = 0: go there now
    ctl.expect(Q2, QD2, Q3)


def test_holds_the_last_point_and_waits_for_a_trajectory_to_start(ctl):
    ctl.state(Q2, QD2)
    ctl.traj.publish(trajectory([(1, Q1), (2, Q4)], stamp_sec=1))   # ended long ago
    ctl.expect(Q2, QD2, Q4)
    far = int(ctl.ros.node.get_clock().now().nanoseconds * 1e-9) + 10_000
    ctl.traj.publish(trajectory([(1, Q1), (2, Q3)], stamp_sec=far))  # starts later:
    ctl.ros.spin_for(0.2)
    ctl.expect(Q2, QD2, Q4)                     # the current reference holds until then


def test_bad_input_is_rejected_and_control_continues(ros, ctl):
    ctl.state(Q1, QD1)
    ctl.traj.publish(trajectory([(0, Q3)]))
    ctl.expect(Q1, QD1, Q3)
    nan = Q2.copy()
    nan[2] = np.nan
    bad_states = {
        "joint_states position contains NaN": lambda: ctl.state(nan, QD2),
        "joint_states lacks joints": lambda: ctl.state(Q2, QD2, names=NAMES[:5]),
        "joint_states velocity has 0 values": lambda: ctl.states.publish(
            JointState(name=NAMES, position=Q2.tolist())),
        "joint_states names joints ['elbow_joint']": lambda: ctl.states.publish(
            JointState(name=NAMES + ["elbow_joint"], position=[0.0] * 7, velocity=[0.0] * 7)),
    }
    bad_trajectories = {
        "time_from_start must increase": trajectory([(1, Q2), (1, Q4)]),
        "positions contain NaN": trajectory([(1, nan)]),
        "not joints of the model": trajectory([(1, Q2[:6])], names=NAMES[:5] + ["gripper"]),
        "desired_trajectory has no points": trajectory([]),
        "desired_trajectory names no joints": JointTrajectory(),
    }
    for _ in range(3):
        for send in bad_states.values():    # one at a time: the controller keeps only the
            send()                          # latest state (keep last 1)
            ros.spin_for(0.05)
        for msg in bad_trajectories.values():
            ctl.traj.publish(msg)
    for text in (*bad_states, *bad_trajectories):
        wait_for_log(ros, ctl.proc, text)
    ros.spin_for(0.2)
    log = ctl.proc.output()
    for text in (*bad_states, *bad_trajectories):
        assert log.count(text) == 1, (text, log)
    ctl.efforts.clear()
    ctl.expect(Q1, QD1, Q3)                     # the last good state and trajectory
    assert ctl.proc.running()
