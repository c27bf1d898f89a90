"""The dynamics node's ~/estimate_payload, ~/time_parameterize and ~/task_space: their
requests in plain Python (ros/payload_timing.py, ros/requests.py, no node), then the node in
its own process with real rclpy:
it records joint_states with efforts of an arm carrying a payload along an excitation, fits
the payload, sets it on itself on request (its ~/inverse_dynamics then answers with it), and
times a path within torque limits, refusing an infeasible one with the joint and the
waypoint, and answers a link's task-space dynamics."""
from types import SimpleNamespace as Msg

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics import identification as ident
from serial_dynamics.ros import payload_timing as pt
from serial_dynamics.ros.requests import answer_task_space
from serial_dynamics.ros.throttle import Rejected
from test_trees import two_arms

srv = pytest.importorskip("serial_dynamics_interfaces.srv")
pytest.importorskip("toppra")

ROBOT = sd.default_robot()
PAYLOAD = dict(mass=2.0, com=(0.01, -0.02, 0.06), inertia=(0.012, 0.010, 0.008, 0.001, -0.0015,
                                                            0.0005))
TRUTH = ROBOT.with_payload(**PAYLOAD)
EX = ident.excitation(ROBOT, duration=6, harmonics=3, maxiter=0, seed=0)
HOME = np.array([0.0, -1.571, 1.571, -1.571, -1.571, 0.0])
PATH = np.array([HOME, HOME + [0.6, 0.3, 0.1, -0.4, 0.0, 0.6], HOME + [-0.7, 0.3, 0.1, -0.4, 0, -0.7]])


def recording(rate=100.0, seed=1):
    t, q, qd, qdd = EX.sample(dt=1.0 / rate)
    tau = TRUTH.inverse_dynamics(q, qd, qdd)
    return t, q, tau + np.random.default_rng(seed).normal(0.0, 0.2, tau.shape)


def path_msg(points, names=()):
    return JointTrajectory(joint_names=list(names), points=[
        JointTrajectoryPoint(positions=[float(x) for x in p]) for p in points])


def tp_request(path, **kw):
    fields = dict(velocity_limits=[], acceleration_limits=[], effort_limits=[], grid=0)
    fields.update(kw)
    return Msg(path=path, **fields)


# ----------------------------------------------------------------- plain Python
def test_the_log_keeps_usable_states_in_the_robots_order():
    log = pt.JointStateLog(ROBOT, seconds=1.0)
    names = ROBOT.joint_names[::-1] + ["gripper"]
    assert log.add(0.0, names, list(range(7)), [10.0 + k for k in range(7)])
    assert not log.add(0.01, names, list(range(7)), [])                     # no efforts
    assert not log.add(0.02, names[1:], list(range(6)), list(range(6)))     # a joint missing
    assert not log.add(0.0, names, list(range(7)), list(range(7)))          # not newer
    assert not log.add(0.03, names, [np.nan] * 7, list(range(7)))           # not finite
    t, q, tau = log.window(0)
    assert q.tolist() == [[5, 4, 3, 2, 1, 0]] and tau.tolist() == [[15, 14, 13, 12, 11, 10]]
    assert log.skipped == 4
    for k in range(1, 300):
        log.add(0.01 * k, names, list(range(7)), list(range(7)))
    assert log.window(0)[0][0] >= 2.98 - 1.0 - 1e-9          # the last second kept
    assert len(log.window(0.5)[0]) == 51


def test_estimate_payload_answer_and_what_it_applies():
    log = pt.JointStateLog(ROBOT)
    t, q, tau = recording()
    for k in range(t.size):
        log.add(t[k], ROBOT.joint_names, q[k], tau[k])
    fields, apply = pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="", apply=True))
    assert abs(fields["mass"] - 2.0) < 0.02 and fields["link"] == "tool0"
    assert np.allclose(fields["com"], PAYLOAD["com"], atol=2e-3)
    assert fields["samples"] == t.size and "payload on 'tool0'" in fields["message"]
    assert apply == {"payload.mass": fields["mass"], "payload.com": fields["com"],
                     "payload.inertia": fields["inertia"], "payload.link": ""}
    assert pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="", apply=False))[1] is None
    with pytest.raises(Rejected, match="window is -1.0"):
        pt.answer_estimate_payload(ROBOT, log, Msg(window=-1.0, link="", apply=False))
    with pytest.raises(Rejected, match="0 joint_states with positions and efforts"):
        pt.answer_estimate_payload(ROBOT, pt.JointStateLog(ROBOT), Msg(window=5.0, link="", apply=False))


