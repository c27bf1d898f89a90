"""Property-based tests (hypothesis) of every message handler of the three nodes.

The nodes are built in this process (not spun: their timers never fire here) and their
handlers called directly with arbitrary message contents: names (known, unknown, repeated,
empty), lengths, NaN, Inf, huge finite values, empty messages. Each handler must never
raise, and must either accept the message -- with the numbers an oracle written here
independently of the node computes -- or refuse it, counting it and logging the reason.
"""
import math

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import WrenchStamped
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.ros import common
from serial_dynamics.ros.computed_torque_controller import ComputedTorqueController
from serial_dynamics.ros.inverse_dynamics import InverseDynamics
from serial_dynamics.ros.simulator import Simulator
from serial_dynamics.trajectory import Waypoints

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
PROPERTIES = settings(max_examples=120, deadline=None, database=None,
                      suppress_health_check=[HealthCheck.function_scoped_fixture,
                                             HealthCheck.too_slow])

# ------------------------------------------------------------------ strategies
special = st.sampled_from([0.0, -0.0, 1e308, -1e308, 1e6, -1e6, 1e6 * (1 + 1e-15), 1.5e6,
                           math.nan, math.inf, -math.inf, 5e-324])
number = st.one_of(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0), special,
                   st.floats(allow_nan=True, allow_infinity=True))
tame = st.floats(-3.0, 3.0)
joint_names = st.one_of(
    st.permutations(NAMES), st.permutations(NAMES),
    st.permutations(NAMES).map(lambda x: list(x)[:5]),                          # missing one
    st.permutations(NAMES + ["gripper"]),                                       # an extra
    st.lists(st.sampled_from(NAMES + ["gripper", "", "elbow_joint "]), max_size=8))


def values(n, good=tame):
    """n numbers, mostly tame (so that many messages are good), sometimes anything;
    sometimes a wrong length."""
    return st.one_of(st.lists(good, min_size=n, max_size=n),
                     st.lists(number, min_size=n, max_size=n),
                     st.lists(number, max_size=8))


@st.composite
def trajectories(draw):
    """Half of them well formed (maybe with one special number put in), half anything."""
    well_formed = draw(st.booleans())
    names = list(draw(st.permutations(NAMES) if well_formed else joint_names))
    m = len(names)
    msg = JointTrajectory(joint_names=names)
    msg.header.stamp.sec = draw(st.sampled_from([0, 1]))
    fields = {f: draw(st.sampled_from(["full", "empty"] + ([] if well_formed else ["any"])))
              for f in ("velocities", "accelerations")}
    full = st.lists(tame, min_size=m, max_size=m)
    t = draw(st.sampled_from([0, 0, 1] + ([] if well_formed else [-10**9])))   # ns
    for _ in range(draw(st.integers(1 if well_formed else 0, 4))):
        sec, nanosec = divmod(t, 10**9)
        pt = JointTrajectoryPoint(positions=draw(full if well_formed else values(m)),
                                  time_from_start=Duration(sec=sec, nanosec=nanosec))
        for f, how in fields.items():
            setattr(pt, f, [] if how == "empty" else draw(values(m) if how == "any" else full))
        msg.points.append(pt)
        t += draw(st.sampled_from([10**9, 250_000_000, 1] + ([] if well_formed else [0, -10**9])))
    if well_formed and draw(st.integers(0, 2)) == 0:            # one special number
        pt = draw(st.sampled_from(msg.points))
        f = draw(st.sampled_from([f for f in ("positions", "velocities", "accelerations")
                                  if len(getattr(pt, f))]))
        row = list(getattr(pt, f))
        row[draw(st.integers(0, m - 1))] = draw(special)
        setattr(pt, f, row)
    return msg


# ------------------------------------------------------------------ oracle
def ok_names(names, extra=False, all_=True):
    """Model indices of the names if a node takes them, else None."""
    if not 0 < len(names) <= common.MAX_NAMES or len(set(names)) != len(names):
        return None
    if not extra and not set(names) <= set(NAMES):
        return None
    if all_ and not set(names) >= set(NAMES):
        return None
    return names


def ok_numbers(x, bound=common.MAX_VALUE):
    a = np.asarray(x, dtype=float)
    return bool(np.all(np.isfinite(a)) and (bound is None or np.all(np.abs(a) <= bound)))


