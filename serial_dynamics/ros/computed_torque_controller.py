"""Model-based joint controller node (computed torque, PD + gravity, gravity compensation).

    python -m serial_dynamics.ros.computed_torque_controller --ros-args -p kp:=[400.0]
    ros2 run serial_dynamics computed_torque_controller
    ros2 param set /computed_torque_controller mode gravity_compensation

Subscribes ``joint_states`` and a time-parameterized trajectory_msgs/JointTrajectory on
``desired_trajectory``; publishes ``effort_commands`` (std_msgs/Float64MultiArray, model
joint order) at ``control_rate`` with the law of the parameter ``mode`` (settable while
running; the laws keep no state, so the first command after a switch is the new law at
the state used):

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
"""
from __future__ import annotations

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

from serial_dynamics.trajectory import Waypoints

from .. import control
from . import common, parameters
from .common import Rejected
from .parameters import StartupError

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
    "compensate_dissipation": ("bool", False, "add the torque that overcomes the joint "
                               "dissipation (friction) at the measured velocity"),
    **parameters.PAYLOAD_PARAMETERS,
}
MAX_STATE_AGE = 0.5   # s; an older (or future) state stamp is taken as "now" (clock mismatch)


def check_mode(mode):
    """None if ``mode`` is a mode of the controller, else the reason."""
    if mode not in MODES:
        return f"parameter 'mode' must be one of {', '.join(MODES)}; got {mode!r}"
    return None


