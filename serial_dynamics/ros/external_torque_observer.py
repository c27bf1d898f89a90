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
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from ..observers import MomentumObserver
from . import common, parameters
from .common import Rejected
from .parameters import StartupError

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
        # payload.* may be set while running: the observer restarts on the new model
        robot = self.robot = parameters.with_payload_parameters(
            self, parameters.load_robot(self, p), p, self._set_model)
        self.threshold = parameters.per_joint("collision_thresholds", p["collision_thresholds"],
                                              robot, [10.0] * robot.dof)
        self.release, self.max_gap = p["collision_release"], p["max_sample_gap"]
        thr, gain = self.threshold, p["gain"]
        for bad, text in (
                (not np.all((thr > 0) & np.isfinite(thr)),
                 f"'collision_thresholds' must be > 0 and finite, got {thr.tolist()}"),
                (not 0 < self.max_gap < np.inf,
                 f"'max_sample_gap' must be > 0 (s), got {self.max_gap}"),
                (not 0 < gain < np.inf, f"'gain' must be > 0 (1/s), got {gain}")):
            if bad:
                raise StartupError(f"parameter {text}")
        self._new_observer = lambda robot: MomentumObserver(robot, p["gain"],
                                                            p["compensate_dissipation"])
        try:
            self.observer = self._new_observer(robot)
        except ValueError as exc:
            raise StartupError(str(exc)) from None
        robot.warmup()
        zero = np.zeros(robot.dof)
        for t in (0.0, 1.0):            # compile or load the observer's kernels now
            self.observer.update(t, zero, zero, zero)
        self.observer.wrench(zero, zero)
        self.observer.reset()
        self.chain = set(robot.all_joint_names)     # mimic joints: named, not used
        self.collision, self.r, self.restarts = False, np.zeros(robot.dof), 0
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self.diagnostics)
        self.pub_tau, self.pub_w, self.pub_c = (
            self.create_publisher(kind, topic, common.QOS_DEPTH) for kind, topic in
            ((JointState, "estimated_external_torques"),
             (WrenchStamped, "estimated_external_wrench"), (Bool, "collision")))
        common.subscribe(self, self.reject, JointState, "joint_states", self.on_state)

    def on_state(self, msg):
        robot, obs = self.robot, self.observer
        try:
            msg_idx, idx = common.name_index(msg.name, robot, "joint_states", allow_extra=True)
            unknown = [x for x in msg.name if x not in self.chain]
            if unknown:
                raise Rejected("unknown joint names", f"joint_states names joints {unknown} "
                               f"that are not in the chain {robot.joint_names}")
            q, qd, tau = (np.empty(robot.dof) for _ in range(3))
            for x, field in ((q, "position"), (qd, "velocity"), (tau, "effort")):
                what = f"joint_states {field}"
                x[idx] = common.finite_vector(getattr(msg, field), len(msg.name), what,
                                              what)[msg_idx]
            t = common.stamp_seconds(msg.header.stamp)
            if t == 0.0:
                raise Rejected("zero stamp", "joint_states has a zero stamp; the observer "
                               "integrates over the stamps: stamp every message")
            if obs.t is not None and t == obs.t:
                raise Rejected("stamp repeated", f"joint_states stamp {t:.9f} s is the "
                               "previous one's (a paused simulator): nothing new to take")
            if obs.t is not None and not 0 < t - obs.t <= self.max_gap:
                self.restart(t - obs.t)
            r = obs.update(t, q, qd, tau)
            w, _ = obs.wrench(q, r)
        except Rejected as exc:
            return self.reject("joint_states", exc,
                               "; the estimate goes on from the last good state")
        except ValueError as exc:     # anything else the library refuses
            return self.reject("joint_states", Rejected("library", str(exc)))
        self.publish(msg.header.stamp, r, w)

    def restart(self, jump):
        """A stamp that jumps back (a simulator restarted, its time at 0 again) or forward
        by more than max_sample_gap (a pause, one stamp far off): a new start, as tf2
        clears its buffer on a jump back. The estimate restarts from the current momentum
        (r = 0 at this sample); logged once per direction, then counted."""
        self.restarts += 1
        way = "back" if jump < 0 else "forward"
        self.reject.once(("restart", way), f"joint_states stamp jumped {way} by {abs(jump):.6g} "
                         f"s (max_sample_gap {self.max_gap:g} s): the observer restarts from "
                         "the current momentum", f"observer restarted {{}} more times since "
                         f"on a stamp jump {way}")
        self.observer.reset()

    def publish(self, stamp, r, w):
        ratio = np.abs(r) / self.threshold
        j = int(np.argmax(ratio))
        if not self.collision and ratio[j] > 1:
            self.collision = True
            self.get_logger().warning(
                f"collision: estimated external torque {r[j]:.4g} at "
                f"{self.robot.joint_names[j]} (threshold {self.threshold[j]:.4g})")
        elif self.collision and ratio[j] < self.release:
            self.collision = False
            self.get_logger().info("collision cleared")
        self.r = r
        out = JointState(name=self.robot.joint_names, effort=r.tolist())
        out.header.stamp = stamp
        wrench = WrenchStamped()
        wrench.header.stamp, wrench.header.frame_id = stamp, self.robot.base_link
        f, m = wrench.wrench.force, wrench.wrench.torque
        f.x, f.y, f.z, m.x, m.y, m.z = w.tolist()
        for pub, topic, message in ((self.pub_tau, "estimated_external_torques", out),
                                    (self.pub_w, "estimated_external_wrench", wrench),
                                    (self.pub_c, "collision", Bool(data=self.collision))):
            pub.publish(message)
            self.reject.put(topic)

    def _set_model(self, robot):
        """A payload change: the momentum p = M qd of the new model starts a new estimate."""
        self.robot, self.observer = robot, self._new_observer(robot)

    def diagnostics(self):
        j = int(np.argmax(np.abs(self.r) / self.threshold))
        return [("largest estimated torque (N m)", f"{abs(self.r[j]):.4g}"),
                ("threshold at that joint (N m)", f"{self.threshold[j]:.4g}"),
                ("collision", self.collision, self.collision),
                ("restarts (stamp jumps)", self.restarts)]

    def close(self):
        pass


def main(args=None):
    return common.run(ExternalTorqueObserver, args)


if __name__ == "__main__":
    raise SystemExit(main())
