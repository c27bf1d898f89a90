"""Issue 52: a seeded message fuzz of the four nodes. The simulator (with two contacts on a
ground plane: its ~/contacts/<name> topics), dynamics, computed_torque_controller and
external_torque_observer run in their own processes, each in a namespace of its own; every
batch sends each topic they subscribe to, the dynamics node's services (among them
~/contact_inverse_dynamics: unknown, empty and too many contact links, points and frame flags
of other lengths, a negative or non-finite friction, a base pose on a fixed base), the
simulator's ~/step and the controller's mode a seeded mix of valid messages,
wrong lengths, unknown, duplicate and empty joint names, NaN and Inf, in-bound extremes
(|x| up to common.MAX_VALUE) and values beyond the bound. One batch replays the issue's
sequence: a position target, the command_timeout warning, then positions and velocities of
1e6 (before 3b31d40 the simulation thread died there). After each batch every node must be
healthy: alive, no internal error in its log, every call answered, and its answer to a
valid input the library's numbers (the simulator: joint_states again after ~/reset and
~/pause false, and the ground's forces on the contacts within the friction cone, where the
links touch it). The fuzz found one more defect: a ~/time_parameterize grid of 2**32 - 1
intervals made the dynamics node set out to allocate 15-32 GiB and stop answering (now refused
beyond payload_timing.MAX_GRID; paths beyond MAX_WAYPOINTS and requests beyond
contact_requests.MAX_CONTACTS are refused likewise)."""
import numpy as np
import pytest
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point, Vector3, Wrench, WrenchStamped
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.observers import MomentumObserver
from serial_dynamics.ros import payload_timing
from serial_dynamics.ros.contact_requests import MAX_CONTACTS
from serial_dynamics.ros.common import MAX_VALUE, Rejected

from conftest import HOME, MATCH_SETTLE, Latest, wait_for_log

srv = pytest.importorskip("serial_dynamics_interfaces.srv")

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
SEED, BATCHES, ISSUE_BATCH = 5200, 6, 1      # batch b draws from SEED + b
PER_TOPIC = 8                                # fuzz messages per topic and batch
NS = {"sim": "/fuzz_sim", "dyn": "/fuzz_dyn", "ctl": "/fuzz_ctl", "obs": "/fuzz_obs"}
GAIN = 50.0                                  # the observer's default gain (1/s)
HEALTH_STAMP = 2_000_000_000                 # s: the observer's health samples, far from any
                                             # fuzzed stamp (a restart of the estimate)
BEYOND = [MAX_VALUE * (1 + 1e-9), -1e7, 1e308, -1e308, np.nan, np.inf, -np.inf]
SERVICES = {"inverse_dynamics": srv.InverseDynamics, "forward_dynamics": srv.ForwardDynamics,
            "mass_matrix": srv.MassMatrix, "trajectory_torques": srv.TrajectoryTorques,
            "task_space": srv.TaskSpace, "estimate_payload": srv.EstimatePayload,
            "time_parameterize": srv.TimeParameterize,
            "contact_inverse_dynamics": srv.ContactInverseDynamics}
CONTACTS = ["forearm_link", "wrist_3_link"]      # the simulator's, on the ground ...
GROUND = 0.3                                      # m: ... at this height (they start above it)
BAD_LOG = ("internal error", "simulation stopped", "Traceback")


# ------------------------------------------------------------------ what a batch sends
def floats(rng, n):
    """n values of one drawn kind: ordinary, in-bound extremes (one exactly +-MAX_VALUE),
    beyond the bound (NaN and Inf among them), or ordinary with one bad value."""
    kind = rng.integers(4)
    x = rng.uniform(-3.0, 3.0, n)
    if kind == 1 and n:
        x = rng.choice([-1.0, 1.0], n) * rng.uniform(0.5, 1.0, n) * MAX_VALUE
        x[rng.integers(n)] = rng.choice([-MAX_VALUE, MAX_VALUE])
    elif kind == 2:
        x = rng.choice(BEYOND, n)
    elif kind == 3 and n:
        x[rng.integers(n)] = rng.choice(BEYOND + [MAX_VALUE, -MAX_VALUE])
    return x.tolist()


