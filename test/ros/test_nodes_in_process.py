"""Issue 20 item 5, in this process (nodes built, not spun): every parameter but the
settable ones is read-only, ``use_sim_time`` included; refused parameter sets are logged
once per cause, not once per set; /diagnostics names each input one way, so that
``received X`` and ``refused X`` pair up."""
import time

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from serial_dynamics.ros.computed_torque_controller import ComputedTorqueController
from serial_dynamics.ros.external_torque_observer import ExternalTorqueObserver
from serial_dynamics.ros.inverse_dynamics import InverseDynamics
from serial_dynamics.ros.simulator import Simulator

SETTABLE = {"payload.mass", "payload.com", "payload.inertia", "payload.link"}


@pytest.fixture(scope="module")
def nodes(ros):    # ros: rclpy is initialized in this process
    made = {}
    try:
        for cls in (Simulator, InverseDynamics, ComputedTorqueController, ExternalTorqueObserver):
            params = [Parameter("robot_description_timeout", value=0.0)]
            if cls is Simulator:
                params.append(Parameter("start_paused", value=True))
            made[cls.NAME] = cls(namespace="/node_parameters", parameter_overrides=params)
        yield made
    finally:
        for node in made.values():
            node.close()
            node.destroy_node()


def test_every_parameter_but_the_settable_ones_is_read_only(nodes):
    for name, node in nodes.items():
        settable = SETTABLE | ({"mode"} if name == "computed_torque_controller" else set())
        names = node.list_parameters([], 0).names
        assert "use_sim_time" in names and settable <= set(names), (name, names)
        writable = {x for x in names if not node.describe_parameter(x).read_only}
        assert writable == settable, (name, writable)
        # use_sim_time set while running: refused (a controller without /clock would stop)
        result, = node.set_parameters([Parameter("use_sim_time", value=True)])
        assert not result.successful and "read-only" in result.reason, (name, result)
        assert node.get_parameter("use_sim_time").value is False
        # the settable ones stay settable
        result, = node.set_parameters([Parameter("payload.mass", value=0.5)])
        assert result.successful, (name, result)
        result, = node.set_parameters([Parameter("payload.mass", value=0.0)])
        assert result.successful, (name, result)
    ctl = nodes["computed_torque_controller"]
    result, = ctl.set_parameters([Parameter("mode", value="pd_gravity")])
    assert result.successful and ctl.ctl.mode == "pd_gravity"
    ctl.set_parameters([Parameter("mode", value="computed_torque")])


def test_refused_parameter_sets_are_logged_once_per_cause(nodes, capfd):
    ctl = nodes["computed_torque_controller"]
    capfd.readouterr()
    for k in range(300):          # a storm: every set refused, with its reason
        result, = ctl.set_parameters([Parameter("payload.mass", value=-1.0 - k)])
        assert not result.successful and "negative" in result.reason, result
        result, = ctl.set_parameters([Parameter("mode", value=f"impedance{k}")])
        assert not result.successful and "must be one of" in result.reason, result
    err = capfd.readouterr().err
    lines = [x for x in err.splitlines() if "rejected" in x]
    # before: 600 lines; now the first of each cause (repeats: a count every 10 s)
    assert len(lines) <= 4, "\n".join(lines[:10])
    assert sum("payload parameters" in x for x in lines) >= 1
    assert sum("parameter 'mode' must be one of" in x for x in lines) >= 1


def _callback(node, topic):
    (sub,) = [s for s in node.subscriptions if s.topic_name.endswith(topic)]
    return lambda msg: sub.callback(msg, {})        # no message info: no sequence number


def test_diagnostics_pair_received_and_refused_by_one_name(nodes):
    sim, ids = nodes["simulator"], nodes["inverse_dynamics"]
    bad_state = JointState(name=["no_such_joint"], position=[0.0])
    _callback(sim, "/simulator/set_state")(bad_state)
    _callback(sim, "external_wrench")(WrenchStamped())          # a zero wrench: accepted
    bad_wrench = WrenchStamped()
    bad_wrench.wrench.force.x = np.nan
    _callback(sim, "external_wrench")(bad_wrench)
    _callback(ids, "tip_wrench")(bad_wrench)
    for node, names in ((sim, {"~/set_state", "external_wrench"}),
                        (ids, {"inverse_dynamics/tip_wrench"})):
        assert set(node.reject.refused) == names, node.reject.refused
        assert set(node.reject.refused) <= set(node.reject.received), node.reject.received
    assert sim.reject.received["external_wrench"] == 2
    assert sim.reject.refused["external_wrench"] == 1


class Sink:
    def __init__(self):
        self.msgs = []

    def publish(self, msg):
        self.msgs.append(msg)


