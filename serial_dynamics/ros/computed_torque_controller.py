"""Model-based joint controller node (computed torque, PD + gravity, gravity compensation).

    python -m serial_dynamics.ros.computed_torque_controller --ros-args -p kp:=[400.0]
    ros2 run serial_dynamics computed_torque_controller
    ros2 param set /computed_torque_controller mode gravity_compensation

Subscribes ``joint_states`` and a time-parameterized trajectory_msgs/JointTrajectory on
``desired_trajectory``; publishes ``effort_commands`` (std_msgs/Float64MultiArray, model
joint order) at ``control_rate`` with the law of the parameter ``mode`` (settable while
running; the laws keep no state, so the first command after a switch is the new law at
the state used). With ``lockstep`` it publishes ``joint_commands`` instead
(sensor_msgs/JointState, effort by name, stamped with the joint state the command was
computed from), at ``control_rate`` and at once on each joint state: a simulator in
lockstep waits for the answer to its latest state.

    computed_torque       tau = M(q) (qdd_d + Kp e + Kd edot) + b(q, qd)
    pd_gravity            tau = Kp' e + Kd' edot + g(q)
    gravity_compensation  tau = g(q)
                          [- delta(qd) in each mode when compensating friction]

(computed_torque is one recursive Newton-Euler call, robot.inverse_dynamics). The error
e = q_d - q is taken at the stamp of the joint state it uses (the state is a few ms old
when it arrives; comparing it with the reference of the same instant removes the lag
bias), the feed-forward qdd_d at the current time. The trajectory starts at its header
stamp (zero: on arrival) from the current reference, and its last point holds at the end.
Before any trajectory the controller holds the first measured position; in
gravity_compensation the reference follows the measured position (trajectories are
refused), so leaving that mode holds where the arm was left. Bad input is refused (the
last good state and trajectory stay); a command that comes out non-finite is not sent.

The node converts parameters and messages; what it holds between two messages and the law
are ``serial_dynamics.loops.controller.Controller`` (one call per callback).
"""
from __future__ import annotations

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from .. import control
from ..loops.controller import Controller, check_mode
from . import common, parameters
from .common import Rejected
from .parameters import StartupError
from ..loops.progress import Heartbeat

MODES = control.MODES        # the laws, written once (control.py)
PARAMETERS = {
    "mode": ("string", "computed_torque", f"control law: {', '.join(MODES)}. Settable while "
             "running"),
    **parameters.ROBOT_PARAMETERS,
    "control_rate": ("double", 500.0, "effort_commands rate (Hz, of the node's clock: "
                     "simulated time with use_sim_time)"),
    "kp": ("double[]", [400.0], "position gains (1/s^2), one or one per joint"),
    "kd": ("double[]", [40.0], "velocity gains (1/s), one or one per joint"),
    "pd.kp": ("double[]", None, "pd_gravity position gains (N m/rad), one or one per joint "
              "([] = kp times the effective inertia 1/(M(q)^-1)_ii at the state used, over "
              "the joints' coupling: docs/ros.md)"),
    "pd.kd": ("double[]", None, "pd_gravity velocity gains (N m s/rad), one or one per joint "
              "([] = kd times the effective inertia 1/(M(q)^-1)_ii at the state used, over "
              "the joints' coupling: docs/ros.md)"),
    "lockstep": ("bool", False, "publish joint_commands (effort by name, stamped with the "
                 "joint state used) instead of effort_commands, also at once on each joint "
                 "state, for a simulator with lockstep (docs/ros.md, Lockstep)"),
    "compensate_dissipation": ("bool", False, "add the torque that overcomes the joint "
                               "dissipation (friction) at the measured velocity"),
    **parameters.PAYLOAD_PARAMETERS,
}


