"""Simulator node: integrates the forward dynamics at a fixed step and publishes
sensor_msgs/JointState.

    python -m serial_dynamics.ros.simulator --ros-args -p real_time_factor:=1.0
    ros2 run serial_dynamics simulator --ros-args --params-file config/simulator.yaml

A thread steps ``FixedStepIntegrator`` at ``sim_dt``, paced against the wall clock at
``real_time_factor`` (it catches up when late, and re-anchors when more than 0.1 s late:
it then runs slower than asked rather than bursting). Commands are held (zero-order) until
replaced or until ``command_timeout`` s of simulated time pass without one. A step above
COARSE_DT is allowed, with a warning (most likely 1 typed for 0.001).

Inputs (checked in ``simulator_inputs``): efforts and servo targets on ``joint_commands``
(the joint PD of ``sim.servo``, integrated implicitly), a push on the tip
(``external_wrench``), a state to jump to (``~/set_state``), steps while paused
(``~/step``). /diagnostics adds the real-time factor achieved, late steps and divergence
events to the message counts.

``floating_base``: the chain's base floats free (``FloatingRobot``); the base pose goes out
on ``odom`` (nav_msgs/Odometry) beside ``joint_states`` and comes in on
``~/set_base_state`` (``floating_state``).
"""
from __future__ import annotations

import sys
import threading
import time

import numpy as np
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from serial_dynamics.sim.fixed_step import SERVO_METHODS
from serial_dynamics.sim.session import TIMEOUT_ACTIONS, Session

from . import common, floating_state, parameters, simulator_inputs
from .common import Rejected
from .pacing import Pacer
from .parameters import StartupError

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "initial_positions": ("double[]", None, "joint positions at start and after ~/reset "
                          "(rad; m), base to tip ([] = zeros)"),
    "dissipation.enabled": ("bool", True, "add the joint dissipation (friction) torques"),
    "position_limits": ("bool", True, "hard stops at the URDF joint limits (a joint that "
                        "reaches one stops there: plastic impact)"),
    "integrator": ("string", "semi_implicit_euler", "fixed-step method of "
                   "serial_dynamics.sim.fixed_step.FixedStepIntegrator: semi_implicit_euler, "
                   "symplectic_euler, rk4 or implicit_midpoint"),
    "sim_dt": ("double", 0.001, "integration step (s)"),
    "real_time_factor": ("double", 1.0, "simulated s per wall-clock s; 0 = as fast as possible"),
    "publish_rate": ("double", 100.0, "joint_states rate (Hz of simulated time)"),
    "publish_clock": ("bool", False, "publish /clock (simulated time, starting at 0) and "
                      "stamp joint_states with it, for nodes with use_sim_time"),
    "clock_rate": ("double", 1000.0, "/clock rate (Hz of simulated time) when publish_clock"),
    "command_timeout": ("double", 0.5, "s of simulated time without a command after which "
                        "command_timeout_action acts; 0 = hold the last command forever"),
    "command_timeout_action": ("string", "brake", "what a lost command stream does: brake "
                               "(the joint servo holds the positions at the timeout, within "
                               "the effort limits, until a command comes; as a real arm) or "
                               f"limp (effort back to zero): {', '.join(TIMEOUT_ACTIONS)}"),
    "clamp_effort": ("bool", True, "clamp commanded effort to the effort limits"),
    "effort_limits": ("double[]", None, "effort limits (N m; N), one or one per joint "
                      "([] = the URDF's <limit effort>; .inf = none)"),
    "start_paused": ("bool", False, "start paused (resume with ~/pause false)"),
    "step_count": ("int", 1, "steps advanced by one ~/step call (while paused)"),
    "external_wrench_timeout": ("double", 0.0, "s of simulated time after which an "
                                "external_wrench is dropped; 0 = held until replaced"),
    "servo.kp": ("double[]", [10000.0], "joint servo stiffness (N m/rad; N/m), one or one per "
                 "joint, for joint_commands with position targets"),
    "servo.kd": ("double[]", [200.0], "joint servo damping (N m s/rad; N s/m), one or one per "
                 "joint, for joint_commands with position and/or velocity targets"),
    **parameters.PAYLOAD_PARAMETERS,
    "floating_base": ("bool", False, "the chain's base link floats free (FloatingRobot): the "
                      "base pose on odom (nav_msgs/Odometry), ~/set_base_state; no joint "
                      "servo, no position_limits"),
    "initial_base_pose": ("double[]", floating_state.IDENTITY, "floating_base: the base pose "
                          "at start and after ~/reset, [x, y, z, qx, qy, qz, qw] in odom_frame "
                          "(the quaternion is normalized)"),
    "odom_frame": ("string", "odom", "floating_base: header.frame_id of odom (the world)"),
}
# parameter ranges (ParameterDescriptor; inclusive, so only those that include their ends)
RANGES = {"real_time_factor": (0.0, 1e6), "command_timeout": (0.0, 1e9),
          "external_wrench_timeout": (0.0, 1e9), "step_count": (1, 10 ** 9)}
