"""The dynamics node's request path as it was before issue 26 item 2, for
bench_ros_throughput.py's before/after comparison in one run:

    python bench/_ros_legacy.py --ros-args -p robot_description_timeout:=0.0

The node of today with its per-request conversions put back as they were (the message fields
through Python lists, the checks of ``common.trajectory_arrays`` for any number of points,
``requests.answer_inverse_dynamics`` answering a list) and spun by rclpy's
SingleThreadedExecutor. Nothing here is used by the package.
"""
from __future__ import annotations

import numpy as np
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from serial_dynamics.ros import common, dynamics, requests
from serial_dynamics.ros.common import MAX_POINTS, MAX_VALUE, Rejected, _show, name_index


def trajectory_arrays(msg, robot, what, need_increasing_time=False):
    msg_idx, model_idx = name_index(msg.joint_names, robot, what)
    m, n, N = len(msg.joint_names), robot.dof, len(msg.points)
    if N == 0:
        raise Rejected("no points", f"{what} has no points")
    if N > MAX_POINTS:
        raise Rejected("too many points", f"{what} has {N} points")
    out = np.zeros((3, N, n))
    have = [True, True, True]
    for k, field in enumerate(("positions", "velocities", "accelerations")):
        sizes = {len(getattr(pt, field)) for pt in msg.points}
        if k > 0 and sizes == {0}:
            have[k] = False
            continue
        if sizes != {m}:
            raise Rejected(f"{field} length", f"{what}: lengths {_show(sorted(sizes))}")
        vals = np.array([getattr(pt, field) for pt in msg.points], dtype=float)
        if not np.all(np.isfinite(vals)):
            raise Rejected(f"{field} NaN/Inf", f"{what}: {field} contain NaN or Inf")
        if np.any(np.abs(vals) > MAX_VALUE):
            raise Rejected(f"{field} out of range", f"{what}: {field} out of range")
        out[k][:, model_idx] = vals[:, msg_idx]
    t = np.array([pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec
                  for pt in msg.points])
    return t, out[0], out[1], out[2], have[1], have[2]


def _torques(self, robot, msg, what, wrench=lambda q: None, in_tip=False):
    _, q, qd, qdd, _, _ = trajectory_arrays(msg, robot, what)
    if len(q) == 1:
        tau = robot.inverse_dynamics(q[0], qd[0], qdd[0], wrench(q[0]))[None]
    else:
        tau = robot.inverse_dynamics(q, qd, qdd, wrench(q))
    if self.compensate:
        tau = tau - robot.dissipation_torques(qd)
    if not np.all(np.isfinite(tau)):
        raise Rejected("result NaN/Inf", "the torques came out non-finite")
    return q, qd, qdd, tau


def _trajectory(msg, robot, q, qd, qdd, tau):
    out = JointTrajectory(header=msg.header, joint_names=robot.joint_names)
    out.points = [JointTrajectoryPoint(positions=q[i].tolist(), velocities=qd[i].tolist(),
                                       accelerations=qdd[i].tolist(), effort=tau[i].tolist(),
                                       time_from_start=pt.time_from_start)
                  for i, pt in enumerate(msg.points)]
    return out


def _answer(self, msg):
    robot = self.robot
    try:
        q, qd, qdd, tau = self._torques(robot, msg, "inverse_dynamics/request", lambda q:
                                        requests.wrench_in_base(robot, self.wrench,
                                                                self.wrench_in_tip, q))
    except Rejected as exc:
        return self.reject("inverse_dynamics/request", exc, "; no response sent")
    except (ValueError, ArithmeticError) as exc:
        return self.reject("inverse_dynamics/request", Rejected("library", str(exc)),
                           "; no response sent")
    self.pub.publish(self._trajectory(msg, robot, q, qd, qdd, tau))
    self.reject.put("inverse_dynamics/response")


def joint_vector(robot, index, values, field, empty_is_zero=False):
    n = robot.dof
    if len(values) == 0 and empty_is_zero:
        return np.zeros(n)
    size = n if index is None else len(index)
    if len(values) != size:
        raise Rejected(field, f"{field} has {len(values)} values")
    a = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(a)):
        raise Rejected(field, f"{field} has NaN or Inf")
    if index is None:
        return a
    out = np.zeros(n)
    out[index] = a
    return out


def answer_inverse_dynamics(robot, req, compensate=False):
    index = requests.joint_order(robot, req.joint_names)
    q = joint_vector(robot, index, req.positions, "positions")
    qd = joint_vector(robot, index, req.velocities, "velocities", empty_is_zero=True)
    qdd = joint_vector(robot, index, req.accelerations, "accelerations", empty_is_zero=True)
    tau = robot.inverse_dynamics(q, qd, qdd, requests.tip_wrench(req.tip_wrench))
    if compensate:
        tau = tau - robot.dissipation_torques(qd)
    return {"joint_names": robot.joint_names, "efforts": tau.tolist()}


def main():
    D = dynamics.Dynamics
    D._torques, D._answer, D._trajectory = _torques, _answer, staticmethod(_trajectory)
    D._inverse_dynamics = lambda self, robot, request: answer_inverse_dynamics(
        robot, request, self.compensate)
    return common.run(D, None, events=False)


if __name__ == "__main__":
    raise SystemExit(main())