def names(rng):
    """Joint names: the model's order, shuffled, a subset, one unknown, one twice, none,
    blank, or one joint too many."""
    kind = rng.integers(8)
    if kind == 0:
        return list(NAMES)
    if kind == 1:
        return rng.permutation(NAMES).tolist()
    if kind == 2:
        return rng.choice(NAMES, rng.integers(1, len(NAMES)), replace=False).tolist()
    if kind == 3:
        return NAMES[:-1] + ["no_such_joint"]
    if kind == 4:
        return NAMES + [NAMES[rng.integers(len(NAMES))]]
    return [[], [""] * len(NAMES), NAMES + ["gripper_joint"]][kind - 5]


def length(rng, m):
    """Mostly ``m``; else 0, one fewer or one more."""
    return int(m if rng.random() < 0.7 else max(0, m + rng.choice([-1, 1, -m])))


def stamp(rng):
    kind = rng.integers(4)
    sec = [0, int(rng.integers(1, 1_000_000)), 2**31 - 1, int(rng.integers(1, 100))][kind]
    return Time(sec=sec, nanosec=0 if kind == 0 else int(rng.integers(1_000_000_000)))


def joint_state(rng, fields=("position", "velocity", "effort")):
    msg = JointState(name=names(rng))
    for field in fields:
        if rng.random() > 0.15:          # else the field stays empty
            setattr(msg, field, floats(rng, length(rng, len(msg.name))))
    msg.header.stamp = stamp(rng)
    return msg


def trajectory(rng, min_points=0):
    jn = names(rng) if rng.random() < 0.6 else list(NAMES)
    times = np.sort(rng.uniform(-0.1, 2.0, 5)) if rng.random() < 0.8 else rng.uniform(-1, 2, 5)
    msg = JointTrajectory(joint_names=jn)
    for t in times[:rng.integers(min_points, 5)]:
        sec = int(np.floor(t))
        msg.points.append(JointTrajectoryPoint(
            positions=floats(rng, length(rng, len(jn))),
            velocities=floats(rng, length(rng, len(jn))) if rng.random() < 0.5 else [],
            accelerations=floats(rng, length(rng, len(jn))) if rng.random() < 0.4 else [],
            time_from_start=Duration(sec=sec, nanosec=int((t - sec) * 1e9))))
    msg.header.stamp = stamp(rng) if rng.random() < 0.3 else Time()
    return msg


def efforts(rng):
    return Float64MultiArray(data=floats(rng, length(rng, len(NAMES))))


def wrench(rng):
    w = floats(rng, 6)
    return Wrench(force=Vector3(x=w[0], y=w[1], z=w[2]), torque=Vector3(x=w[3], y=w[4], z=w[5]))


def wrench_stamped(rng, frames):
    msg = WrenchStamped(wrench=wrench(rng))
    msg.header.frame_id = str(rng.choice(frames))
    return msg


def state_fields(rng, request, accelerations="accelerations"):
    """A dynamics service request's state: names (or none), positions, velocities and
    ``accelerations`` (or efforts)."""
    request.joint_names = names(rng) if rng.random() < 0.6 else []
    m = len(request.joint_names) or len(NAMES)
    request.positions = floats(rng, length(rng, m))
    for field in ("velocities", accelerations):
        setattr(request, field, floats(rng, length(rng, m)) if rng.random() < 0.7 else [])
    return request


LINKS = ["", ROBOT.tip_link, ROBOT.base_link, "wrist_2_link", "no_such_link"]


