"""Payload at run time: the payload.* parameters of the three nodes, set while they run
through the standard SetParameters / SetParametersAtomically services (what `ros2 param
set` calls), checked against ``robot.with_payload(...)`` of the library.

The nodes are started together at the top of the module (each in a namespace of its own)
so that their start-up times overlap.
"""
import numpy as np
import pytest
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

from conftest import HOME, Latest, wait_for_log, stamp_ns as ns

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
DT_NS = 1_000_000
KD = 40.0                                        # the controller's default kd
CTL_START = {"payload.mass": 1.0, "payload.com": [0.0, 0.0, 0.05]}   # given at start-up
BAD_START = [   # (node, parameters, text of the start-up error)
    ("inverse_dynamics", {"payload.mass": -1.0}, "mass -1.0 is negative"),
    ("simulator", {"payload.inertia": [1.0, 2.0]}, "'payload.inertia' must have 6 values"),
]


class Params:
    """SetParameters / SetParametersAtomically of one node, as `ros2 param set` calls them."""

    def __init__(self, ros, node):
        self.ros = ros
        self.plain = ros.node.create_client(SetParameters, f"{node}/set_parameters")
        self.atomic = ros.node.create_client(SetParametersAtomically,
                                             f"{node}/set_parameters_atomically")

    def set(self, **values):
        """One SetParameters call (the parameters apply one by one): its results."""
        req = SetParameters.Request(parameters=_msgs(values))
        return self.ros.call(self.plain, req).results

    def set_atomically(self, **values):
        req = SetParametersAtomically.Request(parameters=_msgs(values))
        return self.ros.call(self.atomic, req).result


def _msgs(values):   # payload_mass=2.0 -> the parameter payload.mass
    return [Parameter(k.replace("_", ".", 1), value=v).to_parameter_msg()
            for k, v in values.items()]


@pytest.fixture(scope="module")
def procs(ros):
    """Every node of this module, started at once; the bad start-ups are checked here."""
    p = {"id": ros.start("inverse_dynamics", ros_args=["-r", "__ns:=/pl_id"]),
         "ctl": ros.start("computed_torque_controller", CTL_START,
                          ros_args=["-r", "__ns:=/pl_ctl"]),
         "sim": ros.start("simulator", {"publish_clock": True, "initial_positions": HOME,
                                        "start_paused": True, "command_timeout": 0.0},
                          ros_args=["-r", "__ns:=/pl_sim"])}
    bad = [(ros.start(node, params, ["-r", f"__ns:=/pl_bad{i}"], expect_running=False), text)
           for i, (node, params, text) in enumerate(BAD_START)]
    yield {**p, "bad": bad}
    for proc in [*p.values(), *(b for b, _ in bad)]:
        proc.stop()


def applied_once(ros, proc, count):
    """The log has ``count`` "(applied)" lines, and no more come."""
    ros.spin_until(lambda: proc.output().count("(applied)") >= count, 10.0, "the applied log")
    ros.spin_for(0.1)
    assert proc.output().count("(applied)") == count, proc.output()


class Id:
    def __init__(self, ros, proc):
        self.ros, self.proc, self.count = ros, proc, 0
        self.pub = ros.node.create_publisher(JointTrajectory, "/pl_id/inverse_dynamics/request", 10)
        self.responses = Latest(ros, JointTrajectory, "/pl_id/inverse_dynamics/response")
        self.params = Params(ros, "/pl_id/inverse_dynamics")
        ros.wait_matched(self.pub, what="the inverse-dynamics node")

    def torques(self, q, qd, qdd):
        self.count += 1
        msg = JointTrajectory(joint_names=NAMES, points=[
            JointTrajectoryPoint(positions=list(q[i]), velocities=list(qd[i]),
                                 accelerations=list(qdd[i])) for i in range(len(q))])
        msg.header.frame_id = tag = f"request {self.count}"
        self.pub.publish(msg)
        r = self.responses.wait(lambda m: m.header.frame_id == tag, what=f"the answer to {tag}")
        return np.array([p.effort for p in r.points])


@pytest.fixture(scope="module")
def idn(ros, procs):
    c = Id(ros, procs["id"])
    yield c
    c.responses.destroy()


Q, QD = ROBOT.random_state(21, batch=3)
QDD = np.random.default_rng(21).uniform(-2, 2, Q.shape)