def test_estimate_payload_answer_without_a_payload():
    """The arm holding nothing: no payload detected, its mass within three standard
    deviations of zero, no com or inertia on the wire; applied, it clears the payload."""
    log = pt.JointStateLog(ROBOT)
    t, q, qd, qdd = EX.sample(dt=0.01)
    tau = ROBOT.inverse_dynamics(q, qd, qdd) + np.random.default_rng(1).normal(0.0, 0.2, q.shape)
    for k in range(t.size):
        log.add(t[k], ROBOT.joint_names, q[k], tau[k])
    fields, apply = pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="", apply=True))
    assert fields["message"].startswith("no payload detected on 'tool0' (mass ")
    assert fields["mass"] <= 3 * fields["mass_std"]
    assert fields["com"] == fields["inertia"] == fields["com_std"] == fields["inertia_std"] == []
    assert apply == {"payload.mass": 0.0, "payload.com": [0.0] * 3, "payload.inertia": [0.0] * 6,
                     "payload.link": ""}


def test_estimate_payload_checks_the_link_first_and_counts_what_it_received():
    log = pt.JointStateLog(ROBOT)
    names = ROBOT.joint_names
    assert not log.add(0.0, names, [0.0] * 6, [])                          # no efforts
    assert not log.add(0.1, names[1:], [0.0] * 5, [0.0] * 5)               # a joint missing
    assert not log.add(0.2, names, [np.nan] * 6, [0.0] * 6)               # not finite
    assert log.add(0.3, names, [0.0] * 6, [0.0] * 6)
    assert not log.add(0.3, names, [0.0] * 6, [0.0] * 6)                  # the same stamp
    # the link before the samples: a wrong link gets the link's refusal
    with pytest.raises(Rejected, match="link 'nose' is not a link of the model; its links "
                                       r"are \[.*'tool0'.*\]; or leave link empty"):
        pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="nose", apply=False))
    with pytest.raises(Rejected, match="link 'base_link' does not move"):
        pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="base_link", apply=False))
    # too few: what the node has received, kept and skipped, and why
    with pytest.raises(Rejected, match=r"1 joint_states with positions and efforts for every "
                       r"joint .* kept, 100 needed: the node has received 5 joint_states in "
                       r"the .* s since it subscribed, kept 1 \(at most the last 120 s\), "
                       r"skipped 4 \(2 no position and effort for every joint; 1 a NaN or "
                       r"Inf; 1 a stamp not after the previous one's\)"):
        pt.answer_estimate_payload(ROBOT, log, Msg(window=0.0, link="", apply=False))
    with pytest.raises(Rejected, match=r"^0 joint_states .* in the last 5 s, 100 needed: "
                       "the node has received 0 joint_states"):
        pt.answer_estimate_payload(ROBOT, pt.JointStateLog(ROBOT),
                                   Msg(window=5.0, link="", apply=False))


def test_time_parameterize_answer():
    names = [ROBOT.joint_names[i] for i in (2, 0, 1, 3, 4, 5)]
    limits = [30.0, 60.0, 90.0, 12.0, 12.0, 12.0]            # in the path's joint order
    out = pt.answer_time_parameterize(ROBOT, tp_request(path_msg(PATH[:, [2, 0, 1, 3, 4, 5]], names),
                                                        effort_limits=limits, grid=80))
    w = sd.trajectory.time_parameterize(ROBOT, PATH, effort_limit=[60, 90, 30, 12, 12, 12], grid=80)
    traj = out["trajectory"]
    assert traj.joint_names == ROBOT.joint_names and out["duration"] == w.duration
    assert len(traj.points) == len(w.t)
    assert list(traj.points[-1].positions) == w.q[-1].tolist()
    assert list(traj.points[0].velocities) == [0.0] * 6
    last = traj.points[-1].time_from_start
    assert abs(last.sec + 1e-9 * last.nanosec - w.duration) < 1e-9
    assert list(traj.points[5].effort) == ROBOT.inverse_dynamics(w.q[5], w.qd[5], w.qdd[5]).tolist()
    with pytest.raises(Rejected, match="effort_limits has 2 values"):
        pt.answer_time_parameterize(ROBOT, tp_request(path_msg(PATH), effort_limits=[1.0, 2.0]))
    with pytest.raises(Rejected, match="path has 1 points"):
        pt.answer_time_parameterize(ROBOT, tp_request(path_msg(PATH[:1])))
    with pytest.raises(ValueError, match="joint 'shoulder_lift_joint'.*at waypoint 0"):
        pt.answer_time_parameterize(ROBOT, tp_request(path_msg(PATH), effort_limits=[20.0]))