def service_request(rng, name):
    """A fuzzed request of the dynamics service ``name``."""
    req = SERVICES[name].Request()
    if name in ("inverse_dynamics", "forward_dynamics"):
        state_fields(rng, req, "accelerations" if name == "inverse_dynamics" else "efforts")
        req.tip_wrench = wrench(rng) if rng.random() < 0.5 else Wrench()
    elif name == "mass_matrix":
        req.joint_names = names(rng) if rng.random() < 0.6 else []
        req.positions = floats(rng, length(rng, len(req.joint_names) or len(NAMES)))
    elif name == "trajectory_torques":
        req.trajectory = trajectory(rng)
    elif name == "task_space":
        state_fields(rng, req)
        req.link = str(rng.choice(LINKS))
        req.damping = float(rng.choice([0.0, 0.01, -1.0, np.nan, np.inf, MAX_VALUE]))
    elif name == "estimate_payload":       # never apply: the model stays the library's
        req.window = float(rng.choice([0.0, 1.0, -1.0, np.nan, np.inf, 1e308]))
        req.link = str(rng.choice(LINKS))
    elif name == "contact_inverse_dynamics":     # mostly a good state: the contacts checked
        if rng.random() < 0.3:
            state_fields(rng, req)
        else:
            req.positions, req.velocities = (x.tolist() for x in ROBOT.random_state(rng))
        contact_request(rng, req)
    else:                                  # time_parameterize
        req.path = trajectory(rng, min_points=2) if rng.random() < 0.4 else JointTrajectory(
            joint_names=list(NAMES), points=[JointTrajectoryPoint(positions=ROBOT.random_state(
                rng)[0].tolist()) for _ in range(rng.integers(2, 4))])     # one the solver takes
        if rng.random() < 0.2:             # beyond MAX_WAYPOINTS: a corner at every one
            many = int(rng.choice([payload_timing.MAX_WAYPOINTS + 1,
                                   5 * payload_timing.MAX_WAYPOINTS]))
            req.path = JointTrajectory(points=[JointTrajectoryPoint(positions=x) for x in
                                               rng.uniform(-0.01, 0.01, (many, 6)).tolist()])
        for field in ("velocity_limits", "acceleration_limits", "effort_limits"):
            if rng.random() < 0.3:
                setattr(req, field, np.abs(floats(rng, int(rng.choice([1, 6, 5])))).tolist())
        req.grid = int(rng.choice([0, 2, 50, 2**32 - 1]))      # the most a uint32 holds
    return req


def contact_request(rng, req):
    """The contact fields of a fuzzed ~/contact_inverse_dynamics request (a fixed base: the
    forces are zero, the efforts M a + b): links (valid, a bad one among them, none, or more
    than MAX_CONTACTS), points and frame flags (none, one each, or a wrong count), friction
    (0, mu, negative, non-finite, huge) and, now and then, base fields a fixed base refuses."""
    k = int(rng.integers(1, 4))
    kind = rng.choice(6, p=[0.4, 0.2, 0.1, 0.1, 0.1, 0.1])
    req.contact_links = [rng.choice(CONTACTS, k).tolist(), rng.choice(LINKS, k).tolist(), [],
                         [CONTACTS[1]] * MAX_CONTACTS, [CONTACTS[1]] * (MAX_CONTACTS + 1),
                         [CONTACTS[0]] * 20 * MAX_CONTACTS][kind]
    m = len(req.contact_links)
    if m <= MAX_CONTACTS + 1 and rng.random() < 0.6:
        req.contact_points = [Point(x=x, y=y, z=z) for x, y, z in
                              np.reshape(floats(rng, 3 * length(rng, m)), (-1, 3)).tolist()]
    if rng.random() < 0.5:
        req.frame_contacts = (rng.random(length(rng, m)) < 0.5).tolist()
    req.friction = float(rng.choice([0.0, 0.0, 0.8, 0.8, -0.5, np.nan, np.inf, 1e308]))
    if rng.random() < 0.1:
        x = floats(rng, 7)
        o = req.base_pose.orientation
        req.base_pose.position.x, o.x, o.y, o.z, o.w = x[0], *x[3:]
    if rng.random() < 0.05:
        req.base_velocity.angular.z = floats(rng, 1)[0]
    return req


def test_time_parameterize_refuses_a_grid_beyond_max_grid():
    """The fuzz's find: the most a uint32 grid holds is refused at once, naming the field
    (before, the solver set out to allocate tens of GiB for it)."""
    path = JointTrajectory(joint_names=list(NAMES), points=[
        JointTrajectoryPoint(positions=q) for q in (HOME, (np.array(HOME) + 0.1).tolist())])
    request = srv.TimeParameterize.Request(path=path, grid=2**32 - 1)
    with pytest.raises(Rejected, match="grid = 4294967295 intervals; at most 10000 are "
                       r"accepted \(0: 200"):
        payload_timing.answer_time_parameterize(ROBOT, request)


