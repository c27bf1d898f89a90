"""The dynamics node's ~/contact_inverse_dynamics: the request in plain Python
(ros/contact_requests.py, no node) -- Solo12 standing on its four feet answered with the
library's numbers (efforts, one wrench per contact carrying its weight), a base that moves,
friction, frame contacts, a fixed base, and every refusal naming its field or contact -- then
the node with real rclpy, started on Solo12's URDF with floating_base:=true."""
from types import SimpleNamespace as Msg

import numpy as np
import pytest
from geometry_msgs.msg import Accel, Point, Pose, Twist

from pin_reference import erd

import serial_dynamics as sd
from serial_dynamics.ros import floating_state
from serial_dynamics.ros.contact_requests import answer_contact_inverse_dynamics as answer
from serial_dynamics.ros.throttle import Rejected

SOLO = "solo_description/robots/solo12.urdf"
FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]
LEGS = np.r_[np.tile([0.0, 0.8, -1.6], 2), np.tile([0.0, -0.8, 1.6], 2)]   # knees bent
BASE = np.r_[0.2, -0.1, 0.3, 0.0, 0.0, np.sin(0.2), np.cos(0.2)]           # level, turned
RTOL = 1e-9


@pytest.fixture(scope="module")
def solo():
    return sd.load_urdf(erd(SOLO), floating_base=True)


def weight(robot):
    return 9.81 * (robot.model.base_mass + robot.model.mass.sum())


def pose(p):
    out = Pose()
    out.position.x, out.position.y, out.position.z = p[:3]
    out.orientation.x, out.orientation.y, out.orientation.z, out.orientation.w = p[3:]
    return out


def twist(v, kind=Twist):
    out = kind()
    out.linear.x, out.linear.y, out.linear.z = v[:3]
    out.angular.x, out.angular.y, out.angular.z = v[3:]
    return out


def request(positions=LEGS, base=BASE, v=np.zeros(6), a=np.zeros(6), links=FEET, **kw):
    fields = dict(joint_names=[], velocities=[], accelerations=[], contact_points=[],
                  frame_contacts=[], friction=0.0)
    fields.update(kw)
    return Msg(positions=list(positions), base_pose=pose(base), base_velocity=twist(v),
               base_acceleration=twist(a, Accel), contact_links=list(links), **fields)


def forces(out):
    return np.array([[w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]
                     for w in out["contact_wrenches"]])


# ----------------------------------------------------------------- plain Python
def test_standing_solo12_is_answered_with_the_librarys_torques_and_its_weight(solo):
    out = answer(solo, request())
    tau, f = solo.contact_inverse_dynamics(np.r_[BASE, LEGS], np.zeros(solo.nv),
                                           np.zeros(solo.nv), [sd.Contact(x) for x in FEET])
    assert out["joint_names"] == solo.joint_names
    np.testing.assert_array_equal(out["efforts"], tau[6:])         # the base's rows left out
    got = forces(out)
    np.testing.assert_array_equal(got[:, :3], f)
    assert np.array_equal(got[:, 3:], np.zeros((4, 3)))            # point contacts: forces
    assert abs(got[:, 2].sum() - weight(solo)) < RTOL * weight(solo)


def test_a_moving_base_joints_in_another_order_friction_and_frame_contacts(solo):
    rng = np.random.default_rng(4)
    qd, qdd = rng.uniform(-1, 1, solo.dof), rng.uniform(-2, 2, solo.dof)
    v, a = np.r_[0.1, -0.2, 0.05, 0.3, -0.1, 0.2], np.r_[0.2, 0.1, -0.3, 0.5, 0.4, -0.2]
    order = rng.permutation(solo.dof)
    names = [solo.joint_names[i] for i in order]
    q, vv, aa = np.r_[BASE, LEGS], np.r_[v, qd], np.r_[a, qdd]
    points = [Point(x=0.0, y=0.0, z=0.01 * k) for k in range(4)]
    for kw, contacts, mu in (
            ({}, [sd.Contact(x) for x in FEET], None),
            ({"friction": 0.9}, [sd.Contact(x) for x in FEET], 0.9),
            ({"contact_points": points, "frame_contacts": [True, False, False, True]},
             [sd.Contact(x, point=(0, 0, 0.01 * k), frame=k in (0, 3))
              for k, x in enumerate(FEET)], None)):
        out = answer(solo, request(LEGS[order], v=v, a=a, joint_names=names,
                                   velocities=qd[order], accelerations=qdd[order], **kw))
        tau, f = solo.contact_inverse_dynamics(q, vv, aa, contacts, friction=mu)
        np.testing.assert_array_equal(out["efforts"], tau[6:])
        got = forces(out)
        for k, fk in enumerate(f):
            np.testing.assert_array_equal(got[k, :len(fk)], fk)
        assert [np.any(g[3:] != 0) for g in got] == [c.frame for c in contacts]