class ComputedTorqueController(Node):
    NAME = "computed_torque_controller"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        # mode is settable while running: declared here (parameters.declare makes read-only)
        self.declare_parameter("mode", PARAMETERS["mode"][1], ParameterDescriptor(
            description=PARAMETERS["mode"][2], dynamic_typing=True))
        self.mode = self.get_parameter("mode").value
        if check_mode(self.mode):
            raise StartupError(check_mode(self.mode))
        p = parameters.declare(self, {k: v for k, v in PARAMETERS.items() if k != "mode"})
        # payload.* may be set while running: the model is swapped between two commands
        self.robot = robot = parameters.with_payload_parameters(
            self, parameters.load_robot(self, p), p, lambda robot: setattr(self, "robot", robot))
        self.kp = parameters.per_joint("kp", p["kp"], robot, None, positive=True)
        self.kd = parameters.per_joint("kd", p["kd"], robot, None, positive=True)
        # pd gains given: constant; not given (None): kp, kd times the effective inertia at
        # the state used (pd_gains), so that every joint's loop has the bandwidth of kp, kd
        self.pd_kp, self.pd_kd = (
            None if p[x] is None else parameters.per_joint(x, p[x], robot, None, True)
            for x in ("pd.kp", "pd.kd"))
        if not 0 < p["control_rate"] < np.inf:
            raise StartupError(f"parameter 'control_rate' must be > 0, got {p['control_rate']}")
        self.period = 1.0 / p["control_rate"]
        self.compensate = p["compensate_dissipation"]
        self.wrap = np.array([k == "continuous" for k in robot.joint_types])
        self.state = None           # (t, q, qd) of the latest good joint state
        self.reference = None       # (t0, Waypoints) in force
        self.error_max, self.saturated = None, set()    # since the last /diagnostics report
        robot.warmup()
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self.diagnostics)
        # joints whose gains are beyond the stability bound: computed_torque's (the loop
        # it makes has unit inertia), pd_gravity's at the latest state (check_bound)
        self.beyond_ct = set(control.beyond(self.kp, self.kd, np.ones(robot.dof),
                                             self.period).tolist())
        self.beyond_pd = set()
        for j in sorted(self.beyond_ct):
            self.warn_bound(j, self.kp[j], self.kd[j], 1.0, "kp, kd (computed_torque)")
        self.add_on_set_parameters_callback(self.validate_mode)
        self.add_post_set_parameters_callback(self.apply_mode)
        self.pub = self.create_publisher(Float64MultiArray, "effort_commands", common.QOS_DEPTH)
        # keep last 1: the law runs on the freshest state; a queue of states behind a stall
        # would feed it old ones, one per period, for as long as the backlog lasts
        common.subscribe(self, self.reject, JointState, "joint_states", self.on_state,
                         depth=1)
        common.subscribe(self, self.reject, JointTrajectory, "desired_trajectory",
                         self.on_trajectory)
        self.create_timer(1.0 / p["control_rate"], self.on_timer)

    def now(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def desired(self, t):
        t0, traj = self.reference
        return traj.sample(t - t0)

    def on_state(self, msg):
        try:
            # extra joints (a gripper, another arm) are ignored; ours must all be there
            msg_idx, idx = common.name_index(msg.name, self.robot, "joint_states",
                                             require_all=True, allow_extra=True)
            q, qd = np.empty(self.robot.dof), np.empty(self.robot.dof)
            q[idx] = common.finite_vector(msg.position, len(msg.name), "joint_states position",
                                          "joint_states position")[msg_idx]
            qd[idx] = common.finite_vector(msg.velocity, len(msg.name), "joint_states velocity",
                                           "joint_states velocity")[msg_idx]
        except Rejected as exc:
            return self.reject("joint_states", exc, "; control continues on the last good state")
        now, t = self.now(), common.stamp_seconds(msg.header.stamp)
        if t == 0.0 or abs(now - t) > MAX_STATE_AGE:
            t = now
        first, self.state = self.state is None, (t, q, qd)
        if first:
            self.check_bound()
        if self.reference is None or self.mode == "gravity_compensation":
            self.hold()

    def hold(self):
        """The reference: at rest where the latest state is."""
        t, q, _ = self.state
        self.reference = (t, Waypoints([0.0], q[None]))

    def on_trajectory(self, msg):
        try:
            t, q, qd, qdd, have_v, have_a = common.trajectory_arrays(
                msg, self.robot, "desired_trajectory", need_increasing_time=True)
            if have_a and not have_v:
                raise Rejected("accelerations without velocities", "desired_trajectory gives "
                               "accelerations but no velocities")
            if self.reference is None:
                raise Rejected("no joint state yet", "desired_trajectory arrived before any "
                               "joint_states message")
            if self.mode == "gravity_compensation":
                raise Rejected("gravity_compensation", "desired_trajectory arrived in mode "
                               "gravity_compensation, which follows no reference; set mode "
                               "to computed_torque or pd_gravity first")
        except Rejected as exc:
            return self.reject("desired_trajectory", exc, "; the trajectory in force stays")
        start = common.stamp_seconds(msg.header.stamp) or self.now()
        if t[0] > 0:                                 # start from the current reference
            q0, qd0, qdd0 = self.desired(start)
            t, q = np.r_[0.0, t], np.vstack([q0, q])
            qd, qdd = np.vstack([qd0, qd]), np.vstack([qdd0, qdd])
        try:
            waypoints = Waypoints(t, q, qd if have_v else None, qdd if have_a else None)
        except ValueError as exc:                    # e.g. times too close to tell apart
            return self.reject("desired_trajectory", Rejected("waypoints", str(exc)),
                               "; the trajectory in force stays")
        self.reference = (start, waypoints)

    def on_timer(self):
        if self.state is None:
            return
        ts, q, qd = self.state
        q_ref, qd_ref, _ = self.desired(ts)            # reference at the state's instant
        qdd_ff = self.desired(self.now())[2]           # feed-forward for the torque applied now
        e = q_ref - q
        e[self.wrap] = np.angle(np.exp(1j * e[self.wrap]))     # shortest way round
        ed, robot, mode = qd_ref - qd, self.robot, self.mode
        try:
            with np.errstate(over="ignore", invalid="ignore"):    # checked below
                kp, kd = self.pd_gains(robot, q) if mode == "pd_gravity" else (self.kp, self.kd)
                tau = control.torque(robot, mode, q, qd, e, ed, qdd_ff, kp, kd, self.compensate)
            if not np.all(np.isfinite(tau)):
                raise ValueError("the torque came out non-finite")
        except (ValueError, ArithmeticError) as exc:   # e.g. gains times error overflow
            return self.reject("effort_commands", Rejected("not finite", f"{exc} (mode "
                               f"{mode}, q = {q}, q_ref = {q_ref}, qd = {qd})"),
                               "; no command sent")
        self.pub.publish(Float64MultiArray(data=tau.tolist()))
        self.reject.put("effort_commands")
        self.error_max = max(self.error_max or 0.0, float(np.max(np.abs(e))))
        self.saturated.update(np.flatnonzero(np.abs(tau) > robot.effort_limit).tolist())

    def pd_gains(self, robot, q):
        """pd_gravity's gains at q: pd.kp, pd.kd as given, or kp, kd scaled by the effective
        inertias at q and the joints' coupling (control.pd_gains): every mode of the
        arm held at q is then no faster than e'' + kd e' + kp e = 0, within the bound
        whenever kp, kd are."""
        if self.pd_kp is not None and self.pd_kd is not None:
            return self.pd_kp, self.pd_kd
        kp, kd = control.pd_gains(robot, q, self.kp, self.kd)
        return (kp if self.pd_kp is None else self.pd_kp,
                kd if self.pd_kd is None else self.pd_kd)

    def check_bound(self):
        """Warn (once per joint) when pd_gravity's gains are beyond the explicit-PD stability
        bound at the control rate with the effective inertia at the latest state."""
        if self.state is None:
            return
        robot, q = self.robot, self.state[1]
        m = control.effective_inertia(robot, q)
        kp, kd = self.pd_gains(robot, q)
        self.beyond_pd = set(control.beyond(kp, kd, m, self.period).tolist())
        for j in sorted(self.beyond_pd):
            self.warn_bound(j, kp[j], kd[j], m[j], "pd.kp, pd.kd (pd_gravity)")

    def warn_bound(self, j, kp, kd, m, what):
        self.reject.once(("bound", what, j), control.explain(
            self.robot.joint_names[j], kp, kd, m, self.period, what))

    def validate_mode(self, params):
        for x in params:
            if x.name == "mode" and check_mode(x.value):
                reason = f"{check_mode(x.value)}; the mode in force ({self.mode}) stays"
                self.reject.once(("set mode",), f"rejected {reason}",
                                 "rejected {} more sets of mode since")
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def apply_mode(self, params):     # after validate_mode and rclpy have stored the value
        for x in params:
            if x.name == "mode" and x.value != self.mode:
                self.mode = x.value
                if self.mode == "gravity_compensation" and self.state is not None:
                    self.hold()             # and from now on at every state
                self.get_logger().info(f"mode {self.mode} in force")

    def diagnostics(self):
        """mode, max |e| and the joints beyond their effort limit since the last report."""
        err, names = self.error_max, [self.robot.joint_names[j] for j in sorted(self.saturated)]
        self.error_max, self.saturated = None, set()
        self.check_bound()
        beyond = [self.robot.joint_names[j] for j in sorted(self.beyond_ct | self.beyond_pd)]
        return [("mode", self.mode),
                ("gains beyond the stability bound", ", ".join(beyond) or "none", bool(beyond)),
                ("tracking error max (rad)", "no command" if err is None else f"{err:.6g}"),
                ("saturated joints", ", ".join(names) or "none", bool(names))]

    def close(self):
        pass


def main(args=None):
    return common.run(ComputedTorqueController, args)


if __name__ == "__main__":
    raise SystemExit(main())