def test_the_observer_restarts_on_a_stamp_jump_back_or_far_forward(nodes, capfd):
    """Before: after a simulator restart (stamps from 0 again) or one stamp far ahead, every
    joint_states was refused as 'stamp not increasing', for good."""
    obs = nodes["external_torque_observer"]
    obs.pub_tau, obs.pub_w, obs.pub_c = Sink(), Sink(), Sink()
    robot = obs.robot
    q = np.array([0.1, -1.2, 1.4, -1.5, -1.5, 0.2])
    qd = np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0])
    tau = robot.gravity_torques(q) + 5.0          # 5 N m the dynamics do not explain

    def send(t):
        msg = JointState(name=robot.joint_names, position=q.tolist(), velocity=qd.tolist(),
                         effort=tau.tolist())
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t - int(t)) * 1e9)
        obs.on_state(msg)
        return np.array(obs.pub_tau.msgs[-1].effort)

    capfd.readouterr()
    refused = dict(obs.reject.refused)
    times = [100 + 0.001 * k for k in range(50)]            # a run
    r = [send(t) for t in times]
    assert np.all(np.abs(r[-1]) > 1.0)                     # the estimate has grown
    for start in (0.001, 1e6, 0.5, 2.0):        # restarted; far ahead; back again; a pause
        r0 = send(start)
        assert np.all(r0 == 0.0), r0                      # a new start: from the momentum
        r1 = send(start + 0.001)
        assert np.any(r1 != 0.0)                           # and the estimate goes on
    assert len(obs.pub_tau.msgs) == 50 + 8                 # every message answered
    assert obs.reject.refused == refused                   # none refused
    assert obs.monitor.restarts == 4
    err = capfd.readouterr().err
    assert err.count("jumped back") == 1 and err.count("jumped forward") == 1, err


def test_a_loss_before_the_node_is_counted_and_warned_about(ros):
    """A burst of 300 states into an observer's queue of 10 (the test its one publisher):
    the states replaced before the node took them are the gaps in the publisher's sequence
    numbers, counted as lost and reported with level WARN. Before: in no count, level OK."""
    obs = ExternalTorqueObserver(namespace="/loss", parameter_overrides=[
        Parameter("robot_description_timeout", value=0.0)])
    obs.pub_tau, obs.pub_w, obs.pub_c = Sink(), Sink(), Sink()
    obs.reject._diagnostics = Sink()
    executor = SingleThreadedExecutor()
    executor.add_node(obs)
    pub = ros.node.create_publisher(JointState, "/loss/joint_states", 10)
    names = obs.robot.joint_names
    try:
        ros.spin_until(lambda: pub.get_subscription_count() > 0, 30, "the observer")
        ros.spin_for(0.5)

        def send(k):
            msg = JointState(name=names, position=[0.0] * 6, velocity=[0.0] * 6,
                             effort=[0.0] * 6)
            msg.header.stamp.sec, msg.header.stamp.nanosec = 500, 1000 * (k + 1)
            pub.publish(msg)

        def spin(seconds):
            deadline = time.monotonic() + seconds
            while time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)

        send(0)                    # the first one taken: where the count starts
        spin(1.0)
        assert obs.reject.received["joint_states"] == 1
        for k in range(1, 301):
            send(k)
        spin(2.0)
        taken = obs.reject.received["joint_states"] - 1
        lost = obs.reject.lost.get("joint_states", 0)
        assert 0 < taken < 300 and taken + lost == 300, (taken, lost)
        obs.reject.report()        # the first report that has the loss warns; later: OK
        reports = [(m.status[0].level, {kv.key: kv.value for kv in m.status[0].values})
                   for m in obs.reject._diagnostics.msgs]
        first = next(k for k, (_, v) in enumerate(reports) if "lost joint_states" in v)
        assert reports[first][0] == DiagnosticStatus.WARN
        assert reports[-1][1]["lost joint_states"] == str(lost)
    finally:
        ros.node.destroy_publisher(pub)
        executor.remove_node(obs)
        obs.destroy_node()


@pytest.mark.parametrize("cls", [ComputedTorqueController, ExternalTorqueObserver])
def test_the_start_up_payload_is_the_loop_s_model_and_a_set_swaps_it(ros, cls):
    """Before (a refactor's slip): the controller and observer dropped the payload.* given at
    start-up; their loops ran on the robot without it."""
    node = cls(namespace="/start_up_payload", parameter_overrides=[
        Parameter("robot_description_timeout", value=0.0), Parameter("payload.mass", value=2.0),
        Parameter("payload.com", value=[0.0, 0.0, 0.05])])
    try:
        loop = node.ctl if cls is ComputedTorqueController else node.monitor
        q = np.array([0.1, -1.2, 1.4, -1.5, -1.5, 0.2])
        plain = node.robot.without_payload()
        expected = plain.with_payload(2.0, (0.0, 0.0, 0.05)).gravity_torques(q)
        np.testing.assert_array_equal(loop.robot.gravity_torques(q), expected)
        assert np.max(np.abs(expected - plain.gravity_torques(q))) > 1.0
        result, = node.set_parameters([Parameter("payload.mass", value=0.0)])     # put down
        assert result.successful
        np.testing.assert_array_equal(loop.robot.gravity_torques(q),
                                      plain.with_payload(0.0, (0.0, 0.0, 0.05)).gravity_torques(q))
    finally:
        node.close()
        node.destroy_node()
