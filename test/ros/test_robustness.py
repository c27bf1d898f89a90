"""Issue 13: running nodes fed what they cannot use -- finite but huge numbers (1e308),
20,001 joint names -- refuse it with one clear log line and carry on: afterwards they
answer correctly, in order, and the process is alive. And every node counts what it
received, refused and sent on /diagnostics."""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd

from conftest import HOME, Latest, wait_for_log

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
HUGE = 1e308
MANY = NAMES + ["elbow_joint"] * (20_001 - 6)   # 20,001 names, the pathological (repeated) case
KP, KD = 100.0, 20.0


def trajectory(names, positions, velocities=(), accelerations=(), frame=""):
    msg = JointTrajectory(joint_names=list(names), points=[JointTrajectoryPoint(
        positions=list(positions), velocities=list(velocities),
        accelerations=list(accelerations))])
    msg.header.frame_id = frame
    return msg


@pytest.fixture(scope="module")
def nodes(ros):
    """The three nodes, started together, each in a namespace of its own."""
    procs = {"ctl": ros.start("computed_torque_controller", {"kp": [KP], "kd": [KD]},
                              ros_args=["-r", "__ns:=/rob_ctl"]),
             "id": ros.start("inverse_dynamics", ros_args=["-r", "__ns:=/rob_id"]),
             "sim": ros.start("simulator", {"start_paused": True, "initial_positions": HOME},
                              ros_args=["-r", "__ns:=/rob_sim"])}
    yield procs
    for p in procs.values():
        p.stop()


def diagnostics_of(ros, name):
    """The latest /diagnostics counts of the node ``name`` (its integer values), as
    {key: int}, via a getter."""
    latest = {}

    def on(msg):
        for s in msg.status:
            if s.name == name:
                latest.clear()
                latest.update({v.key: int(v.value) for v in s.values if v.value.isdigit()})
    ros.node.create_subscription(DiagnosticArray, "/diagnostics", on, 10)
    return latest


def test_controller_survives_huge_values_and_20001_names(ros, nodes):
    proc = nodes["ctl"]
    states = ros.node.create_publisher(JointState, "/rob_ctl/joint_states", 10)
    traj = ros.node.create_publisher(JointTrajectory, "/rob_ctl/desired_trajectory", 10)
    efforts = Latest(ros, Float64MultiArray, "/rob_ctl/effort_commands")
    diagnostics = diagnostics_of(ros, "/rob_ctl/computed_torque_controller")
    ros.wait_matched(states, traj, what="the controller")
    q1, qd1 = ROBOT.random_state(21)
    q2, qd2 = ROBOT.random_state(22)
    q3 = ROBOT.random_state(23)[0]

    def expect(q, qd, q_ref):
        tau = ROBOT.inverse_dynamics(q, qd, KP * (q_ref - q) - KD * qd)
        efforts.wait(lambda m: np.allclose(m.data, tau, rtol=1e-12, atol=1e-9),
                     what=f"effort {tau}")

    def one_state(msg, count):
        """Publish a joint state and wait until the controller has taken it (its count on
        /diagnostics): it keeps only the latest (keep last 1), so a state sent before the
        last was taken would replace it on a loaded machine."""
        states.publish(msg)
        ros.spin_until(lambda: diagnostics.get("received joint_states") == count, 20,
                       f"joint state {count} on /diagnostics")

    try:
        one_state(JointState(name=NAMES, position=q1.tolist(), velocity=qd1.tolist()), 1)
        traj.publish(trajectory(NAMES, q3))     # after the first state: not refused
        expect(q1, qd1, q3)
        # before the fix each of these made the control law overflow and killed the node
        traj.publish(trajectory(NAMES, [HUGE] * 6))
        traj.publish(trajectory(NAMES, q2, [0.0] * 6, [HUGE] * 6))
        for k in range(3):
            one_state(JointState(name=NAMES, position=[HUGE] * 6, velocity=[0.0] * 6), 2 + k)
        one_state(JointState(name=MANY, position=[0.0] * len(MANY),
                             velocity=[0.0] * len(MANY)), 5)
        traj.publish(trajectory(MANY, [0.0] * len(MANY)))
        states.publish(JointState(name=NAMES, position=q2.tolist(), velocity=qd2.tolist()))
        efforts.clear()
        expect(q2, qd2, q3)       # the state sent after them; the last good trajectory
        for text in ("desired_trajectory: positions beyond +-1e+06",
                     "desired_trajectory: accelerations beyond +-1e+06",
                     "joint_states position has values beyond +-1e+06",
                     "joint_states names 20001 joints; at most 1000",
                     "desired_trajectory names 20001 joints; at most 1000"):
            wait_for_log(ros, proc, text)
            assert proc.output().count(text) == 1, text
        ros.spin_until(lambda: diagnostics.get("received joint_states") == 6
                       and diagnostics.get("received desired_trajectory") == 4, 10,
                       "the counts on /diagnostics")
        assert diagnostics["refused joint_states"] == 4
        assert diagnostics["refused desired_trajectory"] == 3
        assert diagnostics["sent effort_commands"] > 0
        assert proc.running()
    finally:
        efforts.destroy()