def test_a_fixed_base_needs_no_force():
    robot = sd.default_robot()
    q, qd = robot.random_state(2)
    out = answer(robot, request(q, base=(0, 0, 0, 0, 0, 0, 1), links=["wrist_3_link"],
                                velocities=qd))
    np.testing.assert_array_equal(out["efforts"], robot.inverse_dynamics(q, qd, np.zeros(6)))
    assert np.array_equal(forces(out), np.zeros((1, 6)))
    with pytest.raises(Rejected, match=r"base_pose is .* the robot's base is fixed.*"
                       "floating_base:=true"):
        answer(robot, request(q, links=["wrist_3_link"]))


@pytest.mark.parametrize("change, field, words", [
    ({"links": FEET[:3] + ["HR_HOOF"]}, "contact_links", r"contact_links\[3\]: link 'HR_HOOF' "
     "is not a link of the model"),
    ({"links": []}, "contact_links", "contact_links is empty"),
    ({"friction": -0.5}, "friction", r"friction = -0.5: give .* > 0, or 0 for none"),
    ({"friction": float("nan")}, "friction", "friction = nan"),
    ({"v": [0, 0, np.inf, 0, 0, 0]}, "base_velocity", "base_velocity has NaN or Inf"),
    ({"base": [0, 0, 0.3, 0, 0, 0.5, 0.5]}, "base_pose quaternion", r"base_pose has a "
     r"quaternion \[qx, qy, qz, qw\] = \[0.0, 0.0, 0.5, 0.5\] of length 0.707107; give a unit "
     "quaternion"),
    ({"base": [0, np.nan, 0.3, 0, 0, 0, 1]}, "base_pose values", r"base_pose must be 7 finite "
     r"numbers \[x, y, z, qx, qy, qz, qw\]"),
    ({"links": FEET * 250 + ["FL_FOOT"]}, "contact_links", "contact_links has 1001 entries; at "
     "most 1000 contacts are accepted"),
    ({"contact_points": [Point()]}, "contact_points", r"contact_points has 1 entries: give one "
     r"per contact_links entry \(4\), or none"),
    ({"contact_points": [Point(x=np.nan)] * 4}, "contact_points[0]", r"contact_points\[0\] has "
     "NaN"),
    ({"accelerations": [0.0] * 11}, "accelerations", "accelerations has 11 values"),
], ids=["unknown link", "no contact", "friction < 0", "friction NaN", "base velocity Inf",
        "quaternion", "base NaN", "too many contacts", "points count", "point NaN",
        "accelerations count"])
def test_refusals_name_the_field(solo, change, field, words):
    with pytest.raises(Rejected, match=words) as info:
        answer(solo, request(**change))
    assert info.value.cause == field


def test_the_most_contacts_are_answered_and_carry_the_weight(solo):
    """contact_requests.MAX_CONTACTS, 1000 (each foot 250 times), are taken; one more is
    refused (above)."""
    out = answer(solo, request(links=FEET * 250))
    tau, f = solo.contact_inverse_dynamics(np.r_[BASE, LEGS], np.zeros(solo.nv),
                                           np.zeros(solo.nv), [sd.Contact(x) for x in FEET * 250])
    np.testing.assert_array_equal(out["efforts"], tau[6:])
    got = forces(out)
    np.testing.assert_array_equal(got[:, :3], f)
    assert abs(got[:, 2].sum() - weight(solo)) < RTOL * weight(solo)


