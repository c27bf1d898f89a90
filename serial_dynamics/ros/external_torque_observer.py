"""External-torque observer node: contact and collision detection from the joint states.

    python -m serial_dynamics.ros.external_torque_observer
    ros2 run serial_dynamics external_torque_observer

Every ``joint_states`` message (position, velocity, and in ``effort`` the actuator torque
applied, as the simulator publishes it) is one sample of
``serial_dynamics.observers.MomentumObserver`` (the generalized-momentum observer, with
its sample times from the header stamps). For each it publishes, with the same stamp, the
estimated external joint torques (``estimated_external_torques``, JointState ``effort``
by name), the tip wrench that explains them in least squares
(``estimated_external_wrench``: exerted on the tip, base frame, as the simulator's
``external_wrench`` input) and ``collision`` (std_msgs/Bool): true from the first sample
where some |tau_ext_i| exceeds its threshold, false again once every |tau_ext_i| is below
``collision_release`` times its threshold (hysteresis).

The node converts parameters and messages; the stamps' checks, the restarts, the estimate
and the collision flag are ``serial_dynamics.loops.observer.CollisionMonitor`` (one call
per joint state).
"""
from __future__ import annotations

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from ..loops.observer import CollisionMonitor
from . import common, parameters
from .common import Rejected
from .parameters import StartupError
from ..loops.progress import Heartbeat

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "gain": ("double", 50.0, "observer gain K (1/s): the estimate follows a step of the "
             "external torque as 1 - exp(-K t)"),
    "collision_thresholds": ("double[]", [10.0], "|estimated torque| (N m; N) beyond which "
                             "a collision is flagged, one or one per joint"),
    "collision_release": ("double", 0.5, "fraction of the thresholds below which every "
                          "joint must fall to clear the collision (hysteresis), in [0, 1]"),
    "compensate_dissipation": ("bool", False, "subtract the modelled joint friction "
                               "(dissipation.*) from the momentum balance"),
    "max_sample_gap": ("double", 0.1, "s between two joint_states stamps beyond which the "
                       "observer restarts from the current momentum (a pause, a reset); a "
                       "stamp that goes back restarts it too (a simulator restarted)"),
    **parameters.PAYLOAD_PARAMETERS,
}


class ExternalTorqueObserver(Node):
    NAME = "external_torque_observer"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        p = parameters.declare(self, PARAMETERS, {"collision_release": (0.0, 1.0)})
        # payload.* (start-up values here) may be set while running: the observer restarts
        # on the new model
        robot = parameters.with_payload_parameters(self, parameters.load_robot(self, p), p,
                                                   lambda robot: self.monitor.set_robot(robot))
        try:
            self.monitor = CollisionMonitor(
                robot, p["gain"], parameters.per_joint("collision_thresholds",
                                                       p["collision_thresholds"], robot,
                                                       [10.0] * robot.dof),
                p["collision_release"], p["max_sample_gap"], p["compensate_dissipation"])
        except ValueError as exc:
            raise StartupError(str(exc)) from None
        with Heartbeat(self.get_logger().info, "compiling the dynamics kernels"):
            self.monitor.warmup()
        self.chain = set(robot.all_joint_names)     # mimic joints: named, not used
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self.monitor.report)
        self.pub_tau, self.pub_w, self.pub_c = (
            self.create_publisher(kind, topic, common.QOS_DEPTH) for kind, topic in
            ((JointState, "estimated_external_torques"),
             (WrenchStamped, "estimated_external_wrench"), (Bool, "collision")))
        common.subscribe(self, self.reject, JointState, "joint_states", self.on_state)

    @property
    def robot(self):
        return self.monitor.robot

    def on_state(self, msg):
        try:
            q, qd, tau = common.joint_state_arrays(msg, self.robot,
                                                   ("position", "velocity", "effort"),
                                                   allow_extra=True)
            unknown = [x for x in msg.name if x not in self.chain]
            if unknown:
                raise Rejected("unknown joint names", f"joint_states names joints {unknown} "
                               f"that are not joints of the model {self.robot.joint_names}")
            sample = self.monitor.update(common.stamp_seconds(msg.header.stamp), q, qd, tau)
        except Rejected as exc:
            return self.reject("joint_states", exc,
                               "; the estimate goes on from the last good state")
        except ValueError as exc:     # anything else the library refuses
            return self.reject("joint_states", Rejected("library", str(exc)))
        for key, text, repeats in sample.notes:
            self.reject.once(key, text, repeats)
        if sample.event and sample.collision:       # (rclpy: one severity per call site)
            self.get_logger().warning(sample.event)
        elif sample.event:
            self.get_logger().info(sample.event)
        self.publish(msg.header.stamp, sample)

    def publish(self, stamp, sample):
        out = JointState(name=self.robot.joint_names, effort=sample.tau_ext.tolist())
        out.header.stamp = stamp
        wrench = WrenchStamped()
        wrench.header.stamp, wrench.header.frame_id = stamp, self.robot.base_link
        f, m = wrench.wrench.force, wrench.wrench.torque
        f.x, f.y, f.z, m.x, m.y, m.z = sample.wrench.tolist()
        for pub, topic, message in ((self.pub_tau, "estimated_external_torques", out),
                                    (self.pub_w, "estimated_external_wrench", wrench),
                                    (self.pub_c, "collision", Bool(data=sample.collision))):
            pub.publish(message)
            self.reject.put(topic)

    def close(self):
        pass


def main(args=None):
    return common.run(ExternalTorqueObserver, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
