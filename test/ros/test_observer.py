"""The external-torque observer node in its own process, fed joint states computed offline
by sd.simulate with a known tip wrench switched on and off: its estimated torques and
wrench against the library (to round-off) and against J^T w (2 %), the collision flag with
its hysteresis, bad messages refused with one log line per cause, and /diagnostics."""
import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

import serial_dynamics as sd
from serial_dynamics.observers import MomentumObserver

from conftest import Latest, wait_for_log

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
Q0 = np.array([0.3, -1.2, 1.4, -1.6, -1.5, 0.4])
W = np.array([20.0, -15.0, 30.0, 1.0, -2.0, 0.5])     # on the tip, base frame
ON, OFF, RAMP = 0.2, 0.6, 0.3           # s: W from ON to OFF, then ramped down to 0 in RAMP
GAIN, THRESHOLDS, RELEASE = 200.0, [8.0, 8.0, 5.0, 3.0, 3.0, 3.0], 0.4
START_NS = 1_000_000_000_000                          # stamps from t = 1000 s
PARAMS = {"gain": GAIN, "collision_thresholds": THRESHOLDS, "collision_release": RELEASE}


def simulate():
    """100 Hz joint states of the UR5e tracking a slow sinusoid (computed torque), pushed
    by W from ON to OFF, then by less and less until OFF + RAMP: rk4 at 1 ms. Returns the
    result and where the push is W in full."""
    phase = np.arange(6.0)

    def torque(t, q, qd):
        s, c = np.sin(2 * t + phase), np.cos(2 * t + phase)
        return ROBOT.inverse_dynamics(q, qd, -0.8 * s + 100 * (Q0 + 0.2 * s - q)
                                      + 20 * (0.4 * c - qd))
    def push(t):
        return 0.0 if t < ON - 1e-9 else float(np.clip((OFF + RAMP - t) / RAMP, 0.0, 1.0))
    res = sd.simulate(ROBOT, 1.2, Q0, np.zeros(6), torque, method="rk4", dt=1e-3,
                      output_dt=0.01, dissipation=False, wrench=lambda t, q, qd: push(t) * W)
    return res, np.array([push(t) == 1.0 for t in res.t])


def stamp(t):
    ns = START_NS + int(round(t * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def state(t, q, qd, tau, names=NAMES):
    msg = JointState(name=list(names), position=list(q), velocity=list(qd), effort=list(tau))
    msg.header.stamp = t if isinstance(t, Time) else stamp(t)
    return msg


def seconds(s):
    return s.sec + 1e-9 * s.nanosec


def hysteresis(r):
    flags, on = [], False
    for x in np.abs(r) / THRESHOLDS:
        on = bool(np.max(x) > 1) if not on else not bool(np.max(x) < RELEASE)
        flags.append(on)
    return flags


class Client:
    def __init__(self, ros):
        self.ros, self.proc = ros, ros.start("external_torque_observer", PARAMS)
        self.pub = ros.node.create_publisher(JointState, "joint_states", 10)
        self.tau = Latest(ros, JointState, "estimated_external_torques", 200)
        self.wrench = Latest(ros, WrenchStamped, "estimated_external_wrench", 200)
        self.collision = Latest(ros, Bool, "collision", 200)
        ros.wait_matched(self.pub, what="the observer node")

    def send(self, msg):
        """Publish and wait for the node's answer (one sample at a time: nothing dropped)."""
        n = len(self.collision.msgs)
        self.pub.publish(msg)
        self.ros.spin_until(lambda: len(self.collision.msgs) > n, 30.0, "the node's answer")


@pytest.fixture(scope="module")
def run(ros):
    res, on = simulate()
    c = Client(ros)
    for k in range(res.t.size):
        c.send(state(res.t[k], res.q[k], res.qd[k], res.tau[k]))
    N = res.t.size
    ros.spin_until(lambda: len(c.tau.msgs) >= N and len(c.wrench.msgs) >= N, 30.0, "all answers")
    yield c, res, on
    for sub in (c.tau, c.wrench, c.collision):
        sub.destroy()
    c.proc.stop()


def test_estimates_match_the_library_and_the_known_wrench(run):
    c, res, on = run
    N = res.t.size
    assert [seconds(m.header.stamp) for m in c.tau.msgs[:N]] == \
        [seconds(stamp(t)) for t in res.t]
    assert all(list(m.name) == NAMES for m in c.tau.msgs[:N])
    r = np.array([m.effort for m in c.tau.msgs[:N]])
    w = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z, m.wrench.torque.x,
                   m.wrench.torque.y, m.wrench.torque.z] for m in c.wrench.msgs[:N]])
    assert {m.header.frame_id for m in c.wrench.msgs} == {ROBOT.base_link}
    obs = MomentumObserver(ROBOT, GAIN)        # the library on the same samples and stamps
    expected = np.array([obs.update(seconds(stamp(t)), q, qd, tau)
                         for t, q, qd, tau in zip(res.t, res.q, res.qd, res.tau)])
    np.testing.assert_allclose(r, expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w, [obs.wrench(q, x)[0] for q, x in zip(res.q, expected)],
                               rtol=0, atol=1e-8)
    # the physics: J^T w within 2 % once converged (6 time constants), W itself within 2 %
    settled = on & (res.t >= ON + 6 / GAIN)
    u = np.einsum("kij,i->kj", ROBOT.jacobian(res.q[settled]), W)
    assert settled.sum() > 30
    assert np.max(np.linalg.norm(r[settled] - u, axis=1) / np.linalg.norm(u, axis=1)) < 0.02
    assert np.max(np.linalg.norm(w[settled] - W, axis=1)) < 0.02 * np.linalg.norm(W)
    quiet = (res.t < ON) | (res.t >= OFF + RAMP + 8 / GAIN)
    assert np.max(np.abs(r[quiet])) < 0.01 * np.max(np.abs(u))


