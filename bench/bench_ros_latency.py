"""ROS latency: round trip of single-point inverse-dynamics requests at 1 kHz, and the
simulator's achieved real-time factor at sim_dt = 1 ms.

    python bench/bench_ros_latency.py [--seconds 10]

Both nodes run as separate processes (python -m serial_dynamics.ros.<node>), on a ROS
domain of their own, with the Fast DDS RMW of the PyPI wheels. The client is an rclpy
node too: a thread publishes the requests on a wall-clock schedule, the executor thread
takes the answers; the round trip is from just before publish to the answer's callback.
Writes the "ros_latency" section of bench/BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import sys
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
os.environ.setdefault("ROS_DOMAIN_ID", str(150 + os.getpid() % 60))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from std_srvs.srv import SetBool  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

import serial_dynamics as sd  # noqa: E402
from serial_dynamics.ros.processes import NodeProcess  # noqa: E402

from _report import stamp, write_section  # noqa: E402

NO_TOPIC = {"robot_description_timeout": 0.0}
HOME = [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]


def spin_until(executor, done, timeout, what):
    deadline = time.monotonic() + timeout
    while not done():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        executor.spin_once(timeout_sec=0.01)


def latency(node, executor, seconds, rate=1000.0):
    robot = sd.default_robot()
    sent, received = {}, {}
    pub = node.create_publisher(JointTrajectory, "inverse_dynamics/request", 10)
    node.create_subscription(JointTrajectory, "inverse_dynamics/response",
                             lambda m: received.setdefault(int(m.header.frame_id),
                                                           time.perf_counter()), 10)
    proc = NodeProcess("inverse_dynamics", NO_TOPIC)
    try:
        spin_until(executor, lambda: pub.get_subscription_count() > 0, 150, "the node")
        q, qd = robot.random_state(0)
        template = JointTrajectory(joint_names=robot.joint_names, points=[
            JointTrajectoryPoint(positions=q.tolist(), velocities=qd.tolist(),
                                 accelerations=[0.5] * robot.dof)])
        for i in range(200):                    # warm the path; not counted
            template.header.frame_id = str(-1 - i)
            pub.publish(template)
            executor.spin_once(timeout_sec=0.002)
        stop = threading.Event()

        def publisher():
            t0, k = time.perf_counter(), 0
            while k < seconds * rate:
                due = t0 + k / rate
                while (now := time.perf_counter()) < due:
                    time.sleep(min(due - now, 0.0005))
                template.header.frame_id = str(k)
                sent[k] = time.perf_counter()
                pub.publish(template)
                k += 1
            stop.set()

        thread = threading.Thread(target=publisher)
        t_start = time.perf_counter()
        thread.start()
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.01)
        t_sent = time.perf_counter() - t_start
        deadline = time.monotonic() + 2.0       # late answers
        while time.monotonic() < deadline and len([k for k in received if k >= 0]) < len(sent):
            executor.spin_once(timeout_sec=0.01)
        thread.join()
    finally:
        proc.stop()
    rtt = np.array([received[k] - sent[k] for k in sent if k in received]) * 1e3
    return dict(sent=len(sent), lost=len(sent) - len(rtt), rate=len(sent) / t_sent,
                p50=np.percentile(rtt, 50), p99=np.percentile(rtt, 99), max=rtt.max(),
                mean=rtt.mean())


def sim_rtf(node, executor, seconds, rtf):
    """Achieved real-time factor of the simulator holding the UR5e still at HOME (gravity
    torques commanded once, held: command_timeout 0), so that nothing diverges."""
    robot = sd.default_robot()
    stamps, efforts = [], []
    ns = f"/bench_rtf{str(rtf).replace('.', '_')}"

    def on_state(m):
        stamps.append((time.monotonic(), m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec))
        efforts.append(list(m.effort))
    node.create_subscription(JointState, f"{ns}/joint_states", on_state, 100)
    pub = node.create_publisher(Float64MultiArray, f"{ns}/effort_commands", 10)
    pause = node.create_client(SetBool, f"{ns}/simulator/pause")
    g = robot.gravity_torques(HOME).tolist()
    proc = NodeProcess("simulator", {**NO_TOPIC, "publish_clock": True, "real_time_factor": rtf,
                                     "initial_positions": HOME, "command_timeout": 0.0,
                                     "start_paused": True}, ros_args=["-r", f"__ns:={ns}"])
    try:
        spin_until(executor, lambda: efforts and pub.get_subscription_count() > 0
                   and pause.service_is_ready(), 150, "the simulator")
        # resent until applied: the first message can be lost while discovery completes
        spin_until(executor, lambda: pub.publish(Float64MultiArray(data=g)) or efforts[-1] == g,
                   10, "the command")
        future = pause.call_async(SetBool.Request(data=False))
        spin_until(executor, future.done, 10, "the simulator to resume")
        spin_until(executor, lambda: stamps[-1][1] > 0, 10, "simulated time")
        stamps.clear()
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            executor.spin_once(timeout_sec=0.01)
    finally:
        proc.stop()
    (w0, s0), (w1, s1) = stamps[0], stamps[-1]
    return (s1 - s0) / (w1 - w0), s1 - s0, w1 - w0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args(argv)
    rclpy.init()
    node = rclpy.create_node("bench_ros_latency")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        lat = latency(node, executor, args.seconds)
        print("inverse dynamics round trip:", {k: round(float(v), 3) for k, v in lat.items()})
        rt = sim_rtf(node, executor, args.seconds, 1.0)
        fast = sim_rtf(node, executor, args.seconds, 0.0)
        print("simulator real-time factor (asked 1.0, asked 0 = as fast as possible):", rt, fast)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    body = f"""## ROS 2 nodes: latency and real-time factor

{stamp()}
`python bench/bench_ros_latency.py` (ROS 2 Jazzy rclpy and Fast DDS from the PyPI wheels; each
node a separate process on one machine; the client is an rclpy node as well, so its own
Python overhead is in the round trip).

**Inverse dynamics over topics**: single-point `trajectory_msgs/JointTrajectory` requests
(UR5e, 6 joints) on `inverse_dynamics/request` at 1 kHz for {args.seconds:g} s, answered on
`inverse_dynamics/response`; round trip from just before `publish` to the answer's callback.

| requests sent | achieved send rate | p50 | p99 | max | mean | lost |
| ---: | ---: | ---: | ---: | ---: | ---: | ---: |
| {lat['sent']} | {lat['rate']:.0f} Hz | {lat['p50']:.3f} ms | {lat['p99']:.3f} ms | {lat['max']:.3f} ms | {lat['mean']:.3f} ms | {lat['lost']} |

**Simulator** (UR5e, `sim_dt` = 1 ms, semi-implicit Euler, joint_states at 100 Hz and /clock
at 1 kHz): real-time factor achieved over {args.seconds:g} s of wall time, from the simulated
stamps of joint_states against their wall-clock arrival. The joint stops (`position_limits`,
on by default) cost about 3.5 µs a step: as fast as possible, 44.6 without them in an
earlier run of this script on 2026-11-21.

| real_time_factor asked | achieved | simulated s | wall s |
| ---: | ---: | ---: | ---: |
| 1.0 | {rt[0]:.3f} | {rt[1]:.2f} | {rt[2]:.2f} |
| 0 (as fast as possible) | {fast[0]:.2f} | {fast[1]:.2f} | {fast[2]:.2f} |
"""
    write_section("ros_latency", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
