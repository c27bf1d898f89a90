"""The inverse-dynamics node in its own process: requests and responses over real topics,
checked against the library."""
import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import WrenchStamped
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd

from conftest import Latest, wait_for_log

ROBOT = sd.default_robot()


class Client:
    def __init__(self, ros, proc, ns=""):
        self.ros, self.proc, self.count = ros, proc, 0
        self.pub = ros.node.create_publisher(JointTrajectory, f"{ns}inverse_dynamics/request", 10)
        self.wrench = ros.node.create_publisher(WrenchStamped, f"{ns}inverse_dynamics/tip_wrench", 10)
        self.responses = Latest(ros, JointTrajectory, f"{ns}inverse_dynamics/response")
        ros.wait_matched(self.pub, self.wrench, what=f"{proc.module} node")

    def send(self, msg):
        self.count += 1
        msg.header.frame_id = f"request {self.count}"
        msg.header.stamp.sec, msg.header.stamp.nanosec = self.count, 123
        self.pub.publish(msg)
        return msg.header.frame_id

    def ask(self, msg):
        tag = self.send(msg)
        return self.responses.wait(lambda m: m.header.frame_id == tag, what=f"the answer to {tag}")

    def close(self):
        self.responses.destroy()
        self.proc.stop()


def request(names, q, qd=None, qdd=None):
    msg = JointTrajectory(joint_names=list(names))
    for i in range(len(q)):
        msg.points.append(JointTrajectoryPoint(
            positions=list(q[i]), velocities=[] if qd is None else list(qd[i]),
            accelerations=[] if qdd is None else list(qdd[i]),
            time_from_start=Duration(sec=i, nanosec=1000 * i)))
    return msg


@pytest.fixture(scope="module")
def node(ros):
    c = Client(ros, ros.start("inverse_dynamics"))
    yield c
    c.close()


def test_many_point_request_in_any_joint_order_matches_the_library(node):
    rng = np.random.default_rng(1)
    q, qd = ROBOT.random_state(rng, batch=200)
    qdd = rng.uniform(-3, 3, q.shape)
    perm = rng.permutation(6)                       # the request names joints shuffled
    names = [ROBOT.joint_names[i] for i in perm]
    msg = request(names, q[:, perm], qd[:, perm], qdd[:, perm])
    r = node.ask(msg)
    assert list(r.joint_names) == ROBOT.joint_names   # model order
    assert (r.header.stamp.sec, r.header.stamp.nanosec) == (msg.header.stamp.sec, 123)
    assert len(r.points) == 200
    tau = np.array([p.effort for p in r.points])
    np.testing.assert_allclose(tau, ROBOT.inverse_dynamics(q, qd, qdd), rtol=1e-12, atol=1e-10)
    np.testing.assert_array_equal([p.positions for p in r.points], q)
    np.testing.assert_array_equal([p.velocities for p in r.points], qd)
    np.testing.assert_array_equal([p.accelerations for p in r.points], qdd)
    assert [(p.time_from_start.sec, p.time_from_start.nanosec) for p in r.points] == \
        [(i, 1000 * i) for i in range(200)]


def test_missing_velocities_and_accelerations_mean_zero(node):
    q, _ = ROBOT.random_state(2, batch=3)
    r = node.ask(request(ROBOT.joint_names, q))
    np.testing.assert_allclose([p.effort for p in r.points], ROBOT.gravity_torques(q),
                               rtol=1e-12, atol=1e-10)
    assert all(list(p.velocities) == [0.0] * 6 == list(p.accelerations) for p in r.points)


def test_tip_wrench_latest_applies_in_base_or_tip_frame(ros, node):
    q, qd = ROBOT.random_state(3, batch=4)
    qdd = np.ones_like(q)
    w = np.array([10.0, -5.0, 20.0, 1.0, 2.0, -0.5])
    R = ROBOT.forward_kinematics(q)[:, :3, :3]
    expected = {"base_link": ROBOT.inverse_dynamics(q, qd, qdd, w),
                "tool0": ROBOT.inverse_dynamics(q, qd, qdd, np.hstack([R @ w[:3], R @ w[3:]]))}
    for frame, tau in expected.items():
        msg = WrenchStamped()
        msg.header.frame_id = frame
        f, m = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, m.x, m.y, m.z = w.tolist()
        node.wrench.publish(msg)
        # the wrench and the requests travel on different topics: ask until it applies
        for _ in range(100):
            r = node.ask(request(ROBOT.joint_names, q, qd, qdd))
            got = np.array([p.effort for p in r.points])
            if np.allclose(got, tau, rtol=1e-12, atol=1e-9):
                break
            ros.spin_for(0.05)
        np.testing.assert_allclose(got, tau, rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(expected["base_link"] - ROBOT.inverse_dynamics(q, qd, qdd))) > 0.5
    zero = WrenchStamped()
    zero.header.frame_id = "base_link"
    node.wrench.publish(zero)
    bad = WrenchStamped()
    bad.header.frame_id = "camera"
    node.wrench.publish(bad)
    wait_for_log(ros, node.proc, "neither the base")


BAD = {   # log text of the cause -> a request that must be refused
    "contain NaN or Inf": request(ROBOT.joint_names, [[0, 0, float("nan"), 0, 0, 0]]),
    "needs 6 positions": request(ROBOT.joint_names, [[0.0] * 5]),
    "needs 6 velocities": request(ROBOT.joint_names, [[0.0] * 6], [[0.0] * 7]),
    "not joints of the model": request([*ROBOT.joint_names[:5], "gripper"], [[0.0] * 6]),
    "more than once": request([*ROBOT.joint_names[:5], "elbow_joint"], [[0.0] * 6]),
    "lacks joints": request(ROBOT.joint_names[:5], [[0.0] * 5]),
    "names no joints": JointTrajectory(),
    "has no points": JointTrajectory(joint_names=ROBOT.joint_names),
}