def test_inverse_dynamics_payload_set_while_running_and_a_bad_one_refused(idn):
    before = idn.torques(Q, QD, QDD)
    np.testing.assert_allclose(before, ROBOT.inverse_dynamics(Q, QD, QDD), rtol=1e-12, atol=1e-10)
    com = [0.01, -0.02, 0.08]
    results = idn.params.set(payload_mass=2.5, payload_com=com)    # two parameters, one call
    assert [r.successful for r in results] == [True, True], results
    expected = ROBOT.with_payload(2.5, com).inverse_dynamics(Q, QD, QDD)
    after = idn.torques(Q, QD, QDD)
    np.testing.assert_allclose(after, expected, rtol=0, atol=1e-9)
    assert np.max(np.abs(after - before)) > 1.0          # 2.5 kg at the tool: tens of N m
    # applied one by one: the mass first (com still 0), then the com
    wait_for_log(idn.ros, idn.proc, "payload 2.5 kg on tool0, center of mass [0.0, 0.0, 0.0] m")
    wait_for_log(idn.ros, idn.proc, "payload 2.5 kg on tool0, center of mass [0.01, -0.02, 0.08] m")

    bad = idn.params.set(payload_mass=-1.0)[0]
    assert not bad.successful and "mass -1.0 is negative" in bad.reason, bad
    bad = idn.params.set(payload_link="camera")[0]
    assert not bad.successful and "'camera' is not a link of the model" in bad.reason, bad
    np.testing.assert_array_equal(idn.torques(Q, QD, QDD), after)    # the payload stays
    wait_for_log(idn.ros, idn.proc, "rejected payload parameters {'payload.mass': -1.0}")
    assert idn.proc.running()


def test_an_atomic_set_applies_all_its_parameters_together_or_none(idn):
    prev = idn.torques(Q, QD, QDD)
    com, inertia = [0.0, 0.05, 0.02], [0.01, 0.02, 0.015, 0.001, 0.0, 0.0]
    # one bad value (5 inertia numbers) refuses the whole call: mass and com unchanged too
    bad = idn.params.set_atomically(payload_mass=1.5, payload_com=com,
                                    payload_inertia=inertia[:5])
    assert not bad.successful and "'payload.inertia' must have 6 values" in bad.reason, bad
    np.testing.assert_array_equal(idn.torques(Q, QD, QDD), prev)
    applied = idn.proc.output().count("(applied)")
    ok = idn.params.set_atomically(payload_mass=1.5, payload_com=com, payload_inertia=inertia,
                                   payload_link="wrist_3_link")
    assert ok.successful, ok
    got = idn.torques(Q, QD, QDD)
    np.testing.assert_allclose(
        got, ROBOT.with_payload(1.5, com, inertia, "wrist_3_link").inverse_dynamics(Q, QD, QDD),
        rtol=0, atol=1e-9)
    applied_once(idn.ros, idn.proc, applied + 1)                   # one model for the call
    # one parameter alone: the others keep their values
    assert idn.params.set(payload_mass=0.5)[0].successful
    np.testing.assert_allclose(
        idn.torques(Q, QD, QDD),
        ROBOT.with_payload(0.5, com, inertia, "wrist_3_link").inverse_dynamics(Q, QD, QDD),
        rtol=0, atol=1e-9)
    # mass 0 and zero inertia: no payload, the robot as loaded
    assert idn.params.set_atomically(payload_mass=0.0, payload_inertia=[0.0] * 6).successful
    np.testing.assert_allclose(idn.torques(Q, QD, QDD), ROBOT.inverse_dynamics(Q, QD, QDD),
                               rtol=1e-12, atol=1e-10)
    wait_for_log(idn.ros, idn.proc, "no payload (applied)")