MAX_LAG = 0.1   # s of wall time behind schedule before the pacing re-anchors
COARSE_DT = 0.01   # s; a larger sim_dt is warned about (an arm needs steps of about 1 ms)


class Simulator(Node):
    NAME = "simulator"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        p = parameters.declare(self, PARAMETERS, RANGES)
        # payload.* may be set while running: a new plant, swapped in between two steps
        robot = parameters.with_payload_parameters(
            self, parameters.load_robot(self, p), p, lambda r: self.session.set_robot(r))
        q0 = parameters.per_joint("initial_positions", p["initial_positions"], robot,
                                  np.zeros(robot.dof))
        check_initial_positions(robot, q0, p["initial_positions"])
        limit = parameters.per_joint("effort_limits", p["effort_limits"], robot,
                                     robot.effort_limit, positive=True)
        for name in ("sim_dt", "publish_rate", "clock_rate"):
            if not 0 < p[name] < np.inf:
                raise StartupError(f"parameter {name!r} must be > 0, got {p[name]}")
        kp, kd = (parameters.per_joint(f"servo.{x}", p[f"servo.{x}"], robot, None, positive=True)
                  for x in ("kp", "kd"))
        if not (np.all(np.isfinite(kp)) and np.all(np.isfinite(kd))):
            raise StartupError("parameters 'servo.kp' and 'servo.kd' must be finite")
        floating = robot.nq != robot.dof            # a base pose before the joints
        self.wrench_frame = ((p["odom_frame"], "world") if floating    # external_wrench:
                             else (robot.base_link, "base"))           # frame, axes
        self.frames = (p["odom_frame"], robot.base_link)   # odom's frame_id, child_frame_id
        if p["sim_dt"] > COARSE_DT:
            self.get_logger().warning(
                f"sim_dt = {p['sim_dt']} s is a coarse step (above {COARSE_DT} s): an arm "
                "needs about 0.001 s (the default) to be simulated faithfully; was "
                "sim_dt:=0.001 meant?")
        self.dt_ns = round(p["sim_dt"] * 1e9)
        try:
            pose = floating_state.initial_pose(p["initial_base_pose"]) if floating else None
            self.session = Session(
                robot, q0, base_pose=pose, integrator=p["integrator"], dt=self.dt_ns * 1e-9,
                dissipation=p["dissipation.enabled"],
                position_limits=p["position_limits"] and not floating,
                effort_limits=limit if p["clamp_effort"] else None, servo_kp=kp, servo_kd=kd,
                command_timeout=p["command_timeout"],
                command_timeout_action=p["command_timeout_action"],
                wrench_timeout=p["external_wrench_timeout"], paused=p["start_paused"])
        except ValueError as exc:
            raise StartupError(str(exc)) from None
        if floating and p["position_limits"]:
            self.get_logger().info("floating base: no hard stops at the joint limits "
                                   "(position_limits is not available on a floating base)")
        if self.session.timeout_action != p["command_timeout_action"]:
            self.get_logger().warning(
                "command_timeout_action 'brake' needs the joint servo (integrator "
                f"{' or '.join(SERVO_METHODS)}, a fixed base): the arm goes limp at the timeout")
        dt, self.step_count = self.session.dt, p["step_count"]
        self.publish_every = max(1, round(1.0 / (p["publish_rate"] * dt)))
        self.clock_every = max(1, round(1.0 / (p["clock_rate"] * dt)))
        self.rtf, self.publish_clock = p["real_time_factor"], p["publish_clock"]
        self.pacer = Pacer(dt, self.rtf, MAX_LAG)
        robot.warmup()
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self._diagnostics)
        self.state_pub = self.create_publisher(JointState, "joint_states", common.QOS_DEPTH)
        self.clock_pub = (self.create_publisher(Clock, "/clock", common.QOS_DEPTH)
                          if self.publish_clock else None)
        common.subscribe(self, self.reject, Float64MultiArray, "effort_commands", self.on_effort)
        common.subscribe(self, self.reject, JointState, "joint_commands", self.on_joint_command)
        common.subscribe(self, self.reject, WrenchStamped, "external_wrench", self.on_wrench)
        common.subscribe(self, self.reject, JointState, "~/set_state", self.on_set_state)
        self.odom_pub = None
        if floating:
            self.odom_pub = self.create_publisher(Odometry, "odom", common.QOS_DEPTH)
            common.subscribe(self, self.reject, Odometry, "~/set_base_state",
                             self.on_set_base_state)
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(SetBool, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/step", self.on_step)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="simulation", daemon=True)
        self._thread.start()

    robot = property(lambda self: self.session.robot)

    # ------------------------------------------------------------ commands and services
    def _command(self, idx, effort, position=None, velocity=None):
        clamped = self.session.command(idx, effort, position, velocity)
        if clamped is not None:
            j, asked = clamped
            self.reject.once("clamped", f"effort command for {self.robot.joint_names[j]}: "
                             f"{asked:.4g}, beyond its limit {self.session.limit[j]:.4g}; "
                             "clamped to the limit (logged once)")

    def on_effort(self, msg):
        try:
            effort = common.finite_vector(msg.data, self.robot.dof, "effort_commands data",
                                          "effort_commands", bound=None)   # clamped below
        except Rejected as exc:
            return self.reject("effort_commands", exc, "; the last good command stays in force")
        self._command(np.arange(self.robot.dof), effort)

    def on_joint_command(self, msg):
        try:
            idx, effort, position, velocity = simulator_inputs.joint_command(msg, self.robot)
            if not self.session.servo_ok and (position is not None or velocity is not None):
                raise Rejected("joint_commands servo", "joint_commands position/velocity "
                               f"targets need an integrator with the implicit servo "
                               f"{SERVO_METHODS}; this simulator runs another (parameter "
                               "integrator); send effort only" if self.odom_pub is None
                               else "joint_commands position/velocity targets: the joint "
                               "servo is not available on a floating base; send effort only")
        except Rejected as exc:
            return self.reject("joint_commands", exc, "; the last good command stays in force")
        self._command(idx, np.zeros(len(idx)) if effort is None else effort, position, velocity)

    def on_wrench(self, msg):
        try:
            self.session.push(simulator_inputs.external_wrench(msg, *self.wrench_frame))
        except Rejected as exc:
            return self.reject("external_wrench", exc, "; the wrench in force stays")

    def on_set_state(self, msg):
        try:
            self.session.set_state(*simulator_inputs.set_state(msg, self.robot))
        except Rejected as exc:
            return self.reject("set_state", exc, "; the state is left alone")

    def on_set_base_state(self, msg):
        try:
            self.session.set_base_state(*floating_state.base_state(msg, *self.frames))
        except Rejected as exc:
            return self.reject("set_base_state", exc, "; the state is left alone")

    def on_step(self, request, response):
        """While paused: ``step_count`` steps now (in this callback), then a joint_states."""
        if not self.session.paused:
            response.success = False
            response.message = ("not paused: ~/step advances a paused simulation "
                                "(~/pause true first)")
            return response
        k0 = self.session.k
        for _ in range(self.step_count):
            if not self._step(force=True):
                break
        self._publish()
        done = self.session.k - k0
        response.success = done == self.step_count
        response.message = (f"advanced {done} step(s) to t = {self.session.time:.6f} s"
                            + ("" if response.success
                               else "; stopped: the step diverged (see the log)"))
        return response

    def on_reset(self, request, response):
        self.session.reset()
        response.success, response.message = True, "state reset to initial_positions, at rest"
        if self.odom_pub is not None:
            response.message = "state reset to initial_base_pose and initial_positions, at rest"
        return response

    def on_pause(self, request, response):
        self.session.pause(request.data)
        response.success = True
        response.message = "paused" if request.data else "running"
        return response

    # ------------------------------------------------------------ simulation loop
    def _loop(self):
        session, pacer, lag_warned = self.session, self.pacer, False
        start_wall, start_k = time.monotonic(), session.k
        pacer.anchor(session.k)
        try:
            while not self._stop.is_set():
                if session.paused:
                    self._publish()
                    self._stop.wait(self.publish_every * session.dt)
                    pacer.anchor(session.k)
                    continue
                wait = pacer.wait(session.k)
                if wait > 0:
                    self._stop.wait(min(wait, 0.05))
                    continue
                if pacer.reanchors and not lag_warned:
                    lag_warned = True
                    self.get_logger().warning(
                        f"cannot keep up with real_time_factor {self.rtf}: the "
                        "simulation runs slower (logged once)")
                self._step()
        except Exception as exc:  # noqa: BLE001 -- a dead thread would hang silently
            if self.context.ok():
                self.get_logger().error(f"simulation stopped: {exc}")
        wall, simulated = time.monotonic() - start_wall, (session.k - start_k) * session.dt
        if wall > 0 and simulated > 0:
            text = (f"simulated {simulated:.3f} s in {wall:.3f} s of wall time (real-time "
                    f"factor {simulated / wall:.3f}, pauses included)")
            if self.context.ok():
                self.get_logger().info(text)
            else:   # shutting down: /rosout is gone
                print(f"[{self.NAME}] {text}", file=sys.stderr)

    def _step(self, force=False):
        """One step of the session, its notes logged, then /clock and joint_states when due."""
        ok, notes = self.session.step(force)
        for level, text in notes:
            getattr(self.get_logger(), level)(text)
        k = self.session.k
        if ok and self.clock_pub is not None and k % self.clock_every == 0:
            self.clock_pub.publish(Clock(clock=Time(nanoseconds=k * self.dt_ns).to_msg()))
        if ok and k % self.publish_every == 0:
            self._publish()
        return ok

    def _publish(self):
        k, q, qd, tau, pose, twist = self.session.snapshot()
        robot = self.robot               # every joint, mimic joints too (robot_state_publisher)
        effort = np.zeros(len(robot.all_joint_names))
        effort[robot.model.independent] = tau      # a mimic joint has no actuator: 0
        msg = JointState(name=robot.all_joint_names, position=robot.all_joint_positions(q).tolist(),
                         velocity=robot.all_joint_velocities(qd).tolist(), effort=effort.tolist())
        stamp = Time(nanoseconds=k * self.dt_ns) if self.publish_clock else self.get_clock().now()
        msg.header.stamp = stamp.to_msg()
        self.state_pub.publish(msg)
        self.reject.put("joint_states")
        if self.odom_pub is not None:        # the base, same state and stamp
            self.odom_pub.publish(floating_state.odometry(pose, twist, *self.frames,
                                                          msg.header.stamp))
            self.reject.put("odom")

    def _diagnostics(self):
        """The real-time factor achieved since the last report (simulated s per wall s; WARN
        below 90 % of real_time_factor while running), late steps (started more than one
        step period behind the schedule), divergence events (pauses after a failed step)."""
        session = self.session
        k, k0, hold = session.k, self.pacer.mark[1], session.hold   # (wall, k) of the last report
        rtf = self.pacer.achieved(k, session.dt)
        running = not session.paused and k > k0
        slow = running and self.rtf > 0 and rtf < 0.9 * self.rtf
        wrench, servo = hold.wrench, hold.servo
        return [("real-time factor", f"{rtf:.3f}" if running else "paused", slow),
                ("late steps", self.pacer.late_steps), ("divergence events", session.divergences),
                ("external wrench", "none" if wrench is None else
                 " ".join(f"{x:.4g}" for x in wrench)),
                ("servoed joints", 0 if servo is None else
                 int(np.count_nonzero((servo.kp > 0) | (servo.kd > 0))))]

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)


def check_initial_positions(robot, q0, given):
    """StartupError when a joint of ``q0`` is outside its limits, with positions that fit."""
    outside = np.flatnonzero((q0 < robot.lower) | (q0 > robot.upper))
    if outside.size:
        j, lo, hi = outside[0], robot.lower, robot.upper
        middle, bounded = np.clip(0.0, lo, hi), np.isfinite(lo) & np.isfinite(hi)
        middle[bounded] = (lo[bounded] + hi[bounded]) / 2
        example = ", ".join(f"{x:.4f}" for x in middle)
        raise StartupError(
            f"initial_positions{'' if given else ' (not set: zeros)'}: {robot.joint_names[j]} = "
            f"{q0[j]} is outside its limits [{lo[j]}, {hi[j]}]; give positions within the "
            f"limits, e.g. the middle of each range: -p initial_positions:=[{example}]")


def main(args=None):
    return common.run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
