"""The simulator's inputs from the world, over real topics and services: ``~/set_state``,
``~/step`` (stepping while paused), ``external_wrench`` (with its timeout), bad messages
on each new topic, and the /diagnostics keys of the simulator and the inverse-dynamics
node.

The simulator is paused and stepped with ``~/step`` (``step_count`` = 5), with /clock, so
every check is exact: the state after the steps is the library's
``FixedStepIntegrator`` run from the state that was set (to 1e-9), with the wrench
applied in exactly the steps it should be.
"""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

from conftest import HOME, Latest, wait_for_log, stamp_ns as ns

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
NS = "/inp"
STEPS = 5                  # step_count
WRENCH_TIMEOUT = 4         # steps: external_wrench_timeout = 0.004 s
Q1 = np.array([0.3, -1.2, 1.4, -1.0, -1.3, 0.4])
V1 = np.array([0.2, -0.1, 0.3, 0.5, -0.4, 1.0])


def library(q, qd, steps, wrenches):
    """``steps`` steps of the node's integrator from (q, qd) at zero effort; ``wrenches``
    (one per step, None = no push)."""
    integ = FixedStepIntegrator(ROBOT, "semi_implicit_euler", 1e-3, True, position_limits=True)
    for k in range(steps):
        q, qd = integ.step(q, qd, np.zeros(6), wrenches[k])
    return q, qd


class Diagnostics:
    """The latest /diagnostics values of each node, by node name: {key: str}."""

    def __init__(self, ros):
        self.latest = {}
        self.sub = ros.node.create_subscription(DiagnosticArray, "/diagnostics", self.on, 10)

    def on(self, msg):
        for s in msg.status:
            self.latest[s.name] = {v.key: v.value for v in s.values}

    def of(self, name):
        return self.latest.get(name, {})


@pytest.fixture(scope="module")
def sim(ros):
    proc = ros.start("simulator", {"publish_clock": True, "start_paused": True,
                                   "initial_positions": HOME, "step_count": STEPS,
                                   "external_wrench_timeout": WRENCH_TIMEOUT * 1e-3},
                     ros_args=["-r", f"__ns:={NS}"])
    idn = ros.start("inverse_dynamics", ros_args=["-r", "__ns:=/inp_id"])

    class S:
        pass
    s = S()
    s.ros, s.proc, s.idn = ros, proc, idn
    s.states = Latest(ros, JointState, f"{NS}/joint_states", depth=100)
    s.set_state = ros.node.create_publisher(JointState, f"{NS}/simulator/set_state", 10)
    s.wrench = ros.node.create_publisher(WrenchStamped, f"{NS}/external_wrench", 10)
    s.joint = ros.node.create_publisher(JointState, f"{NS}/joint_commands", 10)
    s.request = ros.node.create_publisher(JointTrajectory, "/inp_id/inverse_dynamics/request", 10)
    s.step = ros.node.create_client(Trigger, f"{NS}/simulator/step")
    s.reset = ros.node.create_client(Trigger, f"{NS}/simulator/reset")
    s.pause = ros.node.create_client(SetBool, f"{NS}/simulator/pause")
    s.diag = Diagnostics(ros)
    ros.wait_matched(s.set_state, s.wrench, s.joint, s.request, also=lambda: s.states.msgs,
                     what="the simulator and the inverse-dynamics node")
    yield s
    s.states.destroy()
    proc.stop()
    idn.stop()


def received(s, topic, count):
    """Wait until the simulator's /diagnostics says it received ``count`` on ``topic``."""
    s.ros.spin_until(lambda: s.diag.of(f"{NS}/simulator").get(f"received {topic}") == str(count),
                     30, f"{count} {topic} received (on /diagnostics)")


def step(s):
    """~/step; returns (the state before, the state after) as published."""
    before = s.states.wait(what="a paused state")
    answer = s.ros.call(s.step, Trigger.Request())
    assert answer.success, answer.message
    assert f"advanced {STEPS} step(s)" in answer.message
    after = s.states.wait(lambda m: ns(m) == ns(before) + STEPS * 1_000_000,
                          what=f"the state {STEPS} steps later")
    return before, after


