"""The simulator's floating base in messages (no node state, no rclpy here): the initial
pose parameter, the state <-> nav_msgs/Odometry, and the checks of a base state sent to
``~/set_base_state``.

State (``FloatingRobot``, docs/modelling.md): q = [x, y, z, qx, qy, qz, qw, joints], v =
[base linear velocity, base angular velocity, joint rates], the base's velocities in the
base frame. nav_msgs/Odometry says the same (REP 105 and the message's own comments): the
pose of ``child_frame_id`` (the base link) in ``header.frame_id`` (the world, ``odom``), the
twist in ``child_frame_id`` -- so the base's pose and twist (``Session.joint_state().base``)
go into the message as they are.
"""
from __future__ import annotations

import numpy as np
from nav_msgs.msg import Odometry

from .common import MAX_VALUE, Rejected
# one check of a pose for both nodes (QUAT_TOLERANCE: re-exported, the simulator's rule too)
from .requests import QUAT_TOLERANCE, unit_pose  # noqa: F401

IDENTITY = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]     # [x, y, z, qx, qy, qz, qw]


def initial_pose(values):
    """The ``initial_base_pose`` parameter -> (7,) (its quaternion normalized; [] = identity)."""
    return unit_pose(IDENTITY if not values else values, "initial_base_pose", tolerance=None,
                     bound=MAX_VALUE)


def odometry(pose, twist, frame_id, child_frame_id, stamp=None):
    """nav_msgs/Odometry of the base at ``pose`` (7,) and ``twist`` (6,): pose in
    ``frame_id``, twist in the base frame ``child_frame_id``; covariances zero (a
    simulation knows its state)."""
    msg = Odometry()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id, msg.child_frame_id = frame_id, child_frame_id
    x, y, z, qx, qy, qz, qw = np.asarray(pose, dtype=float).tolist()
    vx, vy, vz, wx, wy, wz = np.asarray(twist, dtype=float).tolist()
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = x, y, z
    o.x, o.y, o.z, o.w = qx, qy, qz, qw
    lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
    lin.x, lin.y, lin.z = vx, vy, vz
    ang.x, ang.y, ang.z = wx, wy, wz
    return msg


def base_state(msg, frame_id, child_frame_id):
    """nav_msgs/Odometry -> (pose (7,), twist (6,)) of the base, as ``odometry`` writes
    them. Frames: '' or the simulator's own; the quaternion of unit length (within
    QUAT_TOLERANCE; normalized); every value finite and within MAX_VALUE."""
    for field, got, want in (("header.frame_id", msg.header.frame_id, frame_id),
                             ("child_frame_id", msg.child_frame_id, child_frame_id)):
        if got not in ("", want):
            raise Rejected(f"set_base_state {field}", f"set_base_state {field} {got!r} is "
                                 f"not the simulator's: give '' or {want!r} (pose in "
                                 f"{frame_id!r}, twist in the base frame {child_frame_id!r})")
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    pose = unit_pose([p.x, p.y, p.z, o.x, o.y, o.z, o.w], "set_base_state pose",
                     bound=MAX_VALUE)
    lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
    twist = np.array([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z])
    if not np.all(np.isfinite(twist)) or np.any(np.abs(twist) > MAX_VALUE):
        raise Rejected("set_base_state twist", "set_base_state twist must be finite and "
                             f"within +-{MAX_VALUE:g}, got {twist.tolist()}")
    return pose, twist
