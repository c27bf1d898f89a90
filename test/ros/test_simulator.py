"""The simulator node in its own process, over real topics and services.

The simulator publishes /clock here, so joint_states stamps are simulated time: an exact
count of integration steps (k * 1 ms), which makes the checks below exact and free of
wall-clock timing. Each published state under a constant effort is compared with the
library's run from the same state (``assert_library_states``) at its stamp: a node that advanced
its clock without integrating, or published anything but its state, fails.
"""
from contextlib import contextmanager

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

from conftest import HOME, Latest, wait_for_log, stamp_ns as ns

DT_NS = 1_000_000


def assert_library_states(robot, msgs, rest, effort, method="semi_implicit_euler"):
    """Every message in ``msgs`` is the state the library reaches from HOME at rest under
    the constant ``effort`` in the steps from the stamp of ``rest`` (the reset state) to
    its stamp: ``sd.simulate`` with the node's settings (``method`` at 1 ms, the robot's
    dissipation, hard stops at the joint limits), which steps through the general
    fixed step, not the real-time path of ``FixedStepIntegrator.step`` the node calls."""
    effort = np.asarray(effort, dtype=float)
    steps = [(ns(m) - ns(rest)) // DT_NS for m in msgs]
    assert all(ns(m) - ns(rest) == k * DT_NS and k > 0 for m, k in zip(msgs, steps))
    ref = sd.simulate(robot, max(steps) * DT_NS * 1e-9, HOME, None, effort,
                      method=method, dt=DT_NS * 1e-9, position_limits=True,
                      dissipation=True)
    assert ref.t.size == max(steps) + 1
    for m, k in zip(msgs, steps):
        np.testing.assert_allclose(m.position, ref.q[k], rtol=0, atol=1e-9,
                                   err_msg=f"position after {k} steps")
        np.testing.assert_allclose(m.velocity, ref.qd[k], rtol=0, atol=1e-9,
                                   err_msg=f"velocity after {k} steps")
        np.testing.assert_array_equal(m.effort, effort)
    return ref


class Sim:
    """A simulator node; its commands hold until replaced (command_timeout 0: a test's
    resending timer starved on a loaded machine cannot let the arm fall), unless a test
    asks for a timeout (then in a namespace of its own, ``ns``)."""

    def __init__(self, ros, ns="", depth=100, **params):
        self.ros = ros
        self.proc = ros.start("simulator", {"publish_clock": True, "initial_positions": HOME,
                                            "command_timeout_action": "limp",
                                            "command_timeout": 0.0, **params},
                              ros_args=["-r", f"__ns:={ns}"] if ns else ())
        self.robot = sd.default_robot()
        p = f"{ns}/" if ns else ""
        self.states = Latest(ros, JointState, f"{p}joint_states", depth=depth)
        self.effort = ros.node.create_publisher(Float64MultiArray, f"{p}effort_commands", 10)
        self.joint = ros.node.create_publisher(JointState, f"{p}joint_commands", 10)
        self.reset_client = ros.node.create_client(Trigger, f"{p}simulator/reset")
        self.pause_client = ros.node.create_client(SetBool, f"{p}simulator/pause")
        ros.wait_matched(self.effort, self.joint, also=lambda: self.states.msgs,
                         what="the simulator")

    def pause(self, on=True):
        assert self.ros.call(self.pause_client, SetBool.Request(data=on)).success

    def reset(self):
        """Pause, reset and return the first state at rest in HOME (its stamp is the
        simulated time of the reset)."""
        self.pause(True)
        assert self.ros.call(self.reset_client, Trigger.Request()).success
        return self.states.wait(lambda m: list(m.position) == HOME and not any(m.velocity)
                                and not any(m.effort), what="the reset state")

    def send(self, effort):
        self.effort.publish(Float64MultiArray(data=[float(x) for x in effort]))

    def wait_effort(self, effort):
        return self.states.wait(lambda m: np.array_equal(m.effort, effort),
                                what=f"applied effort {list(effort)}")

    @contextmanager
    def running_with(self, effort):
        """Resume with ``effort`` applied (resent every 50 ms, as a controller would);
        reset afterwards."""
        timer = self.ros.node.create_timer(0.05, lambda: self.send(effort))
        try:
            self.wait_effort(effort)
            self.pause(False)
            yield
        finally:
            self.ros.node.destroy_timer(timer)
            self.reset()

    def states_over(self, first, steps):
        """joint_states from ``first`` to ``steps`` integration steps later."""
        seen = [first]
        while ns(seen[-1]) < ns(first) + steps * DT_NS:
            seen.append(self.states.wait())
        return seen


@pytest.fixture(scope="module")
def sim(ros):
    s = Sim(ros)
    yield s
    s.states.destroy()
    s.proc.stop()


@pytest.fixture(scope="module")
def inverse_dynamics(ros):
    proc = ros.start("inverse_dynamics")
    pub = ros.node.create_publisher(JointTrajectory, "inverse_dynamics/request", 10)
    responses = Latest(ros, JointTrajectory, "inverse_dynamics/response")
    ros.wait_matched(pub, what="the inverse-dynamics node")
    yield pub, responses
    responses.destroy()
    proc.stop()


def test_joint_states_every_10_ms_of_a_fall_are_the_library_states(sim):
    rest = sim.reset()
    sim.pause(False)
    msgs = [sim.states.wait(lambda m: ns(m) > ns(rest), what="joint_states")]
    while len(msgs) < 60:                              # 0.6 s of fall under zero effort
        msgs.append(sim.states.wait())
    sim.pause(True)
    for m in msgs:
        assert list(m.name) == sim.robot.joint_names
        assert len(m.position) == len(m.velocity) == len(m.effort) == 6
    # publish_rate 100 Hz of simulated time: consecutive stamps 10 ms apart, exactly (the
    # stamps count integration steps). A message may be lost under load (the subscriber
    # queue is finite), so gaps must be whole periods and rare.
    gaps = np.diff([ns(m) for m in msgs])
    assert np.all(gaps % (10 * DT_NS) == 0) and np.all(gaps > 0)
    assert np.mean(gaps == 10 * DT_NS) >= 0.9
    assert_library_states(sim.robot, msgs, rest, np.zeros(6))
    assert np.max(np.abs(np.array(msgs[-1].position) - HOME)) > 0.2     # it did fall
    # and the library's step agrees: FixedStepIntegrator, as the node steps it
    integrator = FixedStepIntegrator(sim.robot, "semi_implicit_euler", 1e-3, True,
                                     position_limits=True)
    q, qd = np.array(HOME), np.zeros(6)
    for _ in range((ns(msgs[-1]) - ns(rest)) // DT_NS):
        q, qd = integrator.step(q, qd, np.zeros(6))
    np.testing.assert_allclose(msgs[-1].position, q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(msgs[-1].velocity, qd, rtol=0, atol=1e-9)


def test_gravity_torques_from_the_inverse_dynamics_node_hold_the_arm(sim, inverse_dynamics):
    request, responses = inverse_dynamics
    rest = sim.reset()
    msg = JointTrajectory(joint_names=sim.robot.joint_names,
                          points=[JointTrajectoryPoint(positions=HOME)])
    msg.header.frame_id = "hold"
    request.publish(msg)
    g = np.array(responses.wait(lambda m: m.header.frame_id == "hold").points[0].effort)
    np.testing.assert_allclose(g, sim.robot.gravity_torques(HOME), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(g)) > 1.0
    with sim.running_with(g):
        start = sim.states.wait(lambda m: ns(m) > ns(rest))
        seen = sim.states_over(start, 2000)                    # 2 s of simulated time
        drift = max(np.max(np.abs(np.array(m.position) - HOME)) for m in seen)
        assert drift < 1e-3
        assert all(np.array_equal(m.effort, g) for m in seen)
    assert_library_states(sim.robot, seen, rest, g)
    # A node that advanced its clock without integrating would hold the arm too: with 90 %
    # of the gravity torques the arm sags, every state as the library's
    rest = sim.reset()
    with sim.running_with(0.9 * g):
        start = sim.states.wait(lambda m: ns(m) > ns(rest))
        seen = sim.states_over(start, 300)
    ref = assert_library_states(sim.robot, seen, rest, 0.9 * g)
    assert np.max(np.abs(np.array(seen[-1].position) - HOME)) > 0.02
    assert np.max(np.abs(ref.q[-1] - HOME)) > 0.02


def test_a_joint_driven_into_its_limit_stops_and_rests_there(sim):
    # position_limits is on by default: wrist_3 (limit 2 pi) is driven at +2 N m while
    # gravity torques hold the rest of the arm
    rest = sim.reset()
    tau = sim.robot.gravity_torques(HOME)
    tau[5] += 2.0
    upper = sim.robot.upper[5]
    with sim.running_with(tau):
        first = sim.states.wait(lambda m: m.position[5] >= upper, what="wrist_3 at its limit")
        seen = sim.states_over(first, 1000)                    # 1 s on the stop
        run = [m for m in sim.states.msgs if ns(rest) < ns(m) <= ns(seen[-1])]
        assert all(m.position[5] == upper and m.velocity[5] == 0.0 for m in seen)
        assert all(np.array_equal(m.effort, tau) for m in seen)
    # the joint_states come every 10 ms; the library's run is checked at every step
    # (test_stops.py): each published state, on the way and on the stop, is its state
    ref = assert_library_states(sim.robot, run, rest, tau)
    assert np.all(ref.q[:, 5] <= upper) and np.max(ref.qd[:, 5]) > 100.0


def test_command_timeout_returns_effort_to_zero_with_one_warning(ros):
    # A fresh clone's run once read the first zero effort 0.67 s after the command took
    # hold; the likely cause is states lost from the 100 the subscription kept while this
    # process fell behind the simulator on a loaded machine. It keeps 1000 here (10 s), and
    # the assertion's message says whether states were lost between the two.
    sim = Sim(ros, ns="/timeout", command_timeout=0.5, depth=1000)
    try:
        sim.reset()
        before = sim.proc.output().count("command_timeout")
        sim.pause(False)
        c = [1.0, 2.0, 1.0, 0.5, 0.25, 0.1]
        sim.send(c)
        held = sim.wait_effort(c)
        released = sim.states.wait(lambda m: not any(m.effort), what="the timeout")
        # command_timeout = 0.5 s of simulated time; joint_states come every 10 ms
        msgs = [ns(m) for m in sim.states.msgs]
        read = msgs[msgs.index(ns(held)):msgs.index(ns(released)) + 1]
        assert 0.49e9 <= ns(released) - ns(held) <= 0.52e9, (
            f"held at {ns(held)} ns, released at {ns(released)} ns; {len(read)} states read "
            f"between, steps of {sorted(set(np.diff(read)))} ns (10 ms each unless some were lost)")
        ros.spin_for(0.5)
        assert sim.proc.output().count("command_timeout") - before == 1
    finally:
        sim.states.destroy()
        sim.proc.stop()


def test_joint_commands_by_name_and_effort_clamping(sim):
    sim.reset()    # paused: commands hold (no simulated time passes), states still come
    sim.joint.publish(JointState(name=["elbow_joint", "shoulder_pan_joint"], effort=[10.0, -5.0]))
    sim.wait_effort([-5.0, 0, 10.0, 0, 0, 0])
    sim.joint.publish(JointState(name=["wrist_1_joint"], effort=[100.0]))   # limit 28 N m
    sim.wait_effort([-5.0, 0, 10.0, 28.0, 0, 0])
    sim.send([1000.0, -1000.0, 0, 0, 0, -29.0])                            # limits 150, 28
    sim.wait_effort([150.0, -150.0, 0, 0, 0, -28.0])
    wait_for_log(sim.ros, sim.proc, "clamped to the limit")
    sim.reset()


BAD_EFFORT = {   # message -> the log text of its cause
    "effort_commands data contains NaN": [[float("nan")] * 6, [0, 0, float("inf"), 0, 0, 0]],
    "effort_commands data has": [[1.0, 2.0], []],     # one cause: the wrong length
}
BAD_JOINT = {
    "that are not joints of the model": JointState(name=["elbow_joint", "gripper"], effort=[1.0, 2.0]),
    "more than once": JointState(name=["elbow_joint", "elbow_joint"], effort=[1.0, 2.0]),
    "joint_commands effort has 1 values": JointState(name=["elbow_joint", "wrist_1_joint"],
                                                     effort=[1.0]),
    "joint_commands effort contains NaN": JointState(name=["elbow_joint"], effort=[float("nan")]),
    "joint_commands names no joints": JointState(),
}


def test_bad_commands_are_rejected_once_per_cause_and_the_last_good_one_stays(ros, sim):
    sim.reset()
    good = [1.0, 2.0, 3.0, 0.5, 0.25, 0.125]
    sim.send(good)
    sim.wait_effort(good)
    for _ in range(3):
        for messages in BAD_EFFORT.values():
            for data in messages:
                sim.effort.publish(Float64MultiArray(data=[float(x) for x in data]))
        for msg in BAD_JOINT.values():
            sim.joint.publish(msg)
    for text in list(BAD_EFFORT) + list(BAD_JOINT):
        wait_for_log(ros, sim.proc, text)
    ros.spin_for(0.3)
    log = sim.proc.output()
    for text in (*BAD_EFFORT, *BAD_JOINT):
        assert log.count(text) == 1, text
    sim.states.clear()
    sim.wait_effort(good)                        # still applying the last good command
    assert sim.proc.running()
    sim.reset()                                  # and still answering


def test_pause_and_reset(sim):
    sim.reset()
    sim.pause(False)
    a = sim.states.wait(lambda m: list(m.position) != HOME, what="motion")
    sim.pause(True)
    # once paused, two consecutive states with the same stamp, then no change at all
    prev = [sim.states.wait()]
    paused = sim.states.wait(lambda m: (ns(m) == ns(prev[-1])) or prev.append(m))
    for _ in range(5):
        m = sim.states.wait()
        assert ns(m) == ns(paused) and list(m.position) == list(paused.position)
    assert ns(paused) >= ns(a)
    sim.reset()                                    # back to HOME at rest (waited for inside)
    sim.pause(False)
    sim.states.wait(lambda m: ns(m) > ns(paused) and list(m.position) != HOME,
                    what="motion after the reset")
    sim.reset()


def test_a_diverging_simulation_pauses_and_the_node_keeps_serving(ros):
    proc = ros.start("simulator", {"clamp_effort": False, "publish_clock": True,
                                   "command_timeout": 0.0}, ros_args=["-r", "__ns:=/div"])
    states = Latest(ros, JointState, "/div/joint_states")
    pub = ros.node.create_publisher(Float64MultiArray, "/div/effort_commands", 10)
    reset = ros.node.create_client(Trigger, "/div/simulator/reset")
    try:
        ros.wait_matched(pub, also=lambda: states.msgs, what="the simulator")
        pub.publish(Float64MultiArray(data=[0.0] * 5 + [1e7]))   # unclamped: wrist_3 explodes
        wait_for_log(ros, proc, "paused at the last good state")
        assert ros.call(reset, Trigger.Request()).success
        states.wait(lambda m: not any(m.position) and not any(m.velocity) and not any(m.effort),
                    what="the reset state")
        assert proc.running()
    finally:
        states.destroy()
        proc.stop()


def test_symplectic_euler_in_the_node_is_the_library_method(ros, sim):
    """integrator:=symplectic_euler: the node's states of a fall are those of
    sd.simulate(method="symplectic_euler"), and differ from semi-implicit Euler's."""
    sim.proc.stop()                               # one simulator at a time on the topics
    other = Sim(ros, integrator="symplectic_euler")
    try:
        rest = other.reset()
        other.pause(False)
        msgs = [other.states.wait(lambda m: ns(m) > ns(rest), what="joint_states")]
        while len(msgs) < 30:                     # 0.3 s of fall under zero effort
            msgs.append(other.states.wait())
        other.pause(True)
        ref = assert_library_states(other.robot, msgs, rest, np.zeros(6), "symplectic_euler")
        k = (ns(msgs[-1]) - ns(rest)) // DT_NS
        semi = sd.simulate(other.robot, k * DT_NS * 1e-9, HOME, None, np.zeros(6),
                           method="semi_implicit_euler", dt=DT_NS * 1e-9,
                           position_limits=True)
        assert np.max(np.abs(semi.q[-1] - ref.q[k])) > 1e-7     # a different method ran
    finally:
        other.states.destroy()
        other.proc.stop()