def expected_trajectory(msg):
    """(t, q, qd, qdd in model order, have_v, have_a) if the trajectory is usable, else None."""
    names = list(msg.joint_names)
    if ok_names(names) is None or not 0 < len(msg.points) <= common.MAX_POINTS:
        return None
    m, order = len(names), [names.index(x) for x in NAMES]
    arrays, have = [], []
    for f in ("positions", "velocities", "accelerations"):
        rows = [list(getattr(p, f)) for p in msg.points]
        if f != "positions" and all(len(r) == 0 for r in rows):
            arrays.append(np.zeros((len(rows), 6)))
            have.append(False)
            continue
        if any(len(r) != m for r in rows) or not ok_numbers(rows):
            return None
        arrays.append(np.array(rows)[:, order])
        have.append(True)
    t = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points])
    return (t, *arrays, have[1], have[2])


# ------------------------------------------------------------------ harness
class Log:
    def __init__(self):
        self.lines = []

    def warning(self, text):
        self.lines.append(text)

    info = error = warning


class Sink:
    def __init__(self):
        self.msgs = []

    def publish(self, msg):
        self.msgs.append(msg)


def outcome(node, where, call):
    """Run ``call``; 'accepted', or 'rejected' after checking that the refusal was counted
    and its cause logged (the first time it came up)."""
    before = node.reject.refused.get(where, 0)
    keys = set(node.reject.counts)
    call()
    if node.reject.refused.get(where, 0) == before:
        event("accepted")
        return "accepted"
    event("rejected")
    assert node.reject.refused[where] == before + 1
    new = set(node.reject.counts) - keys
    assert all(k[0] == where for k in new)
    assert any(line.startswith(f"rejected {where}: ") for line in node.reject.logger.lines)
    return "rejected"


@pytest.fixture(scope="module")
def nodes(ros):    # ros: rclpy is initialized in this process
    overrides = [Parameter("robot_description_timeout", value=0.0),
                 Parameter("start_paused", value=True), Parameter("clamp_effort", value=True)]
    made = {}
    try:
        for cls in (InverseDynamics, ComputedTorqueController, Simulator):
            params = overrides if cls is Simulator else overrides[:1]
            node = made[cls.NAME] = cls(namespace="/properties", parameter_overrides=params)
            node.reject.logger = Log()
            if hasattr(node, "pub"):
                node.pub = Sink()
        yield made
    finally:
        for node in made.values():
            node.close()
            node.destroy_node()


# ------------------------------------------------------------------ inverse dynamics
@PROPERTIES
@given(msg=trajectories())
def test_inverse_dynamics_request(nodes, msg):
    node = nodes["inverse_dynamics"]
    node.wrench = None
    node.pub.msgs.clear()
    expected = expected_trajectory(msg)
    if expected is not None:
        _, q, qd, qdd, _, _ = expected
        with np.errstate(all="ignore"):
            tau = ROBOT.inverse_dynamics(q, qd, qdd)
        if not np.all(np.isfinite(tau)):
            expected = None
    result = outcome(node, "inverse_dynamics/request", lambda: node.on_request(msg))
    assert result == ("rejected" if expected is None else "accepted")
    if expected is not None:
        (out,) = node.pub.msgs
        assert list(out.joint_names) == NAMES and len(out.points) == len(msg.points)
        np.testing.assert_allclose([p.effort for p in out.points], tau, rtol=1e-9,
                                   atol=1e-9 * (1 + np.max(np.abs(tau))))
        np.testing.assert_array_equal([p.positions for p in out.points], q)
    else:
        assert not node.pub.msgs


@PROPERTIES
@given(w=st.one_of(st.lists(tame.map(lambda x: 100 * x), min_size=6, max_size=6),
                  st.lists(number, min_size=6, max_size=6)),
       frame=st.sampled_from(["", "base_link", "tool0", "camera"]))
def test_inverse_dynamics_tip_wrench(nodes, w, frame):
    node = nodes["inverse_dynamics"]
    node.wrench = None
    msg = WrenchStamped()
    msg.header.frame_id = frame
    f, m = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, m.x, m.y, m.z = w
    good = ok_numbers(w) and frame != "camera"
    assert outcome(node, "tip_wrench", lambda: node.on_wrench(msg)) == \
        ("accepted" if good else "rejected")
    if good:
        np.testing.assert_array_equal(node.wrench, w)
        assert node.wrench_in_tip == (frame == "tool0")
    else:
        assert node.wrench is None
    node.wrench = None


# ------------------------------------------------------------------ controller
@pytest.fixture()
def controller(nodes):
    node = nodes["computed_torque_controller"]
    node.ctl.state = node.ctl.reference = None
    node.on_state(JointState(name=NAMES, position=[0.1] * 6, velocity=[0.0] * 6))
    node.pub.msgs.clear()
    return node


def check_command(node):
    """on_timer never raises; what it sends is finite."""
    node.pub.msgs.clear()
    node.on_timer()
    assert all(np.all(np.isfinite(m.data)) and len(m.data) == 6 for m in node.pub.msgs)


