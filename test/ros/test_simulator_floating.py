"""The simulator node on a floating base (``floating_base:=true``), in its own process: the
UR5e on a free base in zero gravity, paused and stepped with ``~/step`` under a constant
effort, with /clock so that every stamp counts integration steps exactly.

The base pose published on ``odom`` (and the joints on ``joint_states``) after the steps is
the library's own ``sd.simulate`` of the same commands (the node's method and dt): a node
that let the base stand still, published the twist in the world frame, or mixed the
quaternion order would be far off. ``~/set_base_state`` and ``~/reset`` move the base; a
push on the tip (``external_wrench``) is in world coordinates; servo targets drive the
joint servo on the floating base as the library's ``FixedStepIntegrator`` does.
"""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

import serial_dynamics as sd
from serial_dynamics.ros import floating_state
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.servo import servo

from conftest import HOME, Latest, stamp_ns as ns

NS = "/flt"
STEPS = 100                # step_count: 0.1 s a ~/step
DT = 1e-3
EFFORT = np.array([0.5, -1.0, 0.5, 0.0, 0.0, 0.0])   # the UR5e base is light: it spins
_QUAT = np.array([0.1, -0.2, 0.3, 0.9]) / np.linalg.norm([0.1, -0.2, 0.3, 0.9])
POSE0 = [0.5, -0.25, 1.0, *_QUAT.tolist()]                  # initial_base_pose
POSE1 = np.array([-1.0, 2.0, 0.5, 0.0, 0.0, np.sin(0.4), np.cos(0.4)])   # ~/set_base_state
TWIST1 = np.array([0.1, -0.2, 0.05, 0.3, -0.1, 0.2])
WRENCH = np.array([0.5, 0.0, -0.3, 0.0, 0.05, 0.0])        # on the tip, world coordinates
ROBOT = sd.load_urdf(sd.builtin_path(), gravity=(0.0, 0.0, 0.0), floating_base=True)


def library(q, v, effort, steps, wrench=None):
    """The library's run of ``steps`` steps of the node's method and dt from (q, v)."""
    res = sd.simulate(ROBOT, steps * DT, q, v, effort, method="semi_implicit_euler", dt=DT,
                      wrench=wrench)
    assert res.t.size == steps + 1
    return res.q[-1], res.qd[-1]


def assert_state(odom, joints, q, v):
    """The published odom and joint_states are the state (q, v), to 1e-12."""
    p, o = odom.pose.pose.position, odom.pose.pose.orientation
    lin, ang = odom.twist.twist.linear, odom.twist.twist.angular
    np.testing.assert_allclose([p.x, p.y, p.z, o.x, o.y, o.z, o.w], q[:7], rtol=0, atol=1e-12,
                               err_msg="odom pose")
    np.testing.assert_allclose([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z], v[:6], rtol=0,
                               atol=1e-12, err_msg="odom twist (base frame)")
    np.testing.assert_allclose(joints.position, q[7:], rtol=0, atol=1e-12, err_msg="joints")
    np.testing.assert_allclose(joints.velocity, v[6:], rtol=0, atol=1e-12, err_msg="rates")
    assert ns(odom) == ns(joints)


@pytest.fixture(scope="module")
def sim(ros):
    proc = ros.start("simulator", {"floating_base": True, "initial_base_pose": POSE0,
                                   "gravity": [0.0, 0.0, 0.0], "publish_clock": True,
                                   "start_paused": True, "initial_positions": HOME,
                                   "step_count": STEPS, "command_timeout": 0.0},
                     ros_args=["-r", f"__ns:={NS}"])

    class S:
        pass
    s = S()
    s.ros, s.proc, s.diag = ros, proc, {}
    s.odom = Latest(ros, Odometry, f"{NS}/odom", depth=100)
    s.states = Latest(ros, JointState, f"{NS}/joint_states", depth=100)
    s.effort = ros.node.create_publisher(Float64MultiArray, f"{NS}/effort_commands", 10)
    s.set_base = ros.node.create_publisher(Odometry, f"{NS}/simulator/set_base_state", 10)
    s.wrench = ros.node.create_publisher(WrenchStamped, f"{NS}/external_wrench", 10)
    s.joint = ros.node.create_publisher(JointState, f"{NS}/joint_commands", 10)
    s.step = ros.node.create_client(Trigger, f"{NS}/simulator/step")
    s.reset = ros.node.create_client(Trigger, f"{NS}/simulator/reset")
    s.diag_sub = ros.node.create_subscription(
        DiagnosticArray, "/diagnostics",
        lambda m: s.diag.update({st.name: {v.key: v.value for v in st.values}
                                 for st in m.status}), 10)
    ros.wait_matched(s.effort, s.set_base, s.wrench, s.joint,
                     also=lambda: s.odom.msgs and s.states.msgs, what="the floating simulator")
    yield s
    s.odom.destroy()
    s.states.destroy()
    proc.stop()


