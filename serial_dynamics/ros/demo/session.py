"""What both scenarios of the demo share (``demo``, ``demo_collision``): the nodes started
as processes, the demo's own node recording the joint states, the start of the
pick-and-place trajectory and a spin loop that notices a node that died or a simulation
that stopped; and the run of a scenario from the command line (``run_and_report``)."""
from __future__ import annotations

import os
import sys
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from serial_dynamics.precompile import precompile, ticking
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

from .. import common
from ..processes import NodeProcess

LEAD, SETTLE = 1.5, 0.5        # s of simulated time before the trajectory (discovery can take
                               # a second on a loaded machine; copies are resent until then) and after
RESEND = 0.05                  # s of wall time between sends of the trajectory before it starts
NOT_FOLLOWED = 0.1             # rad: a larger tracking error means the controller did not follow
STARTUP_TIMEOUT = 150.0        # s of wall time for the nodes to come up (a first run compiles)
LOCKSTEP = 5                   # steps the simulator may run past its latest joint state before
                               # the controller's answer to it (docs/ros.md, Lockstep): a starved
                               # controller holds the simulation back instead of falling behind


class DemoError(RuntimeError):
    pass


def run_and_report(run_scenario, report, plot, args):
    """The command line's run of a scenario: ``run_scenario()`` (its record), then its
    report printed and ``--plot`` written. Returns (record, None), or (None, exit status)
    after an error (1, the message on stderr) or an interrupt (130)."""
    try:
        r = run_scenario()
    except (DemoError, ValueError, OSError) as exc:
        print(f"serial-dynamics demo: error: {exc}", file=sys.stderr)
        return None, 1
    except (KeyboardInterrupt, ExternalShutdownException):
        print("serial-dynamics demo: interrupted", file=sys.stderr)
        return None, 130
    finally:
        if rclpy.ok():
            rclpy.try_shutdown()
    print(report(r))
    if getattr(args, "plot", None):
        plot(r, args.plot)
        print(f"plot written to {args.plot}")
    return r, None


def robot_parameters(urdf, base_link, tip_link):
    """The robot parameters of every node the demo starts."""
    return {"urdf_path": os.path.abspath(urdf) if urdf else "", "base_link": base_link or "",
            "tip_link": tip_link or "", "robot_description_timeout": 0.0}


def _duration(t):
    return Duration(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))


