"""The simulator's input messages, checked and converted (no node state here): joint
commands with servo targets, the external wrench and ``~/set_state``. Each function takes
a message and the robot and returns arrays in model order, or raises ``Rejected`` naming
the field and the reason.
"""
from __future__ import annotations

import numpy as np

from . import common
from .common import Rejected


def _field(values, m, msg_idx, what):
    """An optional JointState field: None when empty, else its values (checked) in the
    message's order of the known joints."""
    if len(values) == 0:
        return None
    return common.finite_vector(values, m, what, what)[msg_idx]


def joint_command(msg, robot):
    """sensor_msgs/JointState -> (model indices, effort, position targets, velocity
    targets), each (k,) or None when the message leaves the field empty. Effort is not
    bounded here (it is clamped to the limits); targets are bounded by MAX_VALUE. A message
    with none of the three fields is refused."""
    msg_idx, idx = common.name_index(msg.name, robot, "joint_commands", require_all=False)
    m = len(msg.name)
    if not (len(msg.effort) or len(msg.position) or len(msg.velocity)):
        # the historic cause and text of an effort of the wrong length (no field at all)
        raise Rejected("joint_commands effort length", f"joint_commands effort has 0 values; "
                       f"expected {m} (or position and/or velocity targets, {m} each)")
    effort = None
    if len(msg.effort):
        effort = common.finite_vector(msg.effort, m, "joint_commands effort",
                                      "joint_commands effort", bound=None)[msg_idx]
    position = _field(msg.position, m, msg_idx, "joint_commands position")
    velocity = _field(msg.velocity, m, msg_idx, "joint_commands velocity")
    return idx, effort, position, velocity


def external_wrench(msg, frame, axes="base"):
    """geometry_msgs/WrenchStamped -> (6,) [force; torque] on the tip at its origin, or None
    for a zero wrench (no push). frame_id must be '' or ``frame``, the robot's ``axes``
    frame: the base link ("base"), or the world on a floating base ("world")."""
    f, t = msg.wrench.force, msg.wrench.torque
    w = common.finite_vector([f.x, f.y, f.z, t.x, t.y, t.z], 6, "external_wrench",
                             "external_wrench")
    got = msg.header.frame_id
    if got not in ("", frame):
        raise Rejected("external_wrench frame", f"external_wrench frame_id {got!r} is not the "
                       f"{axes} frame: give '' or {frame!r} (the wrench on the tip "
                       f"link at its origin, in {axes} coordinates)")
    return w if np.any(w) else None


def set_state(msg, robot):
    """sensor_msgs/JointState -> (model indices, positions or None, velocities): positions
    within the joint limits; velocities of the named joints 0 when the field is empty
    (put there at rest); at least one of the two fields."""
    msg_idx, idx = common.name_index(msg.name, robot, "set_state", require_all=False)
    m = len(msg.name)
    if not (len(msg.position) or len(msg.velocity)):
        raise Rejected("set_state empty", f"set_state names {m} joints but has neither "
                       "positions nor velocities")
    q = _field(msg.position, m, msg_idx, "set_state position")
    qd = _field(msg.velocity, m, msg_idx, "set_state velocity")
    if q is not None:
        lo, hi = robot.lower[idx], robot.upper[idx]
        out = np.flatnonzero((q < lo) | (q > hi))
        if out.size:
            j = out[0]
            raise Rejected("set_state outside the limits", f"set_state position of "
                           f"{robot.joint_names[idx[j]]} = {q[j]} is outside its limits "
                           f"[{lo[j]}, {hi[j]}]")
    return idx, q, (np.zeros(len(idx)) if qd is None else qd)
