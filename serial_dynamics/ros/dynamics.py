"""Dynamics node: inverse and forward dynamics, the mass matrix and the torques along a
trajectory as ROS 2 services, and the inverse-dynamics request/response topic pair.

    python -m serial_dynamics.ros.dynamics
    ros2 run serial_dynamics dynamics

Services (types in serial_dynamics_interfaces/srv; checked and answered by ``requests.py``):
``~/inverse_dynamics``, ``~/forward_dynamics``, ``~/mass_matrix``, ``~/trajectory_torques``;
``~/estimate_payload`` (from the ``joint_states`` with efforts it has seen; on request it sets
its own payload.*) and ``~/time_parameterize`` (``payload_timing.py``).
A refused request is answered with ``success: false`` and a message naming the field and
the fix; the node carries on.

Topics, for 1 kHz streams: a trajectory_msgs/JointTrajectory on ``inverse_dynamics/request``
(joint names in any order; one point or many; missing velocities/accelerations are zeros) is
answered on ``inverse_dynamics/response`` with the same header, the joint names in model
order and, for every point, positions, velocities, accelerations and the torques ``effort``
that produce them: tau = M(q) qdd + b(q, qd) - J^T w (+ the dissipation, when compensated),
computed in one batched call for all the points (the single-state path for one).
/diagnostics counts requests and calls, refusals, the request rate and the latency (receipt
of a request to its answer, in this node) per service and for the topic pair, since the
previous report. ``inverse_dynamics.py`` starts this node under its old name.
"""
from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from serial_dynamics_interfaces.srv import (EstimatePayload, ForwardDynamics, InverseDynamics,
                                            MassMatrix, TimeParameterize, TrajectoryTorques)
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from . import common, parameters, payload_timing, requests
from .common import Rejected

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "include_gravity": ("bool", True, "include the gravity torques"),
    "compensate_dissipation": ("bool", False, "add the torque that overcomes the joint "
                               "dissipation (friction) at the requested velocities"),
    **parameters.PAYLOAD_PARAMETERS,
}


# Services: reliable and volatile as rclpy's default, but keeping the last REQUEST_DEPTH
# requests (as the topic pair) so that a stall of the node does not drop calls at 1 kHz.
SERVICE_QOS = QoSProfile(depth=common.REQUEST_DEPTH)