# ------------------------------------------------------------------ the nodes and the test's ends
class Fuzz:
    """The four nodes, and this process's publishers, subscriptions and clients for them."""

    def __init__(self, ros):
        self.ros = ros
        sim, dyn, ctl, obs = (NS[k] for k in ("sim", "dyn", "ctl", "obs"))
        self.procs = {
            "simulator": ros.start("simulator", {"initial_positions": HOME, "contacts": CONTACTS,
                                                 "ground.height": GROUND},
                                   ros_args=["-r", f"__ns:={sim}"]),
            "dynamics": ros.start("dynamics", ros_args=["-r", f"__ns:={dyn}"]),
            "controller": ros.start("computed_torque_controller",
                                    ros_args=["-r", f"__ns:={ctl}"]),
            "observer": ros.start("external_torque_observer", ros_args=["-r", f"__ns:={obs}"])}
        pub = lambda kind, topic: ros.node.create_publisher(kind, topic, 100)  # noqa: E731
        self.topics = {         # topic: (publisher, fuzzed message)
            "simulator effort_commands": (pub(Float64MultiArray, f"{sim}/effort_commands"),
                                          efforts),
            "simulator joint_commands": (pub(JointState, f"{sim}/joint_commands"), joint_state),
            "simulator external_wrench": (pub(WrenchStamped, f"{sim}/external_wrench"),
                                          lambda r: wrench_stamped(r, ["", "base_link", "tool0"])),
            "simulator ~/set_state": (pub(JointState, f"{sim}/simulator/set_state"),
                                      lambda r: joint_state(r, ("position", "velocity"))),
            "dynamics inverse_dynamics/request": (pub(JointTrajectory,
                                                      f"{dyn}/inverse_dynamics/request"),
                                                  trajectory),
            "dynamics inverse_dynamics/tip_wrench": (
                pub(WrenchStamped, f"{dyn}/inverse_dynamics/tip_wrench"),
                lambda r: wrench_stamped(r, ["", "base_link", "tool0", "world"])),
            "dynamics joint_states": (pub(JointState, f"{dyn}/joint_states"), joint_state),
            "controller joint_states": (pub(JointState, f"{ctl}/joint_states"), joint_state),
            "controller desired_trajectory": (pub(JointTrajectory, f"{ctl}/desired_trajectory"),
                                              trajectory),
            "observer joint_states": (pub(JointState, f"{obs}/joint_states"), joint_state)}
        self.pub = {k: p for k, (p, _) in self.topics.items()}
        node = ros.node
        self.clients = {name: node.create_client(kind, f"{dyn}/dynamics/{name}")
                        for name, kind in SERVICES.items()}
        self.reset = node.create_client(Trigger, f"{sim}/simulator/reset")
        self.pause = node.create_client(SetBool, f"{sim}/simulator/pause")
        self.step = node.create_client(Trigger, f"{sim}/simulator/step")
        self.params = node.create_client(SetParameters,
                                         f"{ctl}/computed_torque_controller/set_parameters")
        self.states = Latest(ros, JointState, f"{sim}/joint_states", depth=100)
        self.contacts = {c: Latest(ros, WrenchStamped, f"{sim}/simulator/contacts/{c}", 100)
                         for c in CONTACTS}
        self.responses = Latest(ros, JointTrajectory, f"{dyn}/inverse_dynamics/response", 100)
        self.efforts = Latest(ros, Float64MultiArray, f"{ctl}/effort_commands", depth=100)
        self.estimates = Latest(ros, JointState, f"{obs}/estimated_external_torques", 100)
        for proc in self.procs.values():
            wait_for_log(ros, proc, "ready", timeout=150)
        clients = [*self.clients.values(), self.reset, self.pause, self.step, self.params]
        ros.wait_matched(*self.pub.values(), what="the four nodes",
                         also=lambda: all(c.service_is_ready() for c in clients))
        ros.settled.update(clients)      # wait_matched waited MATCH_SETTLE past the match

    def set_mode(self, value):
        req = SetParameters.Request(parameters=[Parameter("mode", value=value).to_parameter_msg()])
        return self.ros.call(self.params, req).results[0]

    def destroy(self):
        for sub in (self.states, self.responses, self.efforts, self.estimates,
                    *self.contacts.values()):
            sub.destroy()
        for proc in self.procs.values():
            proc.stop()