def test_base_pose_is_checked_by_the_simulators_rule(solo):
    """One check of a pose for both nodes (requests.unit_pose): the same quaternion is refused
    in the same words as the simulator's ~/set_base_state refuses it, and one within
    QUAT_TOLERANCE of unit length is normalized to the same bits."""
    bad = [0.2, -0.1, 0.3, 0.0, 0.0, 0.6, 0.6]
    with pytest.raises(Rejected) as ours:
        answer(solo, request(base=bad))
    with pytest.raises(Rejected) as simulator:
        floating_state.base_state(floating_state.odometry(bad, np.zeros(6), "", ""), "odom",
                                  solo.base_link)
    assert str(simulator.value).startswith("set_base_state pose has a quaternion")
    assert str(ours.value) == str(simulator.value).replace("set_base_state pose", "base_pose")
    near = np.r_[BASE[:3], BASE[3:] * (1 + 0.9 * floating_state.QUAT_TOLERANCE)]
    pose, _ = floating_state.base_state(floating_state.odometry(near, np.zeros(6), "", ""),
                                        "odom", solo.base_link)
    out = answer(solo, request(base=near))
    tau, _ = solo.contact_inverse_dynamics(np.r_[pose, LEGS], np.zeros(solo.nv),
                                           np.zeros(solo.nv), [sd.Contact(x) for x in FEET])
    np.testing.assert_array_equal(out["efforts"], tau[6:])


def test_contacts_that_cannot_carry_the_base_are_named(solo):
    """One foot cannot hold the base (no moment): the library's ValueError names it."""
    with pytest.raises(ValueError, match=r"the contacts \[.*'HL_FOOT'.*\] cannot exert the "
                       "base wrench"):
        answer(solo, request(links=["HL_FOOT"]))


# ----------------------------------------------------------------- the node
def test_the_node_answers_the_torques_that_hold_solo12_standing(ros, solo):
    srv = pytest.importorskip("serial_dynamics_interfaces.srv")
    proc = ros.start("dynamics", {"urdf_path": erd(SOLO), "floating_base": True},
                     ros_args=["-r", "__ns:=/contact_service"])
    client = ros.node.create_client(srv.ContactInverseDynamics,
                                    "/contact_service/dynamics/contact_inverse_dynamics")
    req = srv.ContactInverseDynamics.Request(positions=LEGS.tolist(), base_pose=pose(BASE),
                                             contact_links=FEET)
    out = ros.call(client, req, timeout=150.0)
    assert out.success, out.message
    tau, f = solo.contact_inverse_dynamics(np.r_[BASE, LEGS], np.zeros(solo.nv),
                                           np.zeros(solo.nv), [sd.Contact(x) for x in FEET])
    assert list(out.joint_names) == solo.joint_names
    np.testing.assert_array_equal(out.efforts, tau[6:])
    fz = [w.force.z for w in out.contact_wrenches]
    np.testing.assert_array_equal(fz, f[:, 2])
    assert abs(sum(fz) - weight(solo)) < RTOL * weight(solo)
    # refused, naming the contact; the node carries on
    req.contact_links = FEET[:3] + ["HR_HOOF"]
    out = ros.call(client, req)
    assert not out.success and "contact_links[3]: link 'HR_HOOF'" in out.message
    req.contact_links = ["HL_FOOT"]
    out = ros.call(client, req)
    assert not out.success and "'HL_FOOT'" in out.message and "cannot exert" in out.message
    # the services that take the joints alone say where to go on a floating base
    idyn = ros.node.create_client(srv.InverseDynamics, "/contact_service/dynamics/inverse_dynamics")
    out = ros.call(idyn, srv.InverseDynamics.Request(positions=LEGS.tolist()))
    assert not out.success and "floating base" in out.message \
        and "~/contact_inverse_dynamics" in out.message
    assert proc.running()
