"""The dynamics node's ``~/contact_inverse_dynamics`` (ContactInverseDynamics.srv), checked
and answered in plain Python (no rclpy: the tests call it directly), as ``requests.py``
answers the other services.

The state: the joints as in every service (``joint_names``, positions, velocities,
accelerations); on a floating base also ``base_pose`` (the base link in the world),
``base_velocity`` and ``base_acceleration`` (base frame: the floating robot's v =
[linear; angular] and its derivative, docs/modelling.md), which a fixed base leaves at their
defaults. The contacts: one per ``contact_links`` entry, at ``contact_points`` (the link's
frame; empty: the origins), a wrench where ``frame_contacts`` says so. ``friction`` 0: the
minimum-norm forces, else Coulomb's mu about the world's z. The answer: the joints' efforts
(a floating base's six zero rows left out) and one geometry_msgs/Wrench per contact.
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Wrench

from ..contacts import Contact
from ..model.links import link_problem
from .requests import joint_order, joint_vector, to_array, unit_pose
from .throttle import Rejected

IDENTITY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
# The most contacts one request takes, checked before any is looked at: the friction cones'
# solver works on dense (3k + 6) x 3k matrices; 1000 frame contacts with friction took 2.1 s
# here (Solo12; 0.1 s without friction), a legged robot's feet and hands are a few dozen
MAX_CONTACTS = 1000


def _finite(field, values):
    a = np.array(values, dtype=float)
    if not np.all(np.isfinite(a)):
        raise Rejected(field, f"{field} has NaN or Inf ({a.tolist()}): give finite numbers")
    return a


def base_state(robot, req):
    """(pose (7,), v (6,), a (6,)) of the base from the request; None on a fixed base (which
    must leave the three at their defaults)."""
    p, o = req.base_pose.position, req.base_pose.orientation
    pose = np.array([p.x, p.y, p.z, o.x, o.y, o.z, o.w])
    t, acc = req.base_velocity, req.base_acceleration
    v = _finite("base_velocity", [t.linear.x, t.linear.y, t.linear.z,
                                  t.angular.x, t.angular.y, t.angular.z])
    a = _finite("base_acceleration", [acc.linear.x, acc.linear.y, acc.linear.z,
                                      acc.angular.x, acc.angular.y, acc.angular.z])
    if not robot.is_floating:
        for field, got, rest in (("base_pose", pose, IDENTITY), ("base_velocity", v, 0.0),
                                 ("base_acceleration", a, 0.0)):
            if not np.all(got == rest):
                raise Rejected(field, f"{field} is {got.tolist()} but the robot's base is "
                               "fixed: leave it at its default, or start the node with "
                               "floating_base:=true")
        return None
    return unit_pose(pose, "base_pose"), v, a


def contacts(robot, req):
    """The request's contacts as sd.Contact objects (Rejected naming the field and entry)."""
    k = len(req.contact_links)
    if k > MAX_CONTACTS:
        raise Rejected("contact_links", f"contact_links has {k} entries; at most "
                       f"{MAX_CONTACTS} contacts are accepted (a foot flat on the ground is one "
                       "frame contact, or its sole's corners)")
    links, points, frames = list(req.contact_links), list(req.contact_points), \
        list(req.frame_contacts)
    if k == 0:
        raise Rejected("contact_links", "contact_links is empty: name at least one link that "
                       "touches (for a robot that touches nothing, call ~/inverse_dynamics)")
    for field, got in (("contact_points", points), ("frame_contacts", frames)):
        if len(got) not in (0, k):
            raise Rejected(field, f"{field} has {len(got)} entries: give one per contact_links "
                           f"entry ({k}), or none")
    out = []
    for i, link in enumerate(links):
        problem = link_problem(robot.model, link)
        if problem is not None:
            raise Rejected("contact_links", f"contact_links[{i}]: {problem}")
        point = _finite(f"contact_points[{i}]", [points[i].x, points[i].y, points[i].z]) \
            if points else np.zeros(3)
        out.append(Contact(link, point=point, frame=bool(frames[i]) if frames else False))
    return out


def wrench(f):
    """One contact's force (3,) or wrench (6,) [force; moment] -> geometry_msgs/Wrench."""
    f = np.r_[f, np.zeros(6 - len(f))].tolist()
    w = Wrench()
    w.force.x, w.force.y, w.force.z = f[:3]
    w.torque.x, w.torque.y, w.torque.z = f[3:]
    return w


def answer_contact_inverse_dynamics(robot, req, compensate=False):
    """(tau, f) of robot.contact_inverse_dynamics: M a + b = tau + J^T f (- the dissipation
    torques from tau when compensated); the library's ValueError (no force distribution: it
    names the contacts) goes to the caller."""
    index = joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    qd = joint_vector(robot, index, req.velocities, "velocities", empty_is_zero=True)
    qdd = joint_vector(robot, index, req.accelerations, "accelerations", empty_is_zero=True)
    base = base_state(robot, req)
    mu = req.friction
    if not (np.isfinite(mu) and mu >= 0.0):
        raise Rejected("friction", f"friction = {mu}: give Coulomb's coefficient, a finite "
                       "value > 0, or 0 for none (the minimum-norm forces)")
    where = contacts(robot, req)
    if base is not None:
        pose, v, a = base
        q, qd, qdd = np.r_[pose, q], np.r_[v, qd], np.r_[a, qdd]
    tau, f = robot.contact_inverse_dynamics(q, qd, qdd, where, friction=mu or None)
    tau, qd = (tau[6:], qd[6:]) if base is not None else (tau, qd)
    if compensate:          # the actuators also overcome the joint dissipation
        tau = tau - robot.dissipation_torques(qd)
    if not (np.isfinite(tau).all() and np.isfinite(f).all()):
        raise Rejected("result", "the torques or forces came out non-finite: the state is "
                       "beyond what the model can compute (check the units: rad, rad/s, m)")
    return {"joint_names": robot.joint_names, "efforts": to_array(tau),
            "contact_wrenches": [wrench(x) for x in f]}