def test_inverse_dynamics_survives_huge_values_and_20001_names_and_counts(ros, nodes):
    proc = nodes["id"]
    pub = ros.node.create_publisher(JointTrajectory, "/rob_id/inverse_dynamics/request", 10)
    wrench = ros.node.create_publisher(WrenchStamped, "/rob_id/inverse_dynamics/tip_wrench", 10)
    responses = Latest(ros, JointTrajectory, "/rob_id/inverse_dynamics/response")
    diagnostics = diagnostics_of(ros, "/rob_id/inverse_dynamics")
    ros.wait_matched(pub, wrench, what="the inverse-dynamics node")
    q = np.full(6, 0.3)
    try:
        huge = WrenchStamped()
        huge.header.frame_id = "base_link"
        huge.wrench.force.z = HUGE
        wrench.publish(huge)        # before the fix: accepted, and every later request refused
        ros.spin_for(0.3)           # (another topic: let it arrive first)
        bad = [trajectory(NAMES, [HUGE] * 6, frame="huge positions"),
               trajectory(NAMES, q, [0.0] * 6, [HUGE] * 6, frame="huge accelerations"),
               trajectory(MANY, [0.0] * len(MANY), frame="20001 names")]
        for msg in bad:
            pub.publish(msg)
        pub.publish(trajectory(NAMES, q, frame="good"))
        good = responses.wait(lambda m: m.header.frame_id == "good", what="the good answer")
        # one subscription, one callback thread: answers come in request order, so an
        # answer to a bad request would have come before this one
        assert [m.header.frame_id for m in responses.msgs] == ["good"]
        np.testing.assert_allclose(good.points[0].effort, ROBOT.gravity_torques(q),
                                   rtol=1e-12, atol=1e-10)
        for text in ("tip_wrench has values beyond +-1e+06",
                     "inverse_dynamics/request: positions beyond +-1e+06",
                     "inverse_dynamics/request: accelerations beyond +-1e+06",
                     "inverse_dynamics/request names 20001 joints; at most 1000"):
            wait_for_log(ros, proc, text)
        # what it received, refused and answered, on /diagnostics
        ros.spin_until(lambda: diagnostics.get("received inverse_dynamics/request") == 4,
                       10, "the request count on /diagnostics")
        assert diagnostics["refused inverse_dynamics/request"] == 3
        assert diagnostics["sent inverse_dynamics/response"] == 1
        assert diagnostics["received inverse_dynamics/tip_wrench"] == 1
        assert proc.running()
    finally:
        responses.destroy()


def test_simulator_survives_huge_values_and_20001_names(ros, nodes):
    proc = nodes["sim"]
    states = Latest(ros, JointState, "/rob_sim/joint_states")
    effort = ros.node.create_publisher(Float64MultiArray, "/rob_sim/effort_commands", 10)
    joint = ros.node.create_publisher(JointState, "/rob_sim/joint_commands", 10)
    reset = ros.node.create_client(Trigger, "/rob_sim/simulator/reset")
    diagnostics = diagnostics_of(ros, "/rob_sim/simulator")
    ros.wait_matched(effort, joint, also=lambda: states.msgs, what="the simulator")
    limit = ROBOT.effort_limit

    def applied(tau):
        states.wait(lambda m: np.array_equal(m.effort, tau), what=f"applied effort {tau}")

    try:
        effort.publish(Float64MultiArray(data=[HUGE, -HUGE] * 3))      # clamped to the limits
        applied(limit * [1, -1, 1, -1, 1, -1])
        joint.publish(JointState(name=MANY, effort=[1.0] * len(MANY)))
        joint.publish(JointState(name=["elbow_joint"], effort=[-HUGE]))
        applied(limit * [1, -1, -1, -1, 1, -1])       # the good one, sent after the 20,001
        wait_for_log(ros, proc, "joint_commands names 20001 joints; at most 1000")
        assert ros.call(reset, Trigger.Request()).success
        applied([0.0] * 6)
        ros.spin_until(lambda: diagnostics.get("received joint_commands") == 2, 10,
                       "the counts on /diagnostics")
        assert diagnostics["refused joint_commands"] == 1
        assert diagnostics["received effort_commands"] == 1
        assert "refused effort_commands" not in diagnostics      # clamped, not refused
        assert diagnostics["sent joint_states"] > 0
        assert proc.running()
    finally:
        states.destroy()
