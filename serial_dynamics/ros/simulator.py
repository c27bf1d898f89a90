"""Simulator node: integrates the forward dynamics at a fixed step and publishes
sensor_msgs/JointState.

    python -m serial_dynamics.ros.simulator --ros-args -p real_time_factor:=1.0
    ros2 run serial_dynamics simulator --ros-args --params-file config/simulator.yaml

A thread steps the simulation (``sim.session.Session``: ``FixedStepIntegrator`` at
``sim_dt``, the commands held until replaced or timed out, the edits, pause, divergence),
paced against the wall clock at ``real_time_factor`` (``loops/simulator.SimulatorLoop``:
catching up when late, re-anchoring when more than 0.1 s late). This module converts
parameters and messages and makes one call there per callback.

Inputs (checked in ``simulator_inputs``): efforts and servo targets on ``joint_commands``
(the joint PD of ``sim.servo``, integrated implicitly), a push on the tip
(``external_wrench``), a state to jump to (``~/set_state``), steps while paused
(``~/step``). ``floating_base``: the base pose goes out on ``odom`` (nav_msgs/Odometry)
beside ``joint_states`` and comes in on ``~/set_base_state`` (``floating_state``).
``contacts`` on the ``ground.*`` plane: the steps are ``contacts.stepper``'s and each
contact's force goes out on ``~/contacts/<name>`` (geometry_msgs/WrenchStamped) with
``joint_states``.
"""
from __future__ import annotations

import sys
import threading

from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.time import Time
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger

from ..loops.simulator import SimulatorLoop
from . import common, floating_state, parameters, simulator_inputs, simulator_parameters
from .common import Rejected
from .parameters import StartupError
from .simulator_parameters import PARAMETERS, RANGES
from ..loops.progress import Heartbeat


