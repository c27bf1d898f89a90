"""The dynamics node's service requests, checked and answered in plain Python (no rclpy:
the tests call these functions directly).

Each ``answer_*`` takes the robot and a request of the matching
``serial_dynamics_interfaces/srv`` type (anything with the same fields will do) and returns
the response fields as a dict, or raises ``Rejected`` (its cause: the field) naming the field and the fix. Rules
(docs/ros.md, "Dynamics services"): ``joint_names`` any of the robot's joints (a subset of a
tree's: two arms' joints, one leg's) in any order, the joints not named at zero position,
velocity, acceleration and effort, or empty for every joint in the robot's order
(``robot.joint_names``); empty velocities, accelerations or efforts mean zeros;
``tip_wrench`` is exerted on the tip link at its origin, in base coordinates, and a zero
wrench means none. Answers list the joints in the robot's order. ``unit_pose`` is the one
check of a floating base's pose that both nodes make (``base_pose`` here, the simulator's
``~/set_base_state`` and ``initial_base_pose``).
"""
from __future__ import annotations

import array
import time

import numpy as np

from ..model.links import link_problem
from .throttle import Rejected


def to_array(x) -> array.array:
    """A float64 NumPy array as the array.array('d') that a message's float64[] field holds
    (given a list, the field's setter would convert it element by element)."""
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(x, dtype=float).tobytes())
    return out


def _show(names, at_most=8):
    names = list(names)
    return str(names) if len(names) <= at_most else f"{names[:at_most]} ... ({len(names)} in all)"


def joint_order(robot, names):
    """Model index of each of the request's joints (any of the robot's, each once), or None
    for every joint in the robot's own order."""
    if len(names) == 0 or names == robot.joint_names:
        return None
    fix = (f"name joints of the robot {_show(robot.joint_names)}, each once, in any order "
           "(those not named are at zero), or leave joint_names empty for all in that order")
    model = {name: j for j, name in enumerate(robot.joint_names)}
    unknown = list(dict.fromkeys(x for x in names if x not in model))
    if unknown:
        raise Rejected("joint_names", f"joint_names {_show(unknown)} are not joints of the "
                      f"robot: {fix}")
    index = np.array([model[x] for x in names])
    if len(set(index.tolist())) != len(index):
        raise Rejected("joint_names", f"joint_names names a joint more than once: {fix}")
    return index


def joint_vector(robot, index, values, field, empty_is_zero=False):
    """One value per joint, in the model's order: a float array of length robot.dof (the
    joints the request does not name at zero)."""
    n = robot.dof
    if len(values) == 0 and empty_is_zero:
        return np.zeros(n)
    size = n if index is None else len(index)
    if len(values) != size:
        order = "of joint_names" if index is not None else f"{robot.joint_names}"
        empty = " (or none, for zeros)" if empty_is_zero else ""
        raise Rejected(field, f"{field} has {len(values)} values: give one per joint, {size}, "
                      f"in the order {order}{empty}")
    a = np.asarray(values, dtype=float)     # array.array('d') of a message: no copy
    if not np.isfinite(a).all():
        bad = [int(i) for i in np.flatnonzero(~np.isfinite(a))]
        raise Rejected(field, f"{field} has NaN or Inf at {bad}: give finite numbers")
    if index is None:
        return a
    out = np.zeros(n)
    out[index] = a
    return out


# |1 - |quaternion|| accepted (and normalized) in a message: 4 digits typed by hand pass
QUAT_TOLERANCE = 1e-3


def unit_pose(values, what, tolerance=QUAT_TOLERANCE, bound=np.inf):
    """A floating base's pose [x, y, z, qx, qy, qz, qw] (m; a unit quaternion, w last) as
    (7,), its quaternion normalized: every value finite and within +-``bound``, the
    quaternion's length within ``tolerance`` of 1 (None: any but 0), else Rejected naming
    ``what``. The one check of a pose in a message or parameter: the dynamics node's
    ``base_pose``, the simulator's ``~/set_base_state`` and ``initial_base_pose``."""
    pose = np.array(values, dtype=float)
    if pose.shape != (7,) or not np.all(np.isfinite(pose)) or np.any(np.abs(pose) > bound):
        raise Rejected(f"{what} values", f"{what} must be 7 finite numbers [x, y, z, qx, qy, "
                       f"qz, qw] (m; a quaternion, w last), got {pose.tolist()}")
    norm = float(np.linalg.norm(pose[3:]))
    if norm == 0.0 or (tolerance is not None and abs(norm - 1.0) > tolerance):
        raise Rejected(f"{what} quaternion", f"{what} has a quaternion [qx, qy, qz, qw] = "
                       f"{pose[3:].tolist()} of length {norm:.6g}; give a unit quaternion "
                       "(identity: [0, 0, 0, 1], w last)")
    pose[3:] /= norm
    return pose


def tip_wrench(w):
    """geometry_msgs/Wrench -> (6,) [force; torque] in base coordinates, or None if zero."""
    a = np.array([w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z])
    if not np.all(np.isfinite(a)):
        raise Rejected("tip_wrench", f"tip_wrench has NaN or Inf ({a.tolist()}): give finite "
                      "numbers, or all zeros for no wrench")
    return a if a.any() else None


def _finite(x, what):
    if not np.isfinite(x).all():
        raise Rejected("result", f"the {what} came out non-finite: the state is beyond what "
                      "the model can compute (check the units: rad, rad/s, N m)")
    return x