class Dynamics(Node):
    NAME = "dynamics"

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
        self._latency = {}                                  # service: [calls, sum, max (s)]
        self.reject.watch(self._service_diagnostics)
        for name, srv_type, answer in (
                ("inverse_dynamics", InverseDynamics, self._inverse_dynamics),
                ("forward_dynamics", ForwardDynamics, self._forward_dynamics),
                ("mass_matrix", MassMatrix, requests.answer_mass_matrix),
                ("trajectory_torques", TrajectoryTorques, self._trajectory_torques),
                ("estimate_payload", EstimatePayload, self._estimate_payload),
                ("time_parameterize", TimeParameterize, lambda robot, req:
                 payload_timing.answer_time_parameterize(robot, req, self.compensate))):
            self._latency[f"~/{name}"] = [0, 0.0, 0.0]
            self.create_service(srv_type, f"~/{name}", self._serve(f"~/{name}", answer),
                                qos_profile=SERVICE_QOS)
        self.pub = self.create_publisher(JointTrajectory, "inverse_dynamics/response",
                                         common.REQUEST_DEPTH)
        common.subscribe(self, self.reject, WrenchStamped, "inverse_dynamics/tip_wrench",
                         self.on_wrench)
        common.subscribe(self, self.reject, JointTrajectory, "inverse_dynamics/request",
                         self.on_request, common.REQUEST_DEPTH)
        self.joint_log = payload_timing.JointStateLog(self.robot)     # for ~/estimate_payload
        common.subscribe(self, self.reject, JointState, "joint_states", lambda m: self.joint_log.add(
            m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec or self.get_clock().now().nanoseconds
            * 1e-9, m.name, m.position, m.effort), common.REQUEST_DEPTH)

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

    def _torques(self, robot, msg, what, wrench):
        """(q, qd, qdd, tau (N, n)) of a JointTrajectory; Rejected or the library's ValueError."""
        _, q, qd, qdd, _, _ = common.trajectory_arrays(msg, robot, what)
        if len(q) == 1:     # one point: the single-state path (cheaper to call)
            tau = robot.inverse_dynamics(q[0], qd[0], qdd[0], wrench(q[0]))[None]
        else:               # many: one batched call over the (N, n) arrays
            tau = robot.inverse_dynamics(q, qd, qdd, wrench(q))
        if self.compensate:
            tau = tau - robot.dissipation_torques(qd)
        if not np.all(np.isfinite(tau)):
            raise Rejected("result NaN/Inf", "the torques came out non-finite")
        return q, qd, qdd, tau

    @staticmethod
    def _trajectory(msg, robot, q, qd, qdd, tau):
        """The answer to ``msg``: its header and times, the robot's joints, every field filled."""
        out = JointTrajectory(header=msg.header, joint_names=robot.joint_names)
        out.points = [JointTrajectoryPoint(positions=q[i].tolist(), velocities=qd[i].tolist(),
                                           accelerations=qdd[i].tolist(), effort=tau[i].tolist(),
                                           time_from_start=pt.time_from_start)
                      for i, pt in enumerate(msg.points)]
        return out

    def _answer(self, msg):
        robot = self.robot      # one model for the whole request
        try:
            q, qd, qdd, tau = self._torques(robot, msg, "inverse_dynamics/request", self._wrench)
        except Rejected as exc:
            return self.reject("inverse_dynamics/request", exc, "; no response sent")
        except (ValueError, ArithmeticError) as exc:     # anything else the library refuses
            return self.reject("inverse_dynamics/request", Rejected("library", str(exc)),
                               "; no response sent")
        self.pub.publish(self._trajectory(msg, robot, q, qd, qdd, tau))
        self.reject.put("inverse_dynamics/response")

    # ---------------------------------------------------------------- services
    def _inverse_dynamics(self, robot, request):
        return requests.answer_inverse_dynamics(robot, request, self.compensate)

    def _forward_dynamics(self, robot, request):
        return requests.answer_forward_dynamics(robot, request, self.compensate)

    def _trajectory_torques(self, robot, request):
        """The tip_wrench topic is the topic pair's: a service answers from its request only."""
        msg = request.trajectory
        if not msg.joint_names:         # empty: the robot's order, as in the other services
            msg.joint_names = robot.joint_names
        q, qd, qdd, tau = self._torques(robot, msg, "trajectory", lambda q: None)
        return {"trajectory": self._trajectory(msg, robot, q, qd, qdd, tau)}

    def _estimate_payload(self, robot, request):
        """The estimate's fields; with ``apply``, payload.* set on this node (all or none)."""
        fields, apply = payload_timing.answer_estimate_payload(robot, self.joint_log, request)
        if apply is not None:
            result = self.set_parameters_atomically([Parameter(k, value=v) for k, v in apply.items()])
            if not result.successful:
                raise Rejected("apply", f"the estimate was not applied: {result.reason}")
            fields["message"] += "; applied to payload.*"
        return fields

    def _serve(self, key, answer):
        """The callback of service ``key``: ``answer(robot, request)`` gives the response's
        fields, or raises ``Rejected`` (the field and the fix) or the library's ValueError. Every call is counted and timed; none kills the node."""
        window = self._latency[key]

        def callback(request, response):
            start = time.perf_counter()
            self.reject.got(key)
            try:
                fields = answer(self.robot, request)        # one model for the whole call
            except (ValueError, ArithmeticError) as exc:
                refusal = exc if isinstance(exc, Rejected) else Rejected("library", str(exc))
                self.reject(key, refusal, "; answered success: false")
                response.success, response.message = False, str(exc)
            except Exception as exc:  # noqa: BLE001 -- a node never dies on a request
                self.reject.once(("bug", key, type(exc).__name__),
                                 f"internal error on a {key} call (please report): "
                                 f"{type(exc).__name__}: {exc}; the node carries on",
                                 f"internal error on {{}} more {key} call(s)")
                response.success = False
                response.message = f"internal error: {type(exc).__name__}: {exc}"
            else:
                for field, value in fields.items():
                    setattr(response, field, value)
                response.success = True
            latency = time.perf_counter() - start
            window[0], window[1], window[2] = window[0] + 1, window[1] + latency, max(window[2], latency)
            return response
        return callback

    def _service_diagnostics(self):
        """Per service, since the last report: latency mean and max (ms, from the request
        taken to its answer returned to rclpy, refused ones included). Calls and refusals
        are the counts ``received ~/<service>`` and ``refused ~/<service>``."""
        values = []
        for key, window in self._latency.items():
            calls, total, worst = window
            window[:] = [0, 0.0, 0.0]
            values += [(f"{key} latency mean (ms)", f"{1e3 * total / calls if calls else 0.0:.3f}"),
                       (f"{key} latency max (ms)", f"{1e3 * worst:.3f}")]
        return values

    def close(self):
        pass


def main(args=None):
    return common.run(Dynamics, args)


if __name__ == "__main__":
    raise SystemExit(main())