class Simulator(Node):
    NAME = "simulator"

    def __init__(self, **kwargs):
        super().__init__(self.NAME, **kwargs)
        p = parameters.declare(self, PARAMETERS, RANGES)
        # payload.* may be set while running: a new plant, swapped in between two steps
        robot = parameters.with_payload_parameters(
            self, parameters.load_robot(self, p), p, lambda r: self.session.set_robot(r))
        try:
            session, notes = simulator_parameters.session(robot, p)
        except ValueError as exc:
            raise StartupError(str(exc)) from None
        self.loop = SimulatorLoop(session, p)
        for level, text in notes:
            common.log(self.get_logger(), level, text)
        with Heartbeat(self.get_logger().info, "compiling the dynamics kernels"):
            robot.warmup()
        self.reject = common.Rejections(self, hardware_id=robot.model.name)
        self.reject.watch(self.loop.report)
        self.state_pub = self.create_publisher(JointState, "joint_states", common.QOS_DEPTH)
        self.clock_pub = (self.create_publisher(Clock, "/clock", common.QOS_DEPTH)
                          if self.loop.publish_clock else None)
        common.subscribe(self, self.reject, Float64MultiArray, "effort_commands", self.on_effort)
        common.subscribe(self, self.reject, JointState, "joint_commands", self.on_joint_command)
        common.subscribe(self, self.reject, WrenchStamped, "external_wrench", self.on_wrench)
        common.subscribe(self, self.reject, JointState, "~/set_state", self.on_set_state)
        self.odom_pub = None
        if self.session.has_base:
            self.odom_pub = self.create_publisher(Odometry, "odom", common.QOS_DEPTH)
            common.subscribe(self, self.reject, Odometry, "~/set_base_state",
                             self.on_set_base_state)
        self.contact_pubs = [self.create_publisher(WrenchStamped, f"~/contacts/{name}",
                                                   common.QOS_DEPTH)
                             for name in self.loop.contact_names]
        self.create_service(Trigger, "~/reset", self.on_reset)
        self.create_service(SetBool, "~/pause", self.on_pause)
        self.create_service(Trigger, "~/step", self.on_step)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="simulation", daemon=True)
        self._thread.start()

    session = property(lambda self: self.loop.session)
    robot = property(lambda self: self.loop.session.robot)

    # ------------------------------------------------------------ commands and services
    def on_effort(self, msg):
        try:
            effort = common.finite_vector(msg.data, self.robot.dof, "effort_commands data",
                                          "effort_commands", bound=None)   # clamped below
            clamped = self.loop.command(None, effort)
        except Rejected as exc:
            return self.reject("effort_commands", exc, "; the last good command stays in force")
        if clamped:
            self.reject.once("clamped", clamped)

    def on_joint_command(self, msg):
        try:
            clamped = self.loop.command(*simulator_inputs.joint_command(msg, self.robot),
                                        stamp_ns=Time.from_msg(msg.header.stamp).nanoseconds)
        except Rejected as exc:
            return self.reject("joint_commands", exc, "; the last good command stays in force")
        if clamped:
            self.reject.once("clamped", clamped)

    def on_wrench(self, msg):
        try:
            self.session.push(simulator_inputs.external_wrench(msg, *self.loop.wrench_frame))
        except Rejected as exc:
            return self.reject("external_wrench", exc, "; the wrench in force stays")

    def on_set_state(self, msg):
        try:
            self.session.set_state(*simulator_inputs.set_state(msg, self.robot))
        except Rejected as exc:
            return self.reject("set_state", exc, "; the state is left alone")

    def on_set_base_state(self, msg):
        try:
            self.session.set_base_state(*floating_state.base_state(msg, *self.loop.frames))
        except Rejected as exc:
            return self.reject("set_base_state", exc, "; the state is left alone")

    def on_step(self, request, response):
        """While paused: ``step_count`` steps now (in this callback), then a joint_states."""
        response.success, response.message = self.loop.single_steps(self._step, self._publish,
                                                                    self._failed)
        return response

    def on_reset(self, request, response):
        response.success, response.message = True, self.loop.reset()
        return response

    def on_pause(self, request, response):
        self.session.pause(request.data)
        response.success, response.message = True, "paused" if request.data else "running"
        return response

    # ------------------------------------------------------------ simulation thread
    def _run(self):
        try:    # a failed step only pauses the simulation (loop.guarded)
            self.loop.run(self._stop, self._step, self._publish, self.get_logger().warning,
                          self._failed)
        except Exception as exc:  # noqa: BLE001 -- a dead thread would hang silently
            if self.context.ok():
                self.get_logger().error(f"simulation stopped: {exc}")
        text = self.loop.summary()
        if text and self.context.ok():
            self.get_logger().info(text)
        elif text:   # shutting down: /rosout is gone
            print(f"[{self.NAME}] {text}", file=sys.stderr)

    def _step(self, force=False):
        """One step, its notes logged, then /clock and joint_states when due."""
        tick = self.loop.step(force)
        for level, text in tick.notes:
            common.log(self.get_logger(), level, text)
        if tick.clock_ns is not None:
            self.clock_pub.publish(Clock(clock=Time(nanoseconds=tick.clock_ns).to_msg()))
        if tick.publish:
            self._publish()
        return tick.ok

    def _failed(self, text):
        """Why a step failed (the simulation paused at the last good state)."""
        if self.context.ok():      # shutting down: /rosout is gone
            self.get_logger().error(text)

    def _publish(self):
        k, position, velocity, effort, base = self.session.joint_state()
        msg = JointState(name=self.session.joint_names, position=position.tolist(),
                         velocity=velocity.tolist(), effort=effort.tolist())
        ns = self.loop.clock_ns(k)     # simulated time with publish_clock, else now
        msg.header.stamp = (self.get_clock().now() if ns is None else Time(nanoseconds=ns)).to_msg()
        self.state_pub.publish(msg)
        self.reject.put("joint_states")
        if base is not None:        # a floating base: same state and stamp
            self.odom_pub.publish(floating_state.odometry(*base, *self.loop.frames,
                                                          msg.header.stamp))
            self.reject.put("odom")
        if self.contact_pubs:       # each contact's force on the robot, world axes, same stamp
            for pub, f in zip(self.contact_pubs, self.loop.contact_forces()):
                out = WrenchStamped()
                out.header.stamp, out.header.frame_id = msg.header.stamp, self.loop.contact_frame
                out.wrench.force.x, out.wrench.force.y, out.wrench.force.z = f.tolist()
                pub.publish(out)
            self.reject.put("contacts")

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)


def main(args=None):
    return common.run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
