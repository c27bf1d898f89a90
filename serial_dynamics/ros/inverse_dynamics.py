"""Inverse-dynamics node: the computed-torque service over topics.

    python -m serial_dynamics.ros.inverse_dynamics
    ros2 run serial_dynamics inverse_dynamics

A trajectory_msgs/JointTrajectory on ``inverse_dynamics/request`` (joint names in any
order; one point or many; missing velocities/accelerations are zeros) is answered on
``inverse_dynamics/response`` with the same header, the joint names in model order and,
for every point, positions, velocities, accelerations and the torques ``effort`` that
produce them: tau = M(q) qdd + b(q, qd) - J^T w (+ the dissipation, when compensated),
computed in one batched call for all the points (the single-state path for one).
Requests and answers are counted on /diagnostics, with the request rate and the latency
(receipt of a request to its answer published, in this node) since the previous report.
"""
from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from . import common, parameters
from .common import Rejected

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "include_gravity": ("bool", True, "include the gravity torques"),
    "compensate_dissipation": ("bool", False, "add the torque that overcomes the joint "
                               "dissipation (friction) at the requested velocities"),
    **parameters.PAYLOAD_PARAMETERS,
}


class InverseDynamics(Node):
    NAME = "inverse_dynamics"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        p = parameters.declare(self, PARAMETERS)
        gravity = None if p["include_gravity"] else [0.0, 0.0, 0.0]
        # payload.* may be set while running: the model is swapped between two requests
        self.robot = parameters.with_payload_parameters(
            self, parameters.load_robot(self, p, gravity=gravity), p,
            lambda robot: setattr(self, "robot", robot))
        self.compensate = p["compensate_dissipation"]
        self.wrench = None            # latest tip wrench: (6,) in base_link, or (6,) in tip_link
        self.wrench_in_tip = False
        self.robot.warmup(batch=True)      # trajectories are one batched call
        self.reject = common.Rejections(self, hardware_id=self.robot.model.name)
        self._window = [time.monotonic(), 0, 0.0, 0.0]    # since: requests, sum, max latency (s)
        self.reject.watch(self._diagnostics)
        self.pub = self.create_publisher(JointTrajectory, "inverse_dynamics/response",
                                         common.REQUEST_DEPTH)
        common.subscribe(self, self.reject, WrenchStamped, "inverse_dynamics/tip_wrench",
                         self.on_wrench)
        common.subscribe(self, self.reject, JointTrajectory, "inverse_dynamics/request",
                         self.on_request, common.REQUEST_DEPTH)

    def on_wrench(self, msg):
        f, m = msg.wrench.force, msg.wrench.torque
        try:
            w = common.finite_vector([f.x, f.y, f.z, m.x, m.y, m.z], 6, "tip_wrench", "tip_wrench")
            frame = msg.header.frame_id
            if frame not in ("", self.robot.base_link, self.robot.tip_link):
                raise Rejected("frame", f"tip_wrench frame_id {frame!r} is neither the base "
                               f"({self.robot.base_link!r}) nor the tip ({self.robot.tip_link!r})")
        except Rejected as exc:
            return self.reject("tip_wrench", exc, "; the last good wrench stays in force")
        self.wrench, self.wrench_in_tip = w, frame == self.robot.tip_link and frame != self.robot.base_link

    def _wrench(self, q):
        """The latest wrench in base coordinates, per point: (N, 6) or None."""
        if self.wrench is None or not self.wrench_in_tip:
            return self.wrench
        R = self.robot.forward_kinematics(q)[..., :3, :3]            # (N, 3, 3) tip -> base
        return np.concatenate([R @ self.wrench[:3], R @ self.wrench[3:]], axis=-1)

    def on_request(self, msg):
        start = time.perf_counter()
        self._answer(msg)
        latency, w = time.perf_counter() - start, self._window
        w[1], w[2], w[3] = w[1] + 1, w[2] + latency, max(w[3], latency)

    def _diagnostics(self):
        """Request rate (Hz of wall time), latency mean and max (ms: from the request taken
        off the queue to its answer published, refused ones included) since the last report."""
        now = time.monotonic()
        since, count, total, worst = self._window
        self._window = [now, 0, 0.0, 0.0]
        rate = count / (now - since) if now > since else 0.0
        mean = 1e3 * total / count if count else 0.0
        return [("request rate (Hz)", f"{rate:.1f}"), ("latency mean (ms)", f"{mean:.3f}"),
                ("latency max (ms)", f"{1e3 * worst:.3f}")]

    def _answer(self, msg):
        robot = self.robot      # one model for the whole request
        try:
            _, q, qd, qdd, _, _ = common.trajectory_arrays(msg, robot, "inverse_dynamics/request")
            if len(q) == 1:     # one point: the single-state path (cheaper to call)
                tau = robot.inverse_dynamics(q[0], qd[0], qdd[0], self._wrench(q[0]))[None]
            else:               # many: one batched call over the (N, n) arrays
                tau = robot.inverse_dynamics(q, qd, qdd, self._wrench(q))
            if self.compensate:
                tau = tau - robot.dissipation_torques(qd)
            if not np.all(np.isfinite(tau)):
                raise Rejected("result NaN/Inf", "the torques came out non-finite")
        except Rejected as exc:
            return self.reject("inverse_dynamics/request", exc, "; no response sent")
        except (ValueError, ArithmeticError) as exc:     # anything else the library refuses
            return self.reject("inverse_dynamics/request", Rejected("library", str(exc)),
                               "; no response sent")
        out = JointTrajectory(header=msg.header, joint_names=robot.joint_names)
        out.points = [JointTrajectoryPoint(positions=q[i].tolist(), velocities=qd[i].tolist(),
                                           accelerations=qdd[i].tolist(), effort=tau[i].tolist(),
                                           time_from_start=pt.time_from_start)
                      for i, pt in enumerate(msg.points)]
        self.pub.publish(out)
        self.reject.put("inverse_dynamics/response")

    def close(self):
        pass


def main(args=None):
    return common.run(InverseDynamics, args)


if __name__ == "__main__":
    raise SystemExit(main())