class ComputedTorqueController(Node):
    NAME = "computed_torque_controller"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        # mode is settable while running: declared here (parameters.declare makes read-only)
        self.declare_parameter("mode", PARAMETERS["mode"][1], ParameterDescriptor(
            description=PARAMETERS["mode"][2], dynamic_typing=True))
        mode = self.get_parameter("mode").value
        if check_mode(mode):
            raise StartupError(check_mode(mode))
        p = parameters.declare(self, {k: v for k, v in PARAMETERS.items() if k != "mode"})
        # payload.* (start-up values here) may be set while running: the model is swapped
        # between two commands
        robot = parameters.with_payload_parameters(self, parameters.load_robot(self, p), p,
                                                   lambda robot: setattr(self.ctl, "robot", robot))
        gains = {x: None if p[x] is None else parameters.per_joint(x, p[x], robot, None, True)
                 for x in ("kp", "kd", "pd.kp", "pd.kd")}
        if not 0 < p["control_rate"] < float("inf"):
            raise StartupError(f"parameter 'control_rate' must be > 0, got {p['control_rate']}")
        self.ctl = Controller(robot, 1.0 / p["control_rate"], gains["kp"], gains["kd"],
                              gains["pd.kp"], gains["pd.kd"], p["compensate_dissipation"], mode)
        with Heartbeat(self.get_logger().info, "compiling the dynamics kernels"):
            robot.warmup()
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self.diagnostics)
        self.log_notes(self.ctl.startup_notes())
        self.add_on_set_parameters_callback(self.validate_mode)
        self.add_post_set_parameters_callback(self.apply_mode)
        # lockstep: JointState commands stamped with the state they answer (that stamp)
        self.lockstep, self.answers = p["lockstep"], None
        self.topic = "joint_commands" if self.lockstep else "effort_commands"
        self.pub = self.create_publisher(JointState if self.lockstep else Float64MultiArray,
                                         self.topic, common.QOS_DEPTH)
        # keep last 1: the law runs on the freshest state; a queue of states behind a stall
        # would feed it old ones, one per period, for as long as the backlog lasts
        common.subscribe(self, self.reject, JointState, "joint_states", self.on_state,
                         depth=1)
        common.subscribe(self, self.reject, JointTrajectory, "desired_trajectory",
                         self.on_trajectory)
        self.create_timer(self.ctl.period, self.on_timer)

    @property
    def robot(self):
        return self.ctl.robot

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def log_notes(self, notes):
        for key, text in notes:
            self.reject.once(key, text)

    def on_state(self, msg):
        try:   # extra joints (a gripper, another arm) are ignored; ours must all be there
            q, qd = common.joint_state_arrays(msg, self.robot, ("position", "velocity"),
                                              allow_extra=True)
        except Rejected as exc:
            return self.reject("joint_states", exc, "; control continues on the last good state")
        self.log_notes(self.ctl.set_state(common.stamp_seconds(msg.header.stamp), self.now(),
                                          q, qd))
        if self.lockstep:         # answer this state now: the simulator waits for it
            self.answers = msg.header.stamp
            self.on_timer()

    def on_trajectory(self, msg):
        try:
            t, q, qd, qdd, have_v, have_a = common.trajectory_arrays(
                msg, self.robot, "desired_trajectory", need_increasing_time=True)
            self.ctl.set_trajectory(common.stamp_seconds(msg.header.stamp) or self.now(), t, q,
                                    qd if have_v else None, qdd if have_a else None)
        except Rejected as exc:
            return self.reject("desired_trajectory", exc, "; the trajectory in force stays")

    def on_timer(self):
        try:
            tau = self.ctl.torque(self.now())
        except Rejected as exc:
            return self.reject(self.topic, exc, "; no command sent")
        if tau is None:
            return
        if self.lockstep:
            msg = JointState(name=self.robot.joint_names, effort=tau.tolist())
            msg.header.stamp = self.answers
            self.pub.publish(msg)
        else:
            self.pub.publish(Float64MultiArray(data=tau.tolist()))
        self.reject.put(self.topic)

    def validate_mode(self, params):
        for x in params:
            if x.name == "mode" and check_mode(x.value):
                reason = f"{check_mode(x.value)}; the mode in force ({self.ctl.mode}) stays"
                self.reject.once(("set mode",), f"rejected {reason}",
                                 "rejected {} more sets of mode since")
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def apply_mode(self, params):     # after validate_mode and rclpy have stored the value
        for x in params:
            if x.name == "mode" and self.ctl.set_mode(x.value):
                self.get_logger().info(f"mode {x.value} in force")

    def diagnostics(self):
        values, notes = self.ctl.report()
        self.log_notes(notes)
        return values

    def close(self):
        pass


def main(args=None):
    return common.run(ComputedTorqueController, args)


if __name__ == "__main__":
    raise SystemExit(main())