@pytest.fixture(scope="module")
def fuzz(ros):
    f = Fuzz(ros)
    yield f
    f.destroy()


# ------------------------------------------------------------------ a batch
def issue_sequence(f):
    """Issue 52's sequence: one valid position target; past command_timeout (0.5 s) the
    braking warning; then positions of 1e6 rad three times and velocities of 1e6 rad/s
    three times: the step diverges and logs an error (before 3b31d40 from the call site of
    the warning, which ended the simulation thread)."""
    proc, joint = f.procs["simulator"], f.pub["simulator joint_commands"]
    braking, paused = "(command_timeout): braking", "paused at the last good state"
    before = [proc.output().count(text) for text in (braking, paused)]

    def logged(k, text):
        bad = bad_lines(proc)          # a simulator that stopped would wait forever
        assert not bad, f"the simulator logged: {bad}"
        return proc.output().count(text) > before[k]
    joint.publish(JointState(name=NAMES, position=HOME))
    f.ros.spin_until(lambda: logged(0, braking), 30, "the command_timeout warning")
    for field in ("position", "velocity"):
        for _ in range(3):
            joint.publish(JointState(name=NAMES, **{field: [MAX_VALUE] * 6}))
    f.ros.spin_until(lambda: logged(1, paused), 30, "the divergence of the issue's sequence")


def send_batch(f, rng):
    """PER_TOPIC fuzzed messages on every topic, interleaved, and fuzzed calls; the
    answers of the calls (each must come)."""
    calls = []
    for _ in range(PER_TOPIC):
        for pub, make in f.topics.values():
            pub.publish(make(rng))
        f.ros.spin_for(0.01)
    for name in SERVICES:
        for _ in range({"time_parameterize": 2, "contact_inverse_dynamics": 6}.get(name, 4)):
            calls.append((name, f.clients[name].call_async(service_request(rng, name))))
    calls.append(("simulator ~/step", f.step.call_async(Trigger.Request())))
    mode = ["computed_torque", "pd_gravity", "gravity_compensation", "no_such_mode", "",
            3][rng.integers(6)]
    calls.append(("controller mode", f.params.call_async(SetParameters.Request(
        parameters=[Parameter("mode", value=mode).to_parameter_msg()]))))
    f.ros.spin_until(lambda: all(future.done() for _, future in calls), 60,
                     f"the answers to {len(calls)} fuzzed calls ({[n for n, _ in calls]})")
    broken = [(name, future.result().message) for name, future in calls
              if getattr(future.result(), "message", "").startswith("internal error")]
    assert not broken, f"internal errors answered: {broken}"


# ------------------------------------------------------------------ health checks
def bad_lines(proc):
    """The lines of a node's log that say it failed: an internal error (a handler that
    raised), a simulation thread that ended, a traceback."""
    return [line for line in proc.output().splitlines() if any(t in line for t in BAD_LOG)][:5]


def logs_clean(f, rng):
    for name, proc in f.procs.items():
        assert proc.running(), f"the {name} exited:\n{proc.output()[-3000:]}"
        assert not bad_lines(proc), f"the {name} logged: {bad_lines(proc)}"