def test_set_state_then_step_is_the_library_run(sim):
    sim.set_state.publish(JointState(name=NAMES[::-1], position=Q1[::-1].tolist(),
                                     velocity=V1[::-1].tolist()))     # any order, by name
    received(sim, "~/set_state", 1)
    _, after = step(sim)
    q, qd = library(Q1, V1, STEPS, [None] * STEPS)
    np.testing.assert_allclose(after.position, q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(after.velocity, qd, rtol=0, atol=1e-9)
    assert not any(after.effort)


def test_external_wrench_is_applied_then_times_out(sim):
    """A push of 20 N along x and 1 N m about z on the tip: applied in the first
    WRENCH_TIMEOUT steps after it arrived, then dropped (external_wrench_timeout)."""
    sim.set_state.publish(JointState(name=NAMES, position=Q1.tolist()))   # at rest there
    received(sim, "~/set_state", 2)
    w = np.array([20.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    msg = WrenchStamped()
    msg.header.frame_id = ROBOT.base_link
    msg.wrench.force.x, msg.wrench.torque.z = w[0], w[5]
    sim.wrench.publish(msg)
    received(sim, "external_wrench", 1)
    _, after = step(sim)
    wrenches = [w] * WRENCH_TIMEOUT + [None] * (STEPS - WRENCH_TIMEOUT)
    q, qd = library(Q1, np.zeros(6), STEPS, wrenches)
    np.testing.assert_allclose(after.position, q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(after.velocity, qd, rtol=0, atol=1e-9)
    q_free, _ = library(Q1, np.zeros(6), STEPS, [None] * STEPS)
    assert np.max(np.abs(q - q_free)) > 1e-7                # the push did move the arm
    sim.ros.spin_until(lambda: sim.diag.of(f"{NS}/simulator").get("external wrench") == "none",
                       30, "the dropped wrench on /diagnostics")


def test_stepping_is_refused_while_running(sim):
    assert sim.ros.call(sim.pause, SetBool.Request(data=False)).success
    answer = sim.ros.call(sim.step, Trigger.Request())
    assert not answer.success and "not paused" in answer.message
    assert sim.ros.call(sim.pause, SetBool.Request(data=True)).success


def _wrench(values, frame=""):
    msg = WrenchStamped()
    msg.header.frame_id = frame
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, t.x, t.y, t.z = (float(x) for x in values)
    return msg


BAD = {   # topic -> {log text of the cause: message}
    "external_wrench": {
        "external_wrench contains NaN": _wrench([float("nan"), 0, 0, 0, 0, 0]),
        "external_wrench has values beyond": _wrench([1e7, 0, 0, 0, 0, 0]),
        "is not the base frame": _wrench([1.0, 0, 0, 0, 0, 0], "tool0"),
    },
    "set_state": {
        "set_state names joints ['gripper']": JointState(name=["gripper"], position=[0.0]),
        "set_state position has 1 values": JointState(name=NAMES[:2], position=[0.0]),
        "is outside its limits": JointState(name=["elbow_joint"], position=[7.0]),
        "but has neither positions nor velocities": JointState(name=["elbow_joint"]),
        "set_state velocity contains NaN": JointState(name=["elbow_joint"],
                                                      velocity=[float("nan")]),
    },
    "joint_commands": {
        "joint_commands position contains NaN": JointState(name=["elbow_joint"],
                                                           position=[float("nan")]),
        "joint_commands velocity has 1 values": JointState(name=NAMES[:2], velocity=[0.1]),
        "joint_commands position has values beyond": JointState(name=["elbow_joint"],
                                                                position=[1e9]),
    },
}


def test_bad_messages_on_every_new_topic_are_rejected_once_and_the_node_serves_on(sim):
    pubs = {"external_wrench": sim.wrench, "set_state": sim.set_state,
            "joint_commands": sim.joint}
    for _ in range(3):       # 5 messages at most per topic per round: within the queue depth
        for topic, cases in BAD.items():
            for msg in cases.values():
                pubs[topic].publish(msg)
        sim.ros.spin_for(0.3)
    for cases in BAD.values():
        for text in cases:
            wait_for_log(sim.ros, sim.proc, text)
    sim.ros.spin_for(0.3)
    log = sim.proc.output()
    for cases in BAD.values():
        for text in cases:
            assert log.count(text) == 1, text           # throttled: once per cause
    sim.ros.spin_until(lambda: sim.diag.of(f"{NS}/simulator").get("refused ~/set_state") == "15",
                       30, "the refused counts on /diagnostics")
    diag = sim.diag.of(f"{NS}/simulator")
    assert diag["refused external_wrench"] == "9" and diag["refused joint_commands"] == "9"
    # still serving, from the last good state: set it again and step
    sim.set_state.publish(JointState(name=NAMES, position=Q1.tolist(), velocity=V1.tolist()))
    received(sim, "~/set_state", 18)
    _, after = step(sim)
    q, _ = library(Q1, V1, STEPS, [None] * STEPS)
    np.testing.assert_allclose(after.position, q, rtol=0, atol=1e-9)
    assert sim.proc.running()


def test_diagnostics_keys(sim):
    """The documented keys: the simulator's real-time factor ('paused' while paused), late
    steps, divergence events; the inverse-dynamics node's request rate and latency."""
    point = JointTrajectoryPoint(positions=HOME, velocities=[0.0] * 6, accelerations=[0.0] * 6)
    timer = sim.ros.node.create_timer(0.02, lambda: sim.request.publish(
        JointTrajectory(joint_names=NAMES, points=[point])))
    try:
        sim.ros.spin_until(lambda: float(sim.diag.of("/inp_id/inverse_dynamics")
                                         .get("request rate (Hz)", "0")) > 0,
                           30, "a request rate on /diagnostics")
    finally:
        sim.ros.node.destroy_timer(timer)
    idd = sim.diag.of("/inp_id/inverse_dynamics")
    assert float(idd["latency mean (ms)"]) > 0
    assert float(idd["latency max (ms)"]) >= float(idd["latency mean (ms)"])
    assert 0.0 < float(idd["request rate (Hz)"]) < 200.0       # sent at 50 Hz
    sim_diag = sim.diag.of(f"{NS}/simulator")
    assert sim_diag["real-time factor"] == "paused"
    assert sim_diag["divergence events"] == "0"
    assert int(sim_diag["late steps"]) >= 0
    assert sim.ros.call(sim.pause, SetBool.Request(data=False)).success
    try:
        sim.ros.spin_until(lambda: sim.diag.of(f"{NS}/simulator").get("real-time factor",
                                                                       "paused") != "paused",
                           30, "a real-time factor while running")
        assert 0.0 < float(sim.diag.of(f"{NS}/simulator")["real-time factor"]) < 1.5
    finally:
        assert sim.ros.call(sim.pause, SetBool.Request(data=True)).success