def test_controller_payload_from_start_up_then_set_and_refused(ros, procs):
    proc = procs["ctl"]
    states = ros.node.create_publisher(JointState, "/pl_ctl/joint_states", 10)
    efforts = Latest(ros, Float64MultiArray, "/pl_ctl/effort_commands")
    params = Params(ros, "/pl_ctl/computed_torque_controller")
    try:
        ros.wait_matched(states, what="the controller")
        q, qd = ROBOT.random_state(22)
        states.publish(JointState(name=NAMES, position=q.tolist(), velocity=qd.tolist()))
        v = -KD * qd      # the reference holds the first state: e = 0, edot = -qd

        def expect(robot):
            tau = robot.inverse_dynamics(q, qd, v)
            return np.array(efforts.wait(lambda m: np.allclose(m.data, tau, rtol=0, atol=1e-9),
                                         what=f"effort {tau}").data)
        start = expect(ROBOT.with_payload(1.0, CTL_START["payload.com"]))   # from -p at start-up
        assert params.set(payload_mass=3.0)[0].successful
        new = expect(ROBOT.with_payload(3.0, CTL_START["payload.com"]))
        assert np.max(np.abs(new - start)) > 1.0
        bad = params.set(payload_link="camera")[0]
        assert not bad.successful and "camera" in bad.reason
        bad = params.set_atomically(payload_mass=2.0, payload_inertia=[0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        assert not bad.successful and "triangle inequality" in bad.reason, bad
        efforts.clear()
        ros.spin_until(lambda: len(efforts.msgs) > 5, 20.0, "five commands after the refusals")
        np.testing.assert_array_equal([m.data for m in efforts.msgs[-5:]], [new] * 5)
        assert proc.running()
    finally:
        efforts.destroy()
        ros.node.destroy_publisher(states)


def test_simulator_payload_changes_the_plant_while_running(ros, procs):
    """The torque that holds HOME with a 3 kg payload: without the payload in the plant the
    arm rises (exactly as the library integrates it); with it the arm stays still; the
    payload removed while the simulation steps, the arm moves again."""
    proc, m, com = procs["sim"], 3.0, [0.0, 0.0, 0.05]
    g = ROBOT.with_payload(m, com).gravity_torques(HOME)
    states = Latest(ros, JointState, "/pl_sim/joint_states", depth=100)
    effort = ros.node.create_publisher(Float64MultiArray, "/pl_sim/effort_commands", 10)
    pause = ros.node.create_client(SetBool, "/pl_sim/simulator/pause")
    reset = ros.node.create_client(Trigger, "/pl_sim/simulator/reset")
    params = Params(ros, "/pl_sim/simulator")

    def run(robot, steps=100):
        """From HOME at rest, paused: apply g, run ``steps`` steps; the simulated state
        against the library's integration of ``robot``."""
        effort.publish(Float64MultiArray(data=g.tolist()))
        start = states.wait(lambda s: np.array_equal(s.effort, g) and list(s.position) == HOME,
                            what="the hold torque applied at HOME")
        assert ros.call(pause, SetBool.Request(data=False)).success
        later = states.wait(lambda s: ns(s) >= ns(start) + steps * DT_NS, what=f"{steps} steps")
        integrator = FixedStepIntegrator(robot, "semi_implicit_euler", 1e-3, True,
                                         position_limits=True)     # as the node
        q, qd = np.array(HOME), np.zeros(6)
        for _ in range((ns(later) - ns(start)) // DT_NS):
            q, qd = integrator.step(q, qd, g)
        np.testing.assert_allclose(later.position, q, rtol=0, atol=1e-9)
        np.testing.assert_allclose(later.velocity, qd, rtol=0, atol=1e-9)
        return np.array(later.position), np.array(later.velocity)

    try:
        ros.wait_matched(effort, also=lambda: states.msgs, what="the simulator")
        # no payload in the plant: the torque for 3 kg lifts the arm
        q, qd = run(ROBOT)
        assert np.max(np.abs(q - HOME)) > 0.02 and np.max(np.abs(qd)) > 0.1
        # the payload picked up (set while paused at HOME): the same torque holds the arm
        assert ros.call(pause, SetBool.Request(data=True)).success
        assert ros.call(reset, Trigger.Request()).success
        assert params.set_atomically(payload_mass=m, payload_com=com).successful
        q, qd = run(ROBOT.with_payload(m, com))
        assert np.max(np.abs(q - HOME)) < 1e-9 and np.max(np.abs(qd)) < 1e-9
        # put down while the simulation steps: the plant changes between two steps
        assert params.set(payload_mass=0.0)[0].successful
        moved = states.wait(lambda s: np.max(np.abs(np.array(s.position) - HOME)) > 1e-3,
                            timeout=10.0, what="the arm to rise without its payload")
        assert np.array_equal(moved.effort, g)
        assert proc.running()
        applied_once(ros, proc, 2)
    finally:
        states.destroy()
        ros.node.destroy_publisher(effort)


def test_a_bad_payload_at_start_up_stops_the_node(ros, procs):
    for p, text in procs["bad"]:
        ros.spin_until(lambda: not p.running(), 60, f"{p.module} to exit")
        out = p.output()
        assert p.proc.returncode == 2, out
        assert f"{p.module}: cannot start: payload parameters: " in out and text in out, out
        assert "Traceback" not in out, out
