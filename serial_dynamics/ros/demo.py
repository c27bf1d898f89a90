"""The demo: the simulator and the computed-torque controller, started as separate
processes, track a built-in pick-and-place trajectory; prints the tracking error and the
real-time factor achieved.

    serial-dynamics demo [URDF] [--plot out.png] [--json out.json]
    python -m serial_dynamics.ros.demo [--attach]    # --attach: use nodes already running
                                                     # (launch/demo.launch.py does this)

The simulator publishes /clock and the controller runs on it (use_sim_time), so the
control loop stays at its rate in simulated time even when the simulation runs slower
than real time. The trajectory starts 0.5 s (simulated) after the simulation starts.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd
from serial_dynamics.precompile import precompile
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.trajectory import pick_and_place

from . import common
from .processes import NodeProcess

LEAD, SETTLE = 1.5, 0.5        # s of simulated time before the trajectory (discovery can take
                               # a second on a loaded machine; copies are resent until then) and after
RESEND = 0.05                  # s of wall time between sends of the trajectory before it starts
NOT_FOLLOWED = 0.1             # rad: a larger tracking error means the controller did not follow
STARTUP_TIMEOUT = 150.0        # s of wall time for the nodes to come up (a first run compiles)


class DemoError(RuntimeError):
    pass


def _duration(t):
    return Duration(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)))


def run_demo(urdf=None, base_link=None, tip_link=None, real_time_factor=1.0, attach=False,
             log=print):
    """Run the demo; returns a dict of results (raises DemoError when a node fails)."""
    robot = sd.load_urdf(urdf or sd.builtin_path(), base_link, tip_link)
    traj = pick_and_place(robot)
    robot_params = {"urdf_path": os.path.abspath(urdf) if urdf else "",
                    "base_link": base_link or "", "tip_link": tip_link or "",
                    "robot_description_timeout": 0.0}
    procs = []
    if not attach:
        # compile the kernels here, once, into the cache the nodes load from (two nodes
        # compiling the same kernels side by side on a cold cache take twice as long)
        t = time.monotonic()
        precompile(jobs=2)               # every kernel, on two cores; a warm cache only loads
        FixedStepIntegrator(robot).step(traj.q[0], np.zeros(robot.dof), np.zeros(robot.dof))
        if time.monotonic() - t > 2.0:
            log(f"compiled the numerical kernels in {time.monotonic() - t:.0f} s (first run only)")
        procs.append(NodeProcess("simulator", {**robot_params, "publish_clock": True,
                                               "start_paused": True,
                                               "initial_positions": traj.q[0].tolist(),
                                               "real_time_factor": float(real_time_factor)}))
        procs.append(NodeProcess("computed_torque_controller",
                                 {**robot_params, "use_sim_time": True}))
    rclpy.init(args=[])
    node = rclpy.create_node("demo")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    states = []        # (wall s, stamp s, q, effort)
    node.create_subscription(
        JointState, "joint_states",
        lambda m: states.append((time.monotonic(), common.stamp_seconds(m.header.stamp),
                                 np.array(m.position), np.array(m.effort))), common.QOS_DEPTH)
    efforts = []       # wall s of each effort command seen: the controller runs and has a state
    node.create_subscription(Float64MultiArray, "effort_commands",
                             lambda m: efforts.append(time.monotonic()), common.QOS_DEPTH)
    pub = node.create_publisher(JointTrajectory, "desired_trajectory", common.QOS_DEPTH)
    pause = node.create_client(SetBool, "simulator/pause")

    def spin_until(done, timeout, what):
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
            executor.spin_once(timeout_sec=0.05)

    try:
        t_wall = time.monotonic()
        spin_until(lambda: states and pub.get_subscription_count() > 0
                   and pause.service_is_ready(), STARTUP_TIMEOUT,
                   "the simulator and the controller to start")
        log(f"nodes up in {time.monotonic() - t_wall:.1f} s; running the pick-and-place "
            f"trajectory ({traj.duration:.1f} s)")
        future = pause.call_async(SetBool.Request(data=False))
        spin_until(future.done, 10.0, "the simulator to resume")
        spin_until(lambda: states[-1][1] > 0.0, 10.0, "simulated time to advance")
        # the controller refuses a trajectory before its first joint state; its effort
        # commands say it has one
        spin_until(lambda: efforts, 10.0, "the controller's first effort command")
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
        resend = node.create_timer(RESEND, lambda: pub.publish(msg))
        pub.publish(msg)
        spin_until(lambda: states[-1][1] >= t0, 10.0 + 5.0 * LEAD / real_time_factor,
                   "the trajectory to start")
        node.destroy_timer(resend)
        t_end = t0 + traj.duration + SETTLE
        spin_until(lambda: states[-1][1] >= t_end, 60.0 + 5.0 * t_end / real_time_factor,
                   "the end of the trajectory")
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        for p in procs:
            p.stop()

    run = [s for s in states if s[1] > 0.0]
    wall = np.array([s[0] for s in run])
    stamp = np.array([s[1] for s in run])
    q = np.array([s[2] for s in run])
    effort = np.array([s[3] for s in run])
    on = (stamp >= t0) & (stamp <= t_end)
    q_ref = traj.sample(stamp - t0)[0]
    err = q - q_ref
    rtf = (stamp[-1] - stamp[0]) / (wall[-1] - wall[0])
    worst = np.max(np.abs(err[on]), axis=0)
    followed = bool(worst.max() <= NOT_FOLLOWED)
    if not followed:
        j = int(np.argmax(worst))
        tail = procs[1].output().strip().splitlines()[-5:] if procs else []
        log(f"warning: the arm did not follow the trajectory ({worst[j]:.3f} rad off on "
            f"{robot.joint_names[j]}); the controller's log ends:"
            + "".join("\n  " + x for x in tail))
    return dict(robot=robot.model.name, joints=robot.joint_names, t0=t0,
                stamp=stamp.tolist(), q=q.tolist(), q_ref=q_ref.tolist(),
                rms=np.sqrt(np.mean(err[on] ** 2, axis=0)).tolist(),
                max=worst.tolist(),
                peak_effort=np.max(np.abs(effort[on]), axis=0).tolist(),
                effort_limit=robot.effort_limit.tolist(), samples=int(on.sum()),
                simulated=float(stamp[-1] - stamp[0]), wall=float(wall[-1] - wall[0]),
                real_time_factor=float(rtf), target_real_time_factor=real_time_factor,
                followed=followed)


def report(r) -> str:
    names = [j.removesuffix("_joint") for j in r["joints"]]
    w = max(12, *(len(x) + 2 for x in names))
    row = lambda label, vals, fmt: f"  {label:<24}" + "".join(f"{fmt(v):>{w}}" for v in vals)  # noqa: E731
    lines = [f"computed-torque tracking of the pick-and-place trajectory on {r['robot']} "
             f"({r['samples']} joint states from the trajectory's start to {SETTLE:g} s after "
             "its end; the hold before it is not counted):",
             row("joint", names, str),
             row("RMS error (mrad)", r["rms"], lambda v: f"{1e3 * v:.3f}"),
             row("max error (mrad)", r["max"], lambda v: f"{1e3 * v:.3f}"),
             row("peak effort (N m)", r["peak_effort"], lambda v: f"{v:.1f}"),
             row("effort limit (N m)", r["effort_limit"], lambda v: f"{v:.0f}"),
             f"real-time factor achieved: {r['real_time_factor']:.2f} (asked "
             f"{r['target_real_time_factor']:g}): {r['simulated']:.2f} s simulated in "
             f"{r['wall']:.2f} s of wall time at sim_dt = 1 ms"]
    return "\n".join(lines)


def plot(r, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = np.array(r["stamp"]) - r["t0"]
    q, q_ref = np.array(r["q"]), np.array(r["q_ref"])
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for j, name in enumerate(r["joints"]):
        line, = ax1.plot(t, q[:, j], label=name)
        ax1.plot(t, q_ref[:, j], "--", color=line.get_color(), linewidth=0.8)
        ax2.plot(t, 1e3 * (q[:, j] - q_ref[:, j]), color=line.get_color())
    ax1.set_ylabel("joint position (rad); dashed: desired")
    ax1.legend(fontsize=7, ncol=3)
    ax2.set_ylabel("tracking error (mrad)")
    ax2.set_xlabel("time from the trajectory start (s, simulated); the table's errors count "
                   "from 0 on")
    for ax in (ax1, ax2):
        ax.axvspan(t[0], 0.0, color="0.9", zorder=0)       # the hold before the start
    ax1.set_title(f"computed-torque control, {r['robot']}: real-time factor "
                  f"{r['real_time_factor']:.2f}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args) -> int:
    """Entry point of ``serial-dynamics demo`` (args: urdf, base_link, tip_link and
    optionally plot, json, real_time_factor, attach)."""
    rtf = getattr(args, "real_time_factor", 1.0)
    if not rtf > 0:
        print("serial-dynamics demo: error: the real-time factor must be > 0: the controller "
              "runs in its own process and cannot keep pace with an unpaced simulation",
              file=sys.stderr)
        return 2
    if "ROS_DOMAIN_ID" not in os.environ and not getattr(args, "attach", False):
        # keep the demo's /clock off other ROS graphs on this network
        os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
    print(f"serial_dynamics demo (ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}): simulator + "
          "computed-torque controller as separate processes", flush=True)
    try:
        r = run_demo(args.urdf, args.base_link, args.tip_link, rtf,
                     getattr(args, "attach", False), log=lambda s: print(s, flush=True))
    except (DemoError, ValueError, OSError) as exc:
        print(f"serial-dynamics demo: error: {exc}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, ExternalShutdownException):
        print("serial-dynamics demo: interrupted", file=sys.stderr)
        return 130
    print(report(r))
    if getattr(args, "plot", None):
        plot(r, args.plot)
        print(f"plot written to {args.plot}")
    if getattr(args, "json", None):
        with open(args.json, "w") as fh:
            json.dump({k: v for k, v in r.items() if k not in ("stamp", "q", "q_ref")}, fh,
                      indent=1)
    return 0 if r["followed"] else 1


def add_arguments(p):
    p.add_argument("urdf", nargs="?", default=None, help="URDF path (default: built-in UR5e)")
    p.add_argument("--base-link", default=None)
    p.add_argument("--tip-link", default=None)
    p.add_argument("--plot", metavar="PNG", default=None, help="write a plot of the tracking")
    p.add_argument("--json", metavar="PATH", default=None, help="write the numbers as JSON")
    p.add_argument("--real-time-factor", type=float, default=1.0,
                   help="simulated s per wall s (> 0; default 1)")
    p.add_argument("--attach", action="store_true",
                   help="do not start nodes: use the simulator and controller already running")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m serial_dynamics.ros.demo",
                                     description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