def test_time_parameterize_takes_at_most_max_waypoints():
    """1000 waypoints on a straight stretch are taken (timed as its two ends: the timing
    follows the geometry); 1001 are refused before any is read (points without positions:
    read first, they would be refused for that)."""
    line = PATH[0] + np.linspace(0.0, 1.0, 1000)[:, None] * (PATH[1] - PATH[0])
    out = pt.answer_time_parameterize(ROBOT, tp_request(path_msg(line), grid=50))
    ends = sd.trajectory.time_parameterize(ROBOT, PATH[:2], grid=50)
    assert abs(out["duration"] - ends.duration) < 1e-9 * ends.duration
    np.testing.assert_allclose(out["trajectory"].points[-1].positions, PATH[1], rtol=0,
                               atol=1e-12)
    with pytest.raises(Rejected, match=r"^path has 1001 points; at most 1000 waypoints are "
                       "accepted: give the corners") as refused:
        pt.answer_time_parameterize(ROBOT, tp_request(path_msg([[]] * 1001)))
    assert refused.value.cause == "path"


def ts_request(q, qd=(), qdd=(), names=(), link="", damping=0.0):
    return Msg(link=link, joint_names=list(names), positions=list(q), velocities=list(qd),
               accelerations=list(qdd), damping=damping)


def test_task_space_answer():
    """Every field against its definition composed here from M and J: Lambda = (J M^-1 J^T +
    d^2 1)^-1, J-bar = M^-1 J^T Lambda, the acceleration J qdd + J-dot qd, with J-dot qd by
    central differences of J along qd; the state in another joint order."""
    q, qd = ROBOT.random_state(7)
    qdd = np.linspace(-1.0, 1.0, 6)
    order = [4, 0, 5, 1, 3, 2]
    out = answer_task_space(ROBOT, ts_request(q[order], qd[order], qdd[order],
                                              [ROBOT.joint_names[i] for i in order],
                                              "forearm_link", 0.05))
    J = np.reshape(out["jacobian"], (6, 6))
    np.testing.assert_array_equal(J, ROBOT.jacobian(q, "forearm_link"))
    M = ROBOT.mass_matrix(q)
    lam = np.linalg.inv(J @ np.linalg.solve(M, J.T) + 0.05**2 * np.eye(6))
    np.testing.assert_allclose(np.reshape(out["operational_space_inertia"], (6, 6)), lam,
                               rtol=1e-9, atol=1e-9 * np.abs(lam).max())
    np.testing.assert_allclose(np.reshape(out["dynamically_consistent_inverse"], (6, 6)),
                               np.linalg.solve(M, J.T) @ lam, rtol=1e-9, atol=1e-9)
    h = 1e-6
    jdqd = (ROBOT.jacobian(q + h * qd, "forearm_link") - ROBOT.jacobian(q - h * qd, "forearm_link")) @ qd / (2 * h)
    np.testing.assert_allclose(out["jacobian_dot_qd"], jdqd, atol=1e-7)
    np.testing.assert_allclose(out["frame_acceleration"], J @ qdd + jdqd, atol=1e-7)
    tip = answer_task_space(ROBOT, ts_request(q))              # the tip, at rest: no bias
    np.testing.assert_array_equal(np.reshape(tip["jacobian"], (6, 6)), ROBOT.jacobian(q))
    assert not np.any(tip["jacobian_dot_qd"])
    with pytest.raises(Rejected, match="link 'nose' is not a link of the model"):
        answer_task_space(ROBOT, ts_request(q, link="nose"))
    with pytest.raises(Rejected, match="damping = -1.0: give a finite value >= 0"):
        answer_task_space(ROBOT, ts_request(q, damping=-1.0))
    with pytest.raises(Rejected, match="positions has 2 values"):
        answer_task_space(ROBOT, ts_request(q[:2]))


def test_every_link_of_the_model_on_a_tree():
    """A two-arm robot whose hands are links fixed to the forearms: ~/task_space answers for
    a hand as the library does, ~/estimate_payload takes it too (and then counts samples);
    an unknown link is refused by both in the library's words."""
    arms = sd.load_urdf(two_arms())
    assert "l_hand" not in arms.link_names                 # a frame of the forearm's body
    q, qd = np.linspace(-0.5, 0.5, arms.dof), np.linspace(0.3, -0.3, arms.dof)
    out = answer_task_space(arms, ts_request(q, qd, link="l_hand", damping=0.1))
    np.testing.assert_array_equal(np.reshape(out["jacobian"], (6, arms.dof)),
                                  arms.jacobian(q, "l_hand"))
    np.testing.assert_array_equal(out["jacobian_dot_qd"], arms.jacobian_dot_qd(q, qd, "l_hand"))
    np.testing.assert_array_equal(np.reshape(out["operational_space_inertia"], (6, 6)),
                                  arms.operational_space_inertia(q, "l_hand", 0.1))
    log = pt.JointStateLog(arms)
    with pytest.raises(Rejected, match="^0 joint_states"):
        pt.answer_estimate_payload(arms, log, Msg(window=0.0, link="l_hand", apply=False))
    for answer in (lambda: answer_task_space(arms, ts_request(q, link="l_palm")),
                   lambda: pt.answer_estimate_payload(arms, log, Msg(window=0.0, link="l_palm",
                                                                     apply=False))):
        with pytest.raises(Rejected, match="link 'l_palm' is not a link of the model"):
            answer()