def simulator_steps(f, rng):
    """Zero wrench (it outlives ~/reset), ~/pause true, ~/reset: the paused simulator
    publishes initial_positions; ~/pause false: the falling arm publishes 20 distinct
    finite states."""
    f.pub["simulator external_wrench"].publish(WrenchStamped())
    f.ros.spin_for(MATCH_SETTLE)
    assert f.ros.call(f.pause, SetBool.Request(data=True)).message == "paused"
    assert f.ros.call(f.reset, Trigger.Request()).success
    for sub in (f.states, *f.contacts.values()):
        sub.clear()
    try:
        f.states.wait(lambda m: np.allclose(m.position, HOME, atol=1e-9), 30,
                      "a joint_states at initial_positions after ~/reset")
    except AssertionError as exc:
        last = [np.round(m.position, 4).tolist() for m in f.states.msgs[-3:]]
        raise AssertionError(f"{exc}; {len(f.states.msgs)} joint_states since, the last "
                             f"{last}") from None
    assert f.ros.call(f.pause, SetBool.Request(data=False)).message == "running"
    seen = set()
    f.states.wait(lambda m: seen.add(tuple(m.position)) or len(seen) >= 20, 30,
                  "20 distinct joint_states after ~/reset and ~/pause false")
    assert np.all(np.isfinite([m.position + m.velocity for m in f.states.msgs]))
    ground_pushes(f)


def ground_pushes(f):
    """The arm falls onto the ground (GROUND below its contacts at HOME): within 30 s a
    ~/contacts/<name> message with a push. Every one since ~/reset: in the simulator's frame
    (base_link), finite, a force alone, the ground's on the link (n = z): f_n >= 0 and
    |f_t| <= mu f_n (Coulomb, ground.friction 1.0), and a push only where the library's
    forward kinematics of the joint_states of the same stamp puts the link's origin on the
    ground (within 5 mm: the step's own motion)."""
    try:
        f.ros.spin_until(lambda: any(m.wrench.force.z > 0 for c in CONTACTS
                                     for m in f.contacts[c].msgs), 30, "a push of the ground")
    except AssertionError:
        got = {c: len(f.contacts[c].msgs) for c in CONTACTS}
        raise AssertionError(f"no push of the ground on {CONTACTS} within 30 s (messages: "
                             f"{got})") from None
    f.ros.spin_for(MATCH_SETTLE)                    # the joint_states of the same stamps
    states = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in f.states.msgs}
    paired = 0
    for c in CONTACTS:
        for m in f.contacts[c].msgs:
            w, t = m.wrench.force, m.wrench.torque
            force = np.array([w.x, w.y, w.z])
            assert m.header.frame_id == ROBOT.base_link, m.header.frame_id
            assert np.all(np.isfinite(force)) and (t.x, t.y, t.z) == (0.0, 0.0, 0.0), m
            assert force[2] >= 0.0 and np.hypot(*force[:2]) <= force[2] * (1 + 1e-9), \
                f"{c}: {force.tolist()} is not in the ground's friction cone (mu 1)"
            state = states.get((m.header.stamp.sec, m.header.stamp.nanosec))
            if state is not None and force[2] > 0:
                paired += 1
                z = ROBOT.forward_kinematics(np.array(state.position), c)[2, 3]
                assert z < GROUND + 5e-3, f"{c} pushed {force.tolist()} N at {z:.4f} m, " \
                    f"above the ground ({GROUND} m)"
    assert paired >= 1, "no push at the stamp of a joint_states"