def test_collision_flag_with_hysteresis(run):
    c, res, on = run
    N = res.t.size
    r = np.array([m.effort for m in c.tau.msgs[:N]])
    flags = [m.data for m in c.collision.msgs[:N]]
    assert flags == hysteresis(r)
    rise, fall = flags.index(True), N - 1 - flags[::-1].index(True) + 1
    assert not any(flags[:rise]) and all(flags[rise:fall]) and not any(flags[fall:])
    assert ON <= res.t[rise] < ON + 0.05                 # detection delay: a few samples
    assert OFF <= res.t[fall] <= OFF + RAMP
    # hysteresis: while the push fades, still flagged while the largest joint is between
    # RELEASE x its threshold and its threshold
    ratio = np.max(np.abs(r) / THRESHOLDS, axis=1)
    assert np.any((ratio < 1) & (ratio > RELEASE) & np.array(flags))
    wait_for_log(c.ros, c.proc, "collision cleared")
    assert c.proc.output().count("collision: estimated external torque") == 1


def bad_messages(res):
    t, q, qd, tau = res.t[-1], res.q[-1], res.qd[-1], res.tau[-1]
    later = t + 0.005
    return {   # log text of the cause -> a message that must be refused
        "position has 5 values": state(later, q[:5], qd, tau),
        "velocity contains NaN": state(later, q, [0, 0, np.nan, 0, 0, 0], tau),
        "effort has 7 values": state(later, q, qd, [*tau, 0.0]),
        "not joints of the model": state(later, [*q, 0.0], [*qd, 0.0], [*tau, 0.0], [*NAMES, "gripper"]),
        "lacks joints": state(later, q[:5], qd[:5], tau[:5], NAMES[:5]),
        "is the previous one's": state(t, q, qd, tau),          # a paused simulator
        "zero stamp": state(Time(), q, qd, tau),
    }


def refused(name):
    """A predicate on /diagnostics: the node ``name``'s count of refused joint_states."""
    def count(m):
        s = [s for s in m.status if s.name == name]
        values = {kv.key: kv.value for kv in s[0].values} if s else {}
        return int(values.get("refused joint_states", -1))
    return count