def answer_inverse_dynamics(robot, req, compensate=False):
    """tau = M(q) qdd + b(q, qd) - J^T w  (- the dissipation torques when compensated)."""
    index = joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    qd = joint_vector(robot, index, req.velocities, "velocities", empty_is_zero=True)
    qdd = joint_vector(robot, index, req.accelerations, "accelerations", empty_is_zero=True)
    tau = robot.inverse_dynamics(q, qd, qdd, tip_wrench(req.tip_wrench))
    if compensate:          # the actuators also overcome the joint dissipation
        tau = tau - robot.dissipation_torques(qd)
    return {"joint_names": robot.joint_names, "efforts": to_array(_finite(tau, "torques"))}


def answer_forward_dynamics(robot, req, compensate=False):
    """qdd = M(q)^-1 (tau - b(q, qd) + J^T w)  (tau plus the dissipation torques when the
    node compensates them, so that forward dynamics inverts the node's inverse dynamics)."""
    index = joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    qd = joint_vector(robot, index, req.velocities, "velocities", empty_is_zero=True)
    tau = joint_vector(robot, index, req.efforts, "efforts", empty_is_zero=True)
    if compensate:
        tau = tau + robot.dissipation_torques(qd)
    qdd = robot.forward_dynamics(q, qd, tau, tip_wrench(req.tip_wrench))
    return {"joint_names": robot.joint_names,
            "accelerations": to_array(_finite(qdd, "accelerations"))}


def answer_mass_matrix(robot, req):
    """M(q), row-major, rows and columns in the robot's joint order."""
    index = joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    return {"joint_names": robot.joint_names,
            "mass_matrix": to_array(_finite(robot.mass_matrix(q), "mass matrix").ravel())}


def answer_task_space(robot, req):
    """J, J qdd + J-dot qd, J-dot qd, Lambda and J-bar of ``req.link`` (the tip if empty),
    row-major, columns (J) and rows (J-bar) in the robot's joint order (TaskSpace.srv)."""
    index = joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    qd = joint_vector(robot, index, req.velocities, "velocities", empty_is_zero=True)
    qdd = joint_vector(robot, index, req.accelerations, "accelerations", empty_is_zero=True)
    link = req.link or robot.tip_link
    problem = link_problem(robot.model, link)
    if problem is not None:
        raise Rejected("link", f"{problem}; or leave link empty for the tip")
    if not (np.isfinite(req.damping) and req.damping >= 0.0):
        raise Rejected("damping", f"damping = {req.damping}: give a finite value >= 0 "
                       "(0: none)")
    return {"joint_names": robot.joint_names,
            "jacobian": to_array(_finite(robot.jacobian(q, link), "Jacobian").ravel()),
            "frame_acceleration": to_array(_finite(
                robot.frame_acceleration(q, qd, qdd, link), "frame acceleration")),
            "jacobian_dot_qd": to_array(_finite(robot.jacobian_dot_qd(q, qd, link),
                                                "bias acceleration")),
            "operational_space_inertia": to_array(_finite(robot.operational_space_inertia(
                q, link, req.damping), "operational-space inertia").ravel()),
            "dynamically_consistent_inverse": to_array(_finite(
                robot.dynamically_consistent_inverse(q, link, req.damping),
                "dynamically consistent inverse").ravel())}


# ------------------------------------------------------------------ the topic pair
def wrench_in_base(robot, wrench, in_tip, q):
    """A tip wrench (6,) [force; moment] given in the tip frame (``in_tip``) or the base frame,
    in base coordinates at q (n,) or (N, n): (6,) or (N, 6); None stays None."""
    if wrench is None or not in_tip:
        return wrench
    R = robot.forward_kinematics(q)[..., :3, :3]            # tip -> base, per point
    return np.concatenate([R @ wrench[:3], R @ wrench[3:]], axis=-1)


def torques(robot, q, qd, qdd, wrench=None, in_tip=False, compensate=False):
    """tau (N, n) = M(q) qdd + b(q, qd) - J^T w (- the dissipation when compensated) for the
    points (N, n): one batched call, or the single-state path (cheaper) for one point.
    ``wrench``: (6,) on the tip, in the tip frame if ``in_tip``, else the base's."""
    args = (q[0], qd[0], qdd[0]) if len(q) == 1 else (q, qd, qdd)
    tau = robot.inverse_dynamics(*args, wrench_in_base(robot, wrench, in_tip, args[0]))
    tau = tau.reshape(q.shape)
    if compensate:
        tau = tau - robot.dissipation_torques(qd)
    if not np.isfinite(tau).all():
        raise Rejected("result NaN/Inf", "the torques came out non-finite")
    return tau


def fill_trajectory(msg, robot, q, qd, qdd, tau):
    """The answer to the trajectory ``msg``, written into ``msg`` itself (its header and
    times kept): the robot's joints, every field of every point filled. No message is built
    per request (rclpy serializes the answer before ``publish`` returns)."""
    msg.joint_names = robot.joint_names
    for i, pt in enumerate(msg.points):
        pt.positions, pt.velocities = to_array(q[i]), to_array(qd[i])
        pt.accelerations, pt.effort = to_array(qdd[i]), to_array(tau[i])
    return msg


class Latency:
    """Latencies since the last ``take``: their count, sum and largest."""

    def __init__(self, clock=time.monotonic):
        self.clock = clock
        self.since, self.count, self.total, self.worst = clock(), 0, 0.0, 0.0

    def add(self, seconds):
        self.count, self.total = self.count + 1, self.total + seconds
        self.worst = max(self.worst, seconds)

    def take(self):
        """(rate (Hz), mean (ms), max (ms)) since the last take; a new window starts."""
        now = self.clock()
        rate = self.count / (now - self.since) if now > self.since else 0.0
        mean = 1e3 * self.total / self.count if self.count else 0.0
        out = (rate, mean, 1e3 * self.worst)
        self.since, self.count, self.total, self.worst = now, 0, 0.0, 0.0
        return out