def dynamics_answers(f, rng):
    """A valid ~/inverse_dynamics call and a valid request on the topic pair (tip wrench
    zeroed first) answer the library's torques."""
    q, qd = ROBOT.random_state(rng)
    qdd = rng.uniform(-2.0, 2.0, ROBOT.dof)
    tau = ROBOT.inverse_dynamics(q, qd, qdd)
    r = f.ros.call(f.clients["inverse_dynamics"], srv.InverseDynamics.Request(
        positions=q.tolist(), velocities=qd.tolist(), accelerations=qdd.tolist()))
    assert r.success, r.message
    np.testing.assert_allclose(r.efforts, tau, rtol=1e-12, atol=1e-10)
    f.pub["dynamics inverse_dynamics/tip_wrench"].publish(WrenchStamped())
    f.ros.spin_for(MATCH_SETTLE)         # another topic: let it arrive first
    request = JointTrajectory(joint_names=list(NAMES), points=[JointTrajectoryPoint(
        positions=q.tolist(), velocities=qd.tolist(), accelerations=qdd.tolist())])
    request.header.frame_id = key = f"health {rng.integers(1 << 30)}"
    f.pub["dynamics inverse_dynamics/request"].publish(request)
    m = f.responses.wait(lambda m: m.header.frame_id == key, 30, "the answer on the topic pair")
    np.testing.assert_allclose(m.points[0].effort, tau, rtol=1e-12, atol=1e-10)
    # ~/contact_inverse_dynamics: on the fixed base, the library's efforts and zero forces
    links = rng.choice(CONTACTS, 2).tolist()
    points = rng.uniform(-0.05, 0.05, (2, 3))
    r = f.ros.call(f.clients["contact_inverse_dynamics"], srv.ContactInverseDynamics.Request(
        positions=q.tolist(), velocities=qd.tolist(), accelerations=qdd.tolist(),
        contact_links=links, contact_points=[Point(x=x, y=y, z=z) for x, y, z in points.tolist()],
        frame_contacts=[True, False], friction=0.8))
    assert r.success, r.message
    tau_c, forces = ROBOT.contact_inverse_dynamics(
        q, qd, qdd, [sd.Contact(c, point=p, frame=k == 0)
                     for k, (c, p) in enumerate(zip(links, points))], friction=0.8)
    np.testing.assert_allclose(r.efforts, tau_c, rtol=1e-12, atol=1e-10)
    got = [[w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]
           for w in r.contact_wrenches]
    assert got == [np.r_[x, np.zeros(6 - len(x))].tolist() for x in forces] == [[0.0] * 6] * 2


def controller_commands(f, rng):
    """In gravity_compensation the command on a valid state is g(q); then back to
    computed_torque (the fuzz goes on in it)."""
    assert f.set_mode("gravity_compensation").successful
    q, qd = ROBOT.random_state(rng)
    g = ROBOT.gravity_torques(q)
    f.pub["controller joint_states"].publish(JointState(name=NAMES, position=q.tolist(),
                                                        velocity=qd.tolist()))
    f.efforts.wait(lambda m: np.allclose(m.data, g, rtol=1e-12, atol=1e-9), 30,
                   f"effort_commands g(q) = {g}")
    assert f.set_mode("computed_torque").successful


def observer_estimates(f, rng, batch):
    """Two valid samples 10 ms apart at a stamp no fuzzed one comes near (the estimate
    restarts there): the estimate of the second is the library observer's."""
    t0 = HEALTH_STAMP + 100 * batch
    samples = [(Time(sec=t0, nanosec=k * 10_000_000), *ROBOT.random_state(rng),
                rng.uniform(-20.0, 20.0, ROBOT.dof)) for k in (0, 1)]
    observer = MomentumObserver(ROBOT, GAIN)
    for t, q, qd, tau in samples:
        expected = observer.update(t.sec + 1e-9 * t.nanosec, q, qd, tau)
        msg = JointState(name=NAMES, position=q.tolist(), velocity=qd.tolist(),
                         effort=tau.tolist())
        msg.header.stamp = t
        f.pub["observer joint_states"].publish(msg)
    m = f.estimates.wait(lambda m: m.header.stamp == samples[1][0], 30,
                         "estimated_external_torques of the second health sample")
    np.testing.assert_allclose(m.effort, expected, rtol=1e-9, atol=1e-9)


def check_health(f, batch, rng):
    for what, check in (("node processes", logs_clean), ("simulator", simulator_steps),
                        ("dynamics node", dynamics_answers),
                        ("controller", controller_commands),
                        ("observer", lambda f, rng: observer_estimates(f, rng, batch)),
                        ("node processes", logs_clean)):
        try:
            check(f, rng)
        except AssertionError as exc:
            raise AssertionError(f"batch {batch} (seed {SEED + batch}) left the {what} "
                                 f"unhealthy: {exc}") from None


def test_every_batch_leaves_the_four_nodes_healthy(ros, fuzz):
    for batch in range(BATCHES):
        rng = np.random.default_rng(SEED + batch)
        try:
            if batch == ISSUE_BATCH:
                issue_sequence(fuzz)
            send_batch(fuzz, rng)
            ros.spin_for(MATCH_SETTLE)        # the last messages taken before the checks
        except AssertionError as exc:
            raise AssertionError(f"batch {batch} (seed {SEED + batch}): {exc}") from None
        check_health(fuzz, batch, rng)