def received(s, topic, count):
    s.ros.spin_until(lambda: s.diag.get(f"{NS}/simulator", {}).get(f"received {topic}")
                     == str(count), 30, f"{count} {topic} received (on /diagnostics)")


def step(s):
    """~/step; (odom, joint_states) published right after, and its step count k."""
    k = ns(s.odom.wait(what="a paused odom")) // 1_000_000
    answer = s.ros.call(s.step, Trigger.Request())
    assert answer.success, answer.message
    odom = s.odom.wait(lambda m: ns(m) == (k + STEPS) * 1_000_000, what="odom after ~/step")
    joints = s.states.wait(lambda m: ns(m) == ns(odom), what="joint_states after ~/step")
    return odom, joints


def test_odom_is_the_library_run_then_set_base_state_and_reset(sim):
    q0 = np.concatenate([POSE0, HOME])
    first = sim.odom.wait(what="the initial odom")
    assert (first.header.frame_id, first.child_frame_id) == ("odom", ROBOT.base_link)
    assert_state(first, sim.states.wait(lambda m: ns(m) == ns(first)), q0, np.zeros(12))

    # the joints driven, the base free: it reacts (zero gravity, no other force)
    sim.effort.publish(Float64MultiArray(data=EFFORT.tolist()))
    received(sim, "effort_commands", 1)
    odom, joints = step(sim)
    q, v = library(q0, np.zeros(12), EFFORT, STEPS)
    assert_state(odom, joints, q, v)
    assert np.linalg.norm(q[:3] - q0[:3]) > 1e-3 and np.linalg.norm(v[3:6]) > 1e-2

    # ~/set_base_state: the base moved and set turning, the joints carry on
    sim.set_base.publish(floating_state.odometry(POSE1, TWIST1, "odom", ""))
    received(sim, "~/set_base_state", 1)
    odom, joints = step(sim)
    q[:7], v[:6] = POSE1, TWIST1
    q, v = library(q, v, EFFORT, STEPS)
    assert_state(odom, joints, q, v)

    # a bad one is refused (a zero quaternion) and leaves the state alone
    sim.set_base.publish(floating_state.odometry(np.zeros(7), TWIST1, "odom", ""))
    received(sim, "~/set_base_state", 2)
    odom, joints = step(sim)
    q, v = library(q, v, EFFORT, STEPS)
    assert_state(odom, joints, q, v)
    assert sim.diag[f"{NS}/simulator"]["refused ~/set_base_state"] == "1"

    # a push on the tip in world coordinates (odom) and servo targets (the implicit joint
    # servo on the floating base, default gains), with the effort in force
    push = WrenchStamped()
    push.header.frame_id = "odom"
    push.wrench.force.x, push.wrench.force.z, push.wrench.torque.y = WRENCH[[0, 2, 4]].tolist()
    sim.wrench.publish(push)
    sim.joint.publish(JointState(name=ROBOT.joint_names, position=HOME, effort=EFFORT.tolist()))
    received(sim, "external_wrench", 1)
    received(sim, "joint_commands", 1)
    odom, joints = step(sim)
    integ = FixedStepIntegrator(ROBOT, "semi_implicit_euler", DT)
    for _ in range(STEPS):
        q, v = integ.step(q, v, EFFORT, WRENCH, servo=servo(1e4, 200.0, HOME, None, 6))
    assert_state(odom, joints, q, v)
    assert "refused joint_commands" not in sim.diag[f"{NS}/simulator"]

    # ~/reset: back to initial_base_pose and initial_positions, at rest
    assert sim.ros.call(sim.reset, Trigger.Request()).success
    odom = sim.odom.wait(lambda m: np.allclose([m.pose.pose.position.x, m.pose.pose.orientation.w],
                                               [POSE0[0], POSE0[6]], rtol=0, atol=0),
                         what="odom at the initial pose")
    assert_state(odom, sim.states.wait(lambda m: ns(m) == ns(odom)), q0, np.zeros(12))
