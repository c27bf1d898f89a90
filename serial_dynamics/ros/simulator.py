"""Simulator node: integrates the forward dynamics at a fixed step and publishes
sensor_msgs/JointState.

    python -m serial_dynamics.ros.simulator --ros-args -p real_time_factor:=1.0
    ros2 run serial_dynamics simulator --ros-args --params-file config/simulator.yaml

A thread steps ``FixedStepIntegrator`` at ``sim_dt``, paced against the wall clock at
``real_time_factor`` (it catches up when late, and re-anchors when more than 0.1 s late:
it then runs slower than asked rather than bursting). Commands are held (zero-order) until
replaced or until ``command_timeout`` s of simulated time pass without one. A step above
COARSE_DT is allowed, with a warning (most likely 1 typed for 0.001).
"""
from __future__ import annotations

import sys
import threading
import time

import numpy as np
from rclpy.node import Node
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.methods import SimulationError

from . import common, parameters
from .common import Rejected
from .parameters import StartupError

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "initial_positions": ("double[]", None, "joint positions at start and after ~/reset "
                          "(rad; m), base to tip ([] = zeros)"),
    "dissipation.enabled": ("bool", True, "add the joint dissipation (friction) torques"),
    "position_limits": ("bool", True, "hard stops at the URDF joint limits (a joint that "
                        "reaches one stops there: plastic impact)"),
    "integrator": ("string", "semi_implicit_euler", "fixed-step method of "
                   "serial_dynamics.sim.fixed_step.FixedStepIntegrator"),
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
    **parameters.PAYLOAD_PARAMETERS,
}
MAX_LAG = 0.1   # s of wall time behind schedule before the pacing re-anchors
COARSE_DT = 0.01   # s; a larger sim_dt is warned about (an arm needs steps of about 1 ms)