# ----------------------------------------------------------------- the node
def test_the_node_estimates_sets_and_times(ros):
    proc = ros.start("dynamics", {"urdf_path": sd.builtin_path("ur5e")},
                     ros_args=["-r", "__ns:=/payload_timing"])
    pub = ros.node.create_publisher(JointState, "/payload_timing/joint_states", 50)
    est = ros.node.create_client(srv.EstimatePayload, "/payload_timing/dynamics/estimate_payload")
    timing = ros.node.create_client(srv.TimeParameterize,
                                    "/payload_timing/dynamics/time_parameterize")
    idyn = ros.node.create_client(srv.InverseDynamics, "/payload_timing/dynamics/inverse_dynamics")
    ros.wait_matched(pub, also=est.service_is_ready, what="the dynamics node")
    # too little data yet: refused with the reason and what it received, the node carries on
    answer = ros.call(est, srv.EstimatePayload.Request(window=0.0), timeout=150.0)
    assert not answer.success and "joint_states with positions and efforts" in answer.message
    assert "the node has received 0 joint_states" in answer.message
    t, q, tau = recording()
    for k in range(t.size):              # stamped: the node fits on the stamps, not arrival
        s = 100.0 + t[k]                  # (a zero stamp means: the time of arrival)
        stamp = Time(sec=int(s), nanosec=int(round((s % 1) * 1e9)))
        msg = JointState(name=ROBOT.joint_names, position=q[k].tolist(), effort=tau[k].tolist())
        msg.header.stamp = stamp
        pub.publish(msg)
        ros.spin_for(0.002)
    ros.spin_for(0.5)
    answer = ros.call(est, srv.EstimatePayload.Request(window=0.0, apply=True))
    assert answer.success, answer.message
    assert abs(answer.mass - 2.0) < 0.03 and answer.samples > 0.9 * t.size
    assert "applied to payload.*" in answer.message
    # the node now answers with the payload set
    held = ROBOT.with_payload(answer.mass, answer.com, answer.inertia)
    x = srv.InverseDynamics.Request(positions=HOME.tolist())
    efforts = ros.call(idyn, x).efforts
    np.testing.assert_allclose(efforts, held.gravity_torques(HOME), rtol=1e-12)
    # timing within torque limits, with the payload it now holds
    answer = ros.call(timing, srv.TimeParameterize.Request(
        path=path_msg(PATH), effort_limits=[60.0, 90.0, 45.0, 12.0, 12.0, 12.0], grid=60))
    assert answer.success, answer.message
    w = sd.trajectory.time_parameterize(held, PATH, effort_limit=[60, 90, 45, 12, 12, 12], grid=60)
    assert answer.duration == pytest.approx(w.duration, rel=1e-12)
    answer = ros.call(timing, srv.TimeParameterize.Request(path=path_msg(PATH),
                                                          effort_limits=[20.0]))
    assert not answer.success and "'shoulder_lift_joint'" in answer.message \
        and "waypoint 0" in answer.message
    # a link's task-space dynamics, with the payload held
    task = ros.node.create_client(srv.TaskSpace, "/payload_timing/dynamics/task_space")
    q, qd = ROBOT.random_state(3)
    answer = ros.call(task, srv.TaskSpace.Request(link="wrist_2_link", positions=q.tolist(),
                                                  velocities=qd.tolist(), damping=0.01))
    assert answer.success, answer.message
    np.testing.assert_array_equal(answer.operational_space_inertia,
                                  held.operational_space_inertia(q, "wrist_2_link", 0.01).ravel())
    np.testing.assert_array_equal(answer.jacobian_dot_qd, held.jacobian_dot_qd(q, qd, "wrist_2_link"))
    answer = ros.call(task, srv.TaskSpace.Request(link="nose", positions=q.tolist()))
    assert not answer.success and "'nose'" in answer.message
    assert proc.running()
