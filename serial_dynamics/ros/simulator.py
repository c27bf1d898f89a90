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

from serial_dynamics.sim.fixed_step import SERVO_METHODS, FixedStepIntegrator
from serial_dynamics.model.errors import SimulationError

from . import common, floating_state, parameters, simulator_inputs
from .command_hold import CommandHold
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
    "command_timeout": ("double", 0.5, "s of simulated time without a command after which the "
                        "applied effort returns to zero; 0 = hold forever"),
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
        self.robot = robot = parameters.with_payload_parameters(self, parameters.load_robot(self, p), p,
                                                            self._set_plant)
        n = robot.dof
        self.q0 = parameters.per_joint("initial_positions", p["initial_positions"], robot, np.zeros(n))
        self.jq, self.jv = (7, 6) if robot.is_floating else (0, 0)   # joints' start in q, qd
        outside = np.flatnonzero((self.q0 < robot.lower) | (self.q0 > robot.upper))
        if outside.size:
            j, lo, hi = outside[0], robot.lower, robot.upper
            middle, bounded = np.clip(0.0, lo, hi), np.isfinite(lo) & np.isfinite(hi)
            middle[bounded] = (lo[bounded] + hi[bounded]) / 2
            given = "" if p["initial_positions"] else " (not set: zeros)"
            example = ", ".join(f"{x:.4f}" for x in middle)
            raise StartupError(
                f"initial_positions{given}: {robot.joint_names[j]} = {self.q0[j]} is outside "
                f"its limits [{lo[j]}, {hi[j]}]; give positions within the limits, e.g. the "
                f"middle of each range: -p initial_positions:=[{example}]")
        self.limit = parameters.per_joint("effort_limits", p["effort_limits"], robot,
                                      robot.effort_limit, positive=True)
        if not p["clamp_effort"]:
            self.limit = np.full(n, np.inf)
        for name in ("sim_dt", "publish_rate", "clock_rate"):
            if not 0 < p[name] < np.inf:
                raise StartupError(f"parameter {name!r} must be > 0, got {p[name]}")
        self.kp, self.kd = (parameters.per_joint(f"servo.{x}", p[f"servo.{x}"], robot, None,
                                                 positive=True) for x in ("kp", "kd"))
        if not (np.all(np.isfinite(self.kp)) and np.all(np.isfinite(self.kd))):
            raise StartupError("parameters 'servo.kp' and 'servo.kd' must be finite")
        self.servo_ok = p["integrator"] in SERVO_METHODS and not robot.is_floating
        self.wrench_frame = (robot.base_link, "base")   # external_wrench: frame, axes
        if robot.is_floating:
            try:
                self.q0 = np.concatenate((floating_state.initial_pose(p["initial_base_pose"]),
                                          self.q0))
            except ValueError as exc:
                raise StartupError(str(exc)) from None
            stops_dropped, p["position_limits"] = p["position_limits"], False
            self.frames = (p["odom_frame"], robot.base_link)   # odom's frame_id, child_frame_id
            self.wrench_frame = (p["odom_frame"], "world")     # a floating robot's convention
        self.step_count = p["step_count"]
        if p["sim_dt"] > COARSE_DT:
            self.get_logger().warning(
                f"sim_dt = {p['sim_dt']} s is a coarse step (above {COARSE_DT} s): an arm "
                "needs about 0.001 s (the default) to be simulated faithfully; was "
                "sim_dt:=0.001 meant?")
        self.dt_ns = round(p["sim_dt"] * 1e9)
        self._integrator_for = lambda robot: FixedStepIntegrator(
            robot, p["integrator"], self.dt_ns * 1e-9, p["dissipation.enabled"],
            position_limits=p["position_limits"])
        try:
            self.integrator = self._integrator_for(robot)
        except ValueError as exc:
            raise StartupError(str(exc)) from None
        if robot.is_floating and stops_dropped:
            self.get_logger().info("floating base: no hard stops at the joint limits "
                                   "(position_limits is not available on a floating base)")
        dt = self.integrator.dt
        self.publish_every = max(1, round(1.0 / (p["publish_rate"] * dt)))
        self.clock_every = max(1, round(1.0 / (p["clock_rate"] * dt)))
        self.hold = CommandHold(n, self.kp, self.kd, round(p["command_timeout"] / dt),
                                round(p["external_wrench_timeout"] / dt))
        self.rtf, self.publish_clock = p["real_time_factor"], p["publish_clock"]
        self.pacer = Pacer(dt, self.rtf, MAX_LAG)
        robot.warmup()
        self.integrator.step(self.q0, np.zeros(n + self.jv), np.zeros(n))   # compile the step too

        self.lock = threading.Lock()
        self.paused = p["start_paused"]
        self.k = 0                                   # steps since start (simulated time)
        self.pending = None                          # ~/set_state: (idx, q or None, qd)
        self.pending_base = None                     # ~/set_base_state: (pose, twist)
        self.divergences = 0
        self._reset_state()
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
        if robot.is_floating:
            self.odom_pub = self.create_publisher(Odometry, "odom", common.QOS_DEPTH)
            common.subscribe(self, self.reject, Odometry, "~/set_base_state",
                             self.on_set_base_state)
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(SetBool, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/step", self.on_step)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="simulation", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------ commands and services
    def _reset_state(self):
        self.q, self.qd = self.q0.copy(), np.zeros(self.robot.dof + self.jv)
        self.hold.clear(self.k)
        self.pending = self.pending_base = None

    def _command(self, idx, effort, position=None, velocity=None):
        """The command of the joints ``idx``: effort (clamped), and servo targets (None:
        the joints named have none, NaN entries: none at that joint)."""
        clamped = np.clip(effort, -self.limit[idx], self.limit[idx])
        if np.any(clamped != effort):
            j = idx[np.flatnonzero(clamped != effort)[0]]
            self.reject.once("clamped", f"effort command for {self.robot.joint_names[j]}: "
                             f"{effort[idx == j][0]:.4g}, beyond its limit {self.limit[j]:.4g}; "
                             "clamped to the limit (logged once)")
        with self.lock:
            self.hold.command(self.k, idx, clamped, position, velocity)

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
            if not self.servo_ok and (position is not None or velocity is not None):
                raise Rejected("joint_commands servo", "joint_commands position/velocity "
                               f"targets need an integrator with the implicit servo "
                               f"{SERVO_METHODS}; this simulator runs another (parameter "
                               "integrator); send effort only" if not self.robot.is_floating
                               else "joint_commands position/velocity targets: the joint "
                               "servo is not available on a floating base; send effort only")
        except Rejected as exc:
            return self.reject("joint_commands", exc, "; the last good command stays in force")
        self._command(idx, np.zeros(len(idx)) if effort is None else effort, position, velocity)

    def on_wrench(self, msg):
        try:
            w = simulator_inputs.external_wrench(msg, *self.wrench_frame)
        except Rejected as exc:
            return self.reject("external_wrench", exc, "; the wrench in force stays")
        with self.lock:
            self.hold.push(self.k, w)

    def on_set_state(self, msg):
        try:
            pending = simulator_inputs.set_state(msg, self.robot)
        except Rejected as exc:
            return self.reject("set_state", exc, "; the state is left alone")
        with self.lock:
            self.pending = pending

    def on_set_base_state(self, msg):
        try:
            pending = floating_state.base_state(msg, *self.frames)
        except Rejected as exc:
            return self.reject("set_base_state", exc, "; the state is left alone")
        with self.lock:
            self.pending_base = pending

    def on_step(self, request, response):
        """While paused: ``step_count`` steps now (in this callback), then a joint_states."""
        if not self.paused:
            response.success = False
            response.message = ("not paused: ~/step advances a paused simulation "
                                "(~/pause true first)")
            return response
        k0 = self.k
        for _ in range(self.step_count):
            if not self._step(force=True):
                break
        self._publish()
        done = self.k - k0
        response.success = done == self.step_count
        response.message = (f"advanced {done} step(s) to t = {self.k * self.integrator.dt:.6f} s"
                            + ("" if response.success
                               else "; stopped: the step diverged (see the log)"))
        return response

    def on_reset(self, request, response):
        with self.lock:
            self._reset_state()
        response.success, response.message = True, "state reset to initial_positions, at rest"
        if self.robot.is_floating:
            response.message = "state reset to initial_base_pose and initial_positions, at rest"
        return response

    def _set_plant(self, robot):
        """A new payload (the parameter callback): the integrator of the new model is built
        here, outside the step lock (it compiles nothing, ~0.1 ms), then swapped in by one
        assignment under the lock that every step holds -- so the swap falls between two
        steps, and the step loop takes no extra lock."""
        integrator = self._integrator_for(robot)
        with self.lock:
            self.robot, self.integrator = robot, integrator

    def on_pause(self, request, response):
        with self.lock:
            self.paused = request.data
        response.success = True
        response.message = "paused" if request.data else "running"
        return response

    # ------------------------------------------------------------ simulation loop
    def _loop(self):
        start_wall, start_k, pacer, lag_warned = time.monotonic(), self.k, self.pacer, False
        pacer.anchor(self.k)
        try:
            while not self._stop.is_set():
                if self.paused:
                    self._publish()
                    self._stop.wait(self.publish_every * self.integrator.dt)
                    pacer.anchor(self.k)
                    continue
                wait = pacer.wait(self.k)
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
        wall, simulated = time.monotonic() - start_wall, (self.k - start_k) * self.integrator.dt
        if wall > 0 and simulated > 0:
            text = (f"simulated {simulated:.3f} s in {wall:.3f} s of wall time (real-time "
                    f"factor {simulated / wall:.3f}, pauses included)")
            if self.context.ok():
                self.get_logger().info(text)
            else:   # shutting down: /rosout is gone
                print(f"[{self.NAME}] {text}", file=sys.stderr)

    def _step(self, force=False):
        """One step (``force``: also while paused, for ~/step); False if it diverged."""
        with self.lock:
            if self.paused and not force:
                return True
            integrator, hold = self.integrator, self.hold   # the plant of this step (swapped
            events = hold.expire(self.k)                      # under the lock)
            if "command" in events:
                self.get_logger().warning(f"no command for {hold.timeout_steps * integrator.dt}"
                                          " s (command_timeout): applied effort back to zero, "
                                          "servo targets cleared")
            if "wrench" in events:
                self.get_logger().info("external_wrench_timeout: the external wrench is dropped")
            if self.pending is not None:      # ~/set_state, applied at this step
                idx, q_set, qd_set = self.pending
                self.q, self.qd, self.pending = self.q.copy(), self.qd.copy(), None
                if q_set is not None:
                    self.q[self.jq + idx] = q_set
                self.qd[self.jv + idx] = qd_set
            if self.pending_base is not None:   # ~/set_base_state, applied at this step
                (pose, twist), self.pending_base = self.pending_base, None
                self.q, self.qd = self.q.copy(), self.qd.copy()
                self.q[:7], self.qd[:6] = pose, twist
            try:
                q, qd = integrator.step(self.q, self.qd, hold.tau, hold.wrench,
                                        t=self.k * integrator.dt, servo=hold.servo)
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
                    raise SimulationError("the state is no longer finite")
            except (SimulationError, ValueError) as exc:
                self.paused = True
                self.divergences += 1
                self.get_logger().error(f"{exc} -- paused at the last good state "
                                        f"(t = {self.k * integrator.dt:.3f} s); call ~/reset, then ~/pause false")
                return False
            if hold.servo is not None:
                hold.tau_servo = integrator.servo_torque
            self.q, self.qd, self.k = q, qd, self.k + 1
        if self.clock_pub is not None and self.k % self.clock_every == 0:
            self.clock_pub.publish(Clock(clock=Time(nanoseconds=self.k * self.dt_ns).to_msg()))
        if self.k % self.publish_every == 0:
            self._publish()
        return True

    def _publish(self):
        with self.lock:
            q, qd, tau, k = self.q, self.qd, self.hold.tau + self.hold.tau_servo, self.k
        robot = self.robot               # every joint, mimic joints too (robot_state_publisher)
        effort = np.zeros(len(robot.all_joint_names))
        effort[robot.model.independent] = tau      # a mimic joint has no actuator: 0
        qj, qdj = q[self.jq:], qd[self.jv:]   # the joints (a floating base: after the base)
        msg = JointState(name=robot.all_joint_names, position=robot.all_joint_positions(qj).tolist(),
                         velocity=robot.all_joint_velocities(qdj).tolist(), effort=effort.tolist())
        stamp = Time(nanoseconds=k * self.dt_ns) if self.publish_clock else self.get_clock().now()
        msg.header.stamp = stamp.to_msg()
        self.state_pub.publish(msg)
        self.reject.put("joint_states")
        if self.odom_pub is not None:        # the base, same state and stamp
            self.odom_pub.publish(floating_state.odometry(q, qd, *self.frames, msg.header.stamp))
            self.reject.put("odom")

    def _diagnostics(self):
        """The real-time factor achieved since the last report (simulated s per wall s; WARN
        below 90 % of real_time_factor while running), late steps (started more than one
        step period behind the schedule), divergence events (pauses after a failed step)."""
        k, k0, hold = self.k, self.pacer.mark[1], self.hold   # (wall, k) of the last report
        rtf = self.pacer.achieved(k, self.integrator.dt)
        running = not self.paused and k > k0
        slow = running and self.rtf > 0 and rtf < 0.9 * self.rtf
        wrench, servo = hold.wrench, hold.servo
        return [("real-time factor", f"{rtf:.3f}" if running else "paused", slow),
                ("late steps", self.pacer.late_steps), ("divergence events", self.divergences),
                ("external wrench", "none" if wrench is None else
                 " ".join(f"{x:.4g}" for x in wrench)),
                ("servoed joints", 0 if servo is None else
                 int(np.count_nonzero((servo.kp > 0) | (servo.kd > 0))))]

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)


def main(args=None):
    return common.run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
