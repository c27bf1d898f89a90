"""Dynamics node: inverse and forward dynamics, the mass matrix and the torques along a
trajectory as ROS 2 services, and the inverse-dynamics request/response topic pair.

    python -m serial_dynamics.ros.dynamics
    ros2 run serial_dynamics dynamics

Services (types in serial_dynamics_interfaces/srv; checked and answered by ``requests.py``):
``~/inverse_dynamics``, ``~/forward_dynamics``, ``~/mass_matrix``, ``~/trajectory_torques``;
``~/estimate_payload`` (from the ``joint_states`` with efforts it has seen; on request it sets
its own payload.*) and ``~/time_parameterize`` (``payload_timing.py``); ``~/task_space``
(a link's J, acceleration, J-dot qd, Lambda and J-bar); ``~/contact_inverse_dynamics`` (the
joint torques and contact wrenches that realise accelerations with given contacts: a legged
robot's stance, with ``floating_base``; ``contact_requests.py``).
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

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from serial_dynamics_interfaces.srv import (ContactInverseDynamics, EstimatePayload,
                                            ForwardDynamics, InverseDynamics, MassMatrix,
                                            TaskSpace, TimeParameterize, TrajectoryTorques)
from trajectory_msgs.msg import JointTrajectory

from . import common, contact_requests, parameters, payload_timing, requests
from .common import Rejected
from ..loops.progress import Heartbeat

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "include_gravity": ("bool", True, "include the gravity torques"),
    "compensate_dissipation": ("bool", False, "add the torque that overcomes the joint "
                               "dissipation (friction) at the requested velocities"),
    **parameters.PAYLOAD_PARAMETERS,
    "floating_base": ("bool", False, "the base link floats free: ~/contact_inverse_dynamics "
                      "takes the base's pose, velocity and acceleration"),
}


# floating_base: q has the base's pose first, so only the service that takes it answers
FLOATING_BASE = ("{} takes the joints alone, but this node's robot has a floating base "
                 "(floating_base:=true): call ~/contact_inverse_dynamics, which takes the "
                 "base's pose, velocity and acceleration too")

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
        with Heartbeat(self.get_logger().info, "compiling the dynamics kernels"):
            # trajectories: one batched call; Jacobians
            self.robot.warmup(batch=True, kinematics=True)
        self.reject = common.Rejections(self, hardware_id=self.robot.model.name)
        self._latency = {"topic": requests.Latency()}       # the topic pair, each service
        self.reject.watch(self._diagnostics)
        for name, srv_type, answer in (
                ("inverse_dynamics", InverseDynamics, self._inverse_dynamics),
                ("forward_dynamics", ForwardDynamics, self._forward_dynamics),
                ("mass_matrix", MassMatrix, requests.answer_mass_matrix),
                ("trajectory_torques", TrajectoryTorques, self._trajectory_torques),
                ("estimate_payload", EstimatePayload, self._estimate_payload),
                ("time_parameterize", TimeParameterize, lambda robot, req:
                 payload_timing.answer_time_parameterize(robot, req, self.compensate)),
                ("task_space", TaskSpace, requests.answer_task_space),
                ("contact_inverse_dynamics", ContactInverseDynamics, lambda robot, req:
                 contact_requests.answer_contact_inverse_dynamics(robot, req, self.compensate))):
            self._latency[f"~/{name}"] = requests.Latency()
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

    def on_request(self, msg):
        start = time.perf_counter()
        self._answer(msg)
        self._latency["topic"].add(time.perf_counter() - start)

    def _torques(self, robot, msg, what, wrench=None, in_tip=False):
        """(q, qd, qdd, tau (N, n)) of a JointTrajectory; Rejected or the library's ValueError."""
        _, q, qd, qdd, _, _ = common.trajectory_arrays(msg, robot, what)
        return q, qd, qdd, requests.torques(robot, q, qd, qdd, wrench, in_tip, self.compensate)

    def _answer(self, msg):
        robot = self.robot      # one model for the whole request
        try:
            if robot.is_floating:
                raise Rejected("floating_base", FLOATING_BASE.format("inverse_dynamics/request"))
            q, qd, qdd, tau = self._torques(robot, msg, "inverse_dynamics/request",
                                            self.wrench, self.wrench_in_tip)
        except Rejected as exc:
            return self.reject("inverse_dynamics/request", exc, "; no response sent")
        except (ValueError, ArithmeticError) as exc:     # anything else the library refuses
            return self.reject("inverse_dynamics/request", Rejected("library", str(exc)),
                               "; no response sent")
        self.pub.publish(requests.fill_trajectory(msg, robot, q, qd, qdd, tau))
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
        q, qd, qdd, tau = self._torques(robot, msg, "trajectory")
        return {"trajectory": requests.fill_trajectory(msg, robot, q, qd, qdd, tau)}

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
        latency = self._latency[key]

        def callback(request, response):
            start = time.perf_counter()
            self.reject.got(key)
            try:
                robot = self.robot                          # one model for the whole call
                if robot.is_floating and key != "~/contact_inverse_dynamics":
                    raise Rejected("floating_base", FLOATING_BASE.format(key))
                fields = answer(robot, request)
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
            latency.add(time.perf_counter() - start)
            return response
        return callback

    def _diagnostics(self):
        """Since the last report: the topic pair's request rate (Hz of wall time) and
        latency mean and max (ms, from the request taken off the queue to its answer
        published, refused ones included); per service the latency mean and max (ms, to
        the answer returned to rclpy). Calls and refusals are the counts ``received ...``
        and ``refused ...``."""
        rate, mean, worst = self._latency["topic"].take()
        values = [("request rate (Hz)", f"{rate:.1f}"), ("latency mean (ms)", f"{mean:.3f}"),
                  ("latency max (ms)", f"{worst:.3f}")]
        for key, latency in self._latency.items():
            if key != "topic":
                _, mean, worst = latency.take()
                values += [(f"{key} latency mean (ms)", f"{mean:.3f}"),
                           (f"{key} latency max (ms)", f"{worst:.3f}")]
        return values

    def close(self):
        pass


def main(args=None):
    return common.run(Dynamics, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