def test_bad_messages_are_refused_once_per_cause_and_the_node_keeps_serving(ros, run):
    c, res, _ = run
    n = len(c.tau.msgs)
    diagnostics = Latest(ros, DiagnosticArray, "/diagnostics")
    count = refused("/external_torque_observer")
    try:
        for k in range(3):      # 7 messages a round: within the queue depth (10), none dropped
            for msg in bad_messages(res).values():
                c.pub.publish(msg)
            diagnostics.wait(lambda m: count(m) == 7 * (k + 1), what=f"{7 * (k + 1)} refused")
    finally:
        diagnostics.destroy()
    t = res.t[-1] + 0.01
    c.send(state(t, res.q[-1], res.qd[-1], res.tau[-1]))     # then a good one is answered
    ros.spin_until(lambda: len(c.tau.msgs) > n, 30.0, "the answer to the good message")
    assert [seconds(m.header.stamp) for m in c.tau.msgs[n:]] == [seconds(stamp(t))]
    log = c.proc.output()
    for text in bad_messages(res):
        assert log.count(text) == 1, (text, log)
    assert c.proc.running()


def test_diagnostics_report_the_largest_torque_against_its_threshold(ros, run):
    c = run[0]
    name = "/external_torque_observer"
    diagnostics = Latest(ros, DiagnosticArray, "/diagnostics")
    try:
        report = diagnostics.wait(lambda m: any(s.name == name for s in m.status),
                                  what="a report of the observer")
        s = next(s for s in report.status if s.name == name)
        values = {kv.key: kv.value for kv in s.values}
        r = np.array(c.tau.msgs[-1].effort)
        j = int(np.argmax(np.abs(r) / THRESHOLDS))
        assert float(values["largest estimated torque (N m)"]) == pytest.approx(abs(r[j]), rel=1e-3)
        assert float(values["threshold at that joint (N m)"]) == THRESHOLDS[j]
        assert int(values["refused joint_states"]) == 21
        assert int(values["sent collision"]) == len(c.collision.msgs)
    finally:
        diagnostics.destroy()


@pytest.mark.parametrize("params, text", [
    ({"collision_release": 2.0}, "Parameter collision_release out of range Min: 0.0, Max: 1.0"),
    ({"collision_thresholds": [1.0, 2.0]}, "'collision_thresholds' has 2 values"),
    ({"gain": 0.0}, "'gain' must be > 0"),
])
def test_bad_parameters_stop_the_node_with_one_line(ros, params, text):
    proc = ros.start("external_torque_observer", params, ros_args=["-r", "__ns:=/bad"],
                     expect_running=False)
    ros.spin_until(lambda: not proc.running(), 60.0, "the node to exit")
    assert proc.proc.returncode == 2
    out = proc.output()
    line, = [x for x in out.splitlines() if "external_torque_observer: cannot start: " in x]
    assert text in line, out
    assert "Traceback" not in out


def test_a_payload_set_while_running_is_part_of_the_model(ros, run):
    """The arm held still at Q0 with a 3 kg payload in the plant (effort = the holding
    torques of the loaded arm): without the payload in the model the observer reads its
    weight as an external torque, g(q) - g_loaded(q); with payload.* set it reads zero."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter
    c = run[0]
    mass, com = 3.0, [0.0, 0.0, 0.05]
    loaded = ROBOT.with_payload(mass, com=com)
    tau = loaded.gravity_torques(Q0)
    t0 = 100.0                      # a gap after the earlier samples: the observer restarts

    def hold(t_start):
        for k in range(60):         # 0.6 s at 100 Hz: 120 time constants of the observer
            c.send(state(t0 + t_start + 0.01 * k, Q0, np.zeros(6), tau))
        return np.array(c.tau.msgs[-1].effort)

    expected = ROBOT.gravity_torques(Q0) - tau
    assert np.max(np.abs(expected)) > 1.0
    np.testing.assert_allclose(hold(0.0), expected, rtol=1e-6, atol=1e-6)
    client = ros.node.create_client(SetParameters, "external_torque_observer/set_parameters")
    req = SetParameters.Request(parameters=[
        Parameter("payload.mass", value=mass).to_parameter_msg(),
        Parameter("payload.com", value=com).to_parameter_msg()])
    assert all(r.successful for r in ros.call(client, req).results)
    np.testing.assert_allclose(hold(0.6), np.zeros(6), rtol=0, atol=1e-6)