class Session:
    """The nodes (started here unless ``attach``), the demo's own node recording
    ``joint_states`` (wall s, stamp s, q, effort, qd) and seeing ``joint_commands``, the
    trajectory publisher, the simulator's pause client and ``spin_until``. ``nodes``:
    [(module, extra parameters)] started after the simulator and the controller."""

    def __init__(self, robot, traj, robot_params, real_time_factor=1.0, attach=False, log=print,
                 simulator_params=None, nodes=()):
        self.robot, self.traj, self.rtf, self.log, self.procs = robot, traj, real_time_factor, log, []
        if not attach:
            # compile the kernels the nodes run here, once, on two cores, into the cache the
            # nodes load from (two nodes compiling the same kernels side by side on a cold
            # cache take twice as long); a warm cache only loads
            t = time.monotonic()
            with ticking(log, "compiling the numerical kernels the nodes run (first run only)"):
                precompile(jobs=2, names=robot.kernels())
                FixedStepIntegrator(robot).step(traj.q[0], np.zeros(robot.dof), np.zeros(robot.dof))
            if time.monotonic() - t > 2.0:
                log(f"compiled the numerical kernels in {time.monotonic() - t:.0f} s (first run only)")
            self.procs.append(NodeProcess("simulator", {**robot_params, "publish_clock": True,
                                                        "start_paused": True,
                                                        "initial_positions": traj.q[0].tolist(),
                                                        "real_time_factor": float(real_time_factor),
                                                        "lockstep": LOCKSTEP,
                                                        **(simulator_params or {})}))
            self.procs.append(NodeProcess("computed_torque_controller",
                                          {**robot_params, "use_sim_time": True,
                                           "lockstep": True}))
            self.procs += [NodeProcess(m, {**robot_params, "use_sim_time": True, **extra})
                           for m, extra in nodes]
        rclpy.init(args=[])
        self.node = node = rclpy.create_node("demo")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(node)
        self.states = states = []        # (wall s, stamp s, q, effort, qd)
        node.create_subscription(
            JointState, "joint_states",
            lambda m: states.append((time.monotonic(), common.stamp_seconds(m.header.stamp),
                                     np.array(m.position), np.array(m.effort),
                                     np.array(m.velocity))), common.QOS_DEPTH)
        self.efforts = []   # wall s of each command seen: the controller runs and has a state
        node.create_subscription(JointState, "joint_commands",
                                 lambda m: self.efforts.append(time.monotonic()), common.QOS_DEPTH)
        self.pub = node.create_publisher(JointTrajectory, "desired_trajectory", common.QOS_DEPTH)
        self.pause = node.create_client(SetBool, "simulator/pause")

    def spin_until(self, done, timeout, what):
        states, procs = self.states, self.procs
        deadline = time.monotonic() + timeout
        progress = (states[-1][1] if states else 0.0, time.monotonic())   # (stamp, when)
        while not done():
            for p in procs:
                if not p.running():
                    raise DemoError(f"the {p.module} node exited ({p.proc.returncode}):\n"
                                    + p.output().strip())
            now = time.monotonic()
            if now > deadline:
                raise DemoError(f"timed out waiting for {what}")
            if states and states[-1][1] > progress[0]:
                progress = (states[-1][1], now)
            elif progress[0] > 0 and now - progress[1] > 10.0:      # running, then stuck
                log_tail = procs[0].output().strip().splitlines()[-3:] if procs else []
                raise DemoError(f"simulated time stopped at {states[-1][1]:.3f} s while waiting "
                                f"for {what}" + "".join("\n  " + x for x in log_tail))
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, client, request, what):
        self.spin_until(client.service_is_ready, 10.0, f"the service of {what}")
        future = client.call_async(request)
        self.spin_until(future.done, 10.0, what)
        return future.result()

    def start(self, ready=lambda: True):
        """Wait for the nodes (and ``ready()``), resume the simulation and send the
        trajectory; returns once it has started, with its start stamp t0."""
        states, traj, robot, rtf = self.states, self.traj, self.robot, self.rtf
        t_wall = time.monotonic()
        self.spin_until(lambda: states and self.pub.get_subscription_count() > 0
                        and self.pause.service_is_ready() and ready(), STARTUP_TIMEOUT,
                        "the simulator and the controller to start" if len(self.procs) <= 2
                        else "the nodes to start")
        self.log(f"nodes up in {time.monotonic() - t_wall:.1f} s; running the pick-and-place "
                 f"trajectory ({traj.duration:.1f} s)")
        # The controller (in lockstep) answers the paused simulator's state: its first
        # command holds the arm, and says that it has a state (it refuses a trajectory
        # before one). Resumed before that command, the arm would fall under zero effort
        # for as long as the controller took to start (under load, far enough that the
        # recovery saturated and went wild: two of the load check's failures).
        self.spin_until(lambda: self.efforts, 10.0, "the controller's first command on "
                        "joint_commands (a controller started with lockstep:=true)")
        self.call(self.pause, SetBool.Request(data=False), "the simulator to resume")
        self.spin_until(lambda: states[-1][1] > 0.0, 10.0, "simulated time to advance")
        t0 = states[-1][1] + LEAD
        msg = JointTrajectory(joint_names=robot.joint_names)
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t0), int(round((t0 % 1) * 1e9))
        msg.points = [JointTrajectoryPoint(positions=traj.q[i].tolist(),
                                           velocities=traj.qd[i].tolist(),
                                           accelerations=traj.qdd[i].tolist(),
                                           time_from_start=_duration(traj.t[i]))
                      for i in range(len(traj.t))]
        # A message sent once can be lost while the controller's side of discovery is
        # still matching our publisher; resend until the trajectory starts. The copies are
        # identical and start at the absolute stamp t0, so each replaces the last.
        resend = self.node.create_timer(RESEND, lambda: self.pub.publish(msg))
        self.pub.publish(msg)
        self.spin_until(lambda: states[-1][1] >= t0, 10.0 + 5.0 * LEAD / rtf,
                        "the trajectory to start")
        self.node.destroy_timer(resend)
        return t0

    def run_until(self, t_end, what):
        self.spin_until(lambda: self.states[-1][1] >= t_end, 60.0 + 5.0 * t_end / self.rtf, what)

    def close(self):
        self.node.destroy_node()
        rclpy.try_shutdown()
        for p in self.procs:
            p.stop()