def test_bad_requests_get_no_answer_and_one_log_line_per_cause(ros, node):
    tags = []
    for _ in range(3):
        tags += [node.send(msg) for msg in BAD.values()]
    good = node.ask(request(ROBOT.joint_names, [[0.1] * 6]))
    # one subscription, one callback thread, one reliable publisher: answers come in the
    # order of the requests, so any answer to a bad request would have come before this
    assert not [m for m in node.responses.msgs if m.header.frame_id in tags]
    np.testing.assert_allclose(good.points[0].effort, ROBOT.gravity_torques([0.1] * 6),
                               rtol=1e-12, atol=1e-10)
    log = node.proc.output()
    for text in BAD:
        assert log.count(text) == 1, (text, log)
    assert node.proc.running()


def test_options_gravity_off_and_dissipation_compensated(ros):
    params = {"include_gravity": False, "compensate_dissipation": True,
              "dissipation.joints": ["elbow_joint", "wrist_1_joint"],
              "dissipation.viscous": [0.5, 0.1], "dissipation.coulomb": [2.0]}
    c = Client(ros, ros.start("inverse_dynamics", params, ros_args=["-r", "__ns:=/opt"]), "/opt/")
    try:
        q, qd = ROBOT.random_state(4, batch=5)
        qdd = np.full_like(q, 0.5)
        r = c.ask(request(ROBOT.joint_names, q, qd, qdd))
        flat = sd.load_urdf(sd.builtin_path(), gravity=(0, 0, 0))
        beta = np.array([0, 0, 0.5, 0.1, 0, 0])
        tauc = np.array([0, 0, 2.0, 2.0, 0, 0])
        expected = flat.inverse_dynamics(q, qd, qdd) + beta * qd + tauc * np.sign(qd)
        np.testing.assert_allclose([p.effort for p in r.points], expected, rtol=1e-12, atol=1e-10)
    finally:
        c.close()


def test_robot_loading_order(ros, tmp_path):
    """robot_description topic (transient local, as robot_state_publisher) when no
    parameter is set; urdf_path before the robot_description parameter before the topic."""
    qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    desc = ros.node.create_publisher(String, "/rd/robot_description", qos)
    desc.publish(String(data=open(sd.builtin_path("planar_3r")).read()))
    params_file = tmp_path / "p.yaml"
    xml = open(sd.builtin_path("spatial_3r")).read()
    params_file.write_text("/**:\n  ros__parameters:\n    robot_description: |\n"
                           + "".join(f"      {line}\n" for line in xml.splitlines()))
    cases = {   # namespace: (parameters, --ros-args extra, expected robot)
        "rd": ({"robot_description_timeout": 20.0}, [], "planar_3r"),
        "rd2": ({"robot_description_timeout": 20.0}, ["--params-file", str(params_file)],
                "spatial_3r"),
        "rd3": ({"robot_description_timeout": 20.0, "urdf_path": sd.builtin_path("ur5e")},
                ["--params-file", str(params_file)], "ur5e"),
    }
    procs = {ns: ros.start("inverse_dynamics", p, ros_args=[
        "-r", f"__ns:=/{ns}", "-r", "robot_description:=/rd/robot_description", *extra])
        for ns, (p, extra, _) in cases.items()}
    try:
        for ns, (_, _, name) in cases.items():
            robot = sd.builtin_robot(name)
            c = Client(ros, procs[ns], f"/{ns}/")
            r = c.ask(request(robot.joint_names, [[0.2] * robot.dof]))
            np.testing.assert_allclose(r.points[0].effort, robot.gravity_torques([0.2] * robot.dof),
                                       rtol=1e-12, atol=1e-10)
            assert f"from {'urdf_path' if name == 'ur5e' else 'the robot_description'}" in c.proc.output()
            c.close()
    finally:
        ros.node.destroy_publisher(desc)
        for p in procs.values():
            p.stop()



def test_old_name_is_the_dynamics_node_with_its_services(ros, node):
    from serial_dynamics_interfaces.srv import MassMatrix
    client = ros.node.create_client(MassMatrix, "inverse_dynamics/mass_matrix")
    r = ros.call(client, MassMatrix.Request(positions=[0.3] * 6))
    assert r.success
    np.testing.assert_allclose(np.reshape(r.mass_matrix, (6, 6)), ROBOT.mass_matrix([0.3] * 6),
                               rtol=1e-12)
    ros.node.destroy_client(client)


def test_a_stopped_node_leaves_the_graph(ros):
    """Its subscriptions, services and publishers are gone from the graph when it has
    stopped (SIGINT). The events executor holds a node's entities in use until it is shut
    down: destroyed before that, the node left its endpoints to time out (the DDS lease, 20 s
    or more), and the next node on the same topics was taken for matched while a client's
    requests went to the dead one."""
    proc = ros.start("dynamics", ros_args=["-r", "__ns:=/leaving"])
    pub = ros.node.create_publisher(JointTrajectory, "/leaving/inverse_dynamics/request", 10)
    sub = ros.node.create_subscription(JointTrajectory, "/leaving/inverse_dynamics/response",
                                       lambda m: None, 10)
    ros.wait_matched(pub, also=lambda: sub.get_publisher_count() > 0, what="the dynamics node")
    assert proc.stop() == 0
    ros.spin_until(lambda: pub.get_subscription_count() == 0 and sub.get_publisher_count() == 0,
                   timeout=10.0, what="the stopped node's endpoints to leave the graph")
    ros.node.destroy_publisher(pub)
    ros.node.destroy_subscription(sub)