@PROPERTIES
@given(names=joint_names, data=st.data())
def test_controller_joint_states(controller, names, data):
    node = controller
    msg = JointState(name=names, position=data.draw(values(len(names))),
                     velocity=data.draw(values(len(names))))
    good = (ok_names(names, extra=True) is not None and len(msg.position) == len(names)
            == len(msg.velocity) and ok_numbers(msg.position) and ok_numbers(msg.velocity))
    before = node.ctl.state
    assert outcome(node, "joint_states", lambda: node.on_state(msg)) == \
        ("accepted" if good else "rejected")
    if good:
        pos, vel = dict(zip(names, msg.position)), dict(zip(names, msg.velocity))
        np.testing.assert_array_equal(node.ctl.state[1], [pos[x] for x in NAMES])
        np.testing.assert_array_equal(node.ctl.state[2], [vel[x] for x in NAMES])
    else:
        assert node.ctl.state is before
    check_command(node)


@PROPERTIES
@given(msg=trajectories())
def test_controller_desired_trajectory(controller, msg):
    node = controller
    expected = expected_trajectory(msg)
    if expected is not None:
        t, q, _, _, have_v, have_a = expected
        if np.any(np.diff(t) <= 0) or t[0] < 0 or (have_a and not have_v):
            expected = None
    before = node.ctl.reference
    assert outcome(node, "desired_trajectory", lambda: node.on_trajectory(msg)) == \
        ("accepted" if expected is not None else "rejected")
    if expected is not None:
        start, traj = node.ctl.reference
        np.testing.assert_array_equal(traj.sample(t[-1] + 1.0)[0], q[-1])   # holds the last
    else:
        assert node.ctl.reference is before
    check_command(node)


def test_controller_huge_gains_send_nothing_and_say_why(controller):
    node, kp = controller, controller.ctl.kp
    try:
        node.ctl.kp = np.full(6, 1e306)
        node.on_state(JointState(name=NAMES, position=[-1e5] * 6, velocity=[0.0] * 6))
        node.ctl.reference = (0.0, Waypoints([0.0], np.full((1, 6), 1e5)))
        check_command(node)
        assert not node.pub.msgs
        assert any("rejected effort_commands" in x for x in node.reject.logger.lines)
    finally:
        node.ctl.kp = kp


# ------------------------------------------------------------------ simulator
@PROPERTIES
@given(data=st.one_of(st.lists(tame.map(lambda x: 100 * x), min_size=6, max_size=6),
                      values(6)))
def test_simulator_effort_commands(nodes, data):
    node = nodes["simulator"]
    before = node.session.hold.tau.copy()
    good = len(data) == 6 and ok_numbers(data, bound=None)
    msg = Float64MultiArray(data=data)
    assert outcome(node, "effort_commands", lambda: node.on_effort(msg)) == \
        ("accepted" if good else "rejected")
    np.testing.assert_array_equal(node.session.hold.tau, np.clip(data, -node.session.limit, node.session.limit) if good
                                  else before)


@PROPERTIES
@given(names=joint_names, data=st.data())
def test_simulator_joint_commands(nodes, names, data):
    node = nodes["simulator"]
    before = node.session.hold.tau.copy()
    msg = JointState(name=names, effort=data.draw(values(len(names), tame.map(lambda x: 100 * x))))
    good = (ok_names(names, all_=False) is not None and len(msg.effort) == len(names)
            and ok_numbers(msg.effort, bound=None))
    assert outcome(node, "joint_commands", lambda: node.on_joint_command(msg)) == \
        ("accepted" if good else "rejected")
    expected = before.copy()
    if good:
        for x, e in zip(names, msg.effort):
            j = NAMES.index(x)
            expected[j] = np.clip(e, -node.session.limit[j], node.session.limit[j])
    np.testing.assert_array_equal(node.session.hold.tau, expected)


# ------------------------------------------------------------------ bounds, before looking
class Untouchable(list):
    """A sequence of a given length that fails if anything in it is looked at."""

    def __init__(self, n):
        super().__init__()
        self.n = n

    def __len__(self):
        return self.n

    def __iter__(self):
        raise AssertionError("looked at")

    __getitem__ = __iter__


def test_oversized_messages_are_refused_before_their_contents_are_looked_at():
    with pytest.raises(common.Rejected, match="names 20001 joints; at most 1000"):
        common.name_index(Untouchable(20_001), ROBOT, "joint_states")
    msg = JointTrajectory(joint_names=NAMES)
    msg.points = Untouchable(common.MAX_POINTS + 1)
    with pytest.raises(common.Rejected, match="has 10001 points; at most 10000"):
        common.trajectory_arrays(msg, ROBOT, "desired_trajectory")