class Simulator(Node):
    NAME = "simulator"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        p = parameters.declare(self, PARAMETERS)
        # payload.* may be set while running: a new plant, swapped in between two steps
        self.robot = robot = parameters.with_payload_parameters(self, parameters.load_robot(self, p), p,
                                                            self._set_plant)
        n = robot.dof
        self.q0 = parameters.per_joint("initial_positions", p["initial_positions"], robot, np.zeros(n))
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
        for name in ("real_time_factor", "command_timeout"):
            if not 0 <= p[name] < np.inf:
                raise StartupError(f"parameter {name!r} must be >= 0 (and finite), got {p[name]}")
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
        dt = self.integrator.dt
        self.publish_every = max(1, round(1.0 / (p["publish_rate"] * dt)))
        self.clock_every = max(1, round(1.0 / (p["clock_rate"] * dt)))
        self.timeout_steps = round(p["command_timeout"] / dt) if p["command_timeout"] > 0 else 0
        self.rtf, self.publish_clock = p["real_time_factor"], p["publish_clock"]
        robot.warmup()
        self.integrator.step(self.q0, np.zeros(n), np.zeros(n))   # compile the step too

        self.lock = threading.Lock()
        self.paused = p["start_paused"]
        self.k = 0                                   # steps since start (simulated time)
        self._reset_state()
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.state_pub = self.create_publisher(JointState, "joint_states", common.QOS_DEPTH)
        self.clock_pub = (self.create_publisher(Clock, "/clock", common.QOS_DEPTH)
                          if self.publish_clock else None)
        common.subscribe(self, self.reject, Float64MultiArray, "effort_commands", self.on_effort)
        common.subscribe(self, self.reject, JointState, "joint_commands", self.on_joint_command)
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(SetBool, "~/pause", self.on_pause)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="simulation", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------ commands and services
    def _reset_state(self):
        n = self.robot.dof
        self.q, self.qd = self.q0.copy(), np.zeros(n)
        self.tau, self.cmd_step, self.timed_out = np.zeros(n), self.k, True   # nothing to time out

    def _command(self, idx, effort):
        clamped = np.clip(effort, -self.limit[idx], self.limit[idx])
        if np.any(clamped != effort):
            j = idx[np.flatnonzero(clamped != effort)[0]]
            self.reject.once("clamped", f"effort command for {self.robot.joint_names[j]}: "
                             f"{effort[idx == j][0]:.4g}, beyond its limit {self.limit[j]:.4g}; "
                             "clamped to the limit (logged once)")
        with self.lock:
            tau = self.tau.copy()
            tau[idx] = clamped
            self.tau, self.cmd_step, self.timed_out = tau, self.k, False

    def on_effort(self, msg):
        try:
            effort = common.finite_vector(msg.data, self.robot.dof, "effort_commands data",
                                          "effort_commands", bound=None)   # clamped below
        except Rejected as exc:
            return self.reject("effort_commands", exc, "; the last good command stays in force")
        self._command(np.arange(self.robot.dof), effort)

    def on_joint_command(self, msg):
        try:
            msg_idx, idx = common.name_index(msg.name, self.robot, "joint_commands",
                                             require_all=False)
            effort = common.finite_vector(msg.effort, len(msg.name), "joint_commands effort",
                                          "joint_commands effort", bound=None)[msg_idx]
        except Rejected as exc:
            return self.reject("joint_commands", exc, "; the last good command stays in force")
        self._command(idx, effort)

    def on_reset(self, request, response):
        with self.lock:
            self._reset_state()
        response.success, response.message = True, "state reset to initial_positions, at rest"
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
        wall0, k0, lag_warned = time.monotonic(), self.k, False
        start_wall, start_k = wall0, self.k
        try:
            while not self._stop.is_set():
                if self.paused:
                    self._publish()
                    self._stop.wait(self.publish_every * self.integrator.dt)
                    wall0, k0 = time.monotonic(), self.k
                    continue
                if self.rtf > 0:
                    due = wall0 + (self.k - k0) * self.integrator.dt / self.rtf
                    now = time.monotonic()
                    if due > now:
                        time.sleep(min(due - now, 0.05))
                        continue
                    if now - due > MAX_LAG:
                        wall0, k0 = now, self.k
                        if not lag_warned:
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

    def _step(self):
        with self.lock:
            if self.paused:
                return
            integrator = self.integrator     # the plant of this step (swapped under the lock)
            if self.timeout_steps and not self.timed_out and self.k - self.cmd_step > self.timeout_steps:
                self.timed_out, self.tau = True, np.zeros(self.robot.dof)
                self.get_logger().warning(f"no command for {self.timeout_steps * integrator.dt}"
                                          " s (command_timeout): applied effort back to zero")
            try:
                q, qd = integrator.step(self.q, self.qd, self.tau, t=self.k * integrator.dt)
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
                    raise SimulationError("the state is no longer finite")
            except (SimulationError, ValueError) as exc:
                self.paused = True
                self.get_logger().error(f"{exc} -- paused at the last good state "
                                        f"(t = {self.k * integrator.dt:.3f} s); call ~/reset, then ~/pause false")
                return
            self.q, self.qd, self.k = q, qd, self.k + 1
        if self.clock_pub is not None and self.k % self.clock_every == 0:
            self.clock_pub.publish(Clock(clock=Time(nanoseconds=self.k * self.dt_ns).to_msg()))
        if self.k % self.publish_every == 0:
            self._publish()

    def _publish(self):
        with self.lock:
            q, qd, tau, k = self.q, self.qd, self.tau, self.k
        robot = self.robot               # every joint, mimic joints too (robot_state_publisher)
        effort = np.zeros(len(robot.all_joint_names))
        effort[robot.model.independent] = tau      # a mimic joint has no actuator: 0
        msg = JointState(name=robot.all_joint_names, position=robot.all_joint_positions(q).tolist(),
                         velocity=robot.all_joint_velocities(qd).tolist(), effort=effort.tolist())
        stamp = Time(nanoseconds=k * self.dt_ns) if self.publish_clock else self.get_clock().now()
        msg.header.stamp = stamp.to_msg()
        self.state_pub.publish(msg)
        self.reject.put("joint_states")

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)


def main(args=None):
    return common.run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
