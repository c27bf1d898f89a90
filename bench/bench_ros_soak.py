"""ROS soak at 1 kHz (issue 26 item 2): the simulator (1 ms steps, joint_states at 1 kHz),
the computed-torque controller (1 kHz), the external-torque observer and the dynamics node,
each its own process, with a client (this process) sending single-point
``inverse_dynamics/request`` messages at 1 kHz (queues of 100) for ``--seconds``:

    python bench/bench_ros_soak.py [--seconds 300] [--rate 1000] [--write]

Reported: requests sent, answered and lost (and the dynamics node's own received count from
/diagnostics), every answer checked to the bit against ``robot.inverse_dynamics`` (the
requests cycle through 64 random UR5e states), the controller's commands and the observer's
estimates per second, each node's CPU (% of a core) and resident memory (VmRSS) at the start,
the largest and at the end (sampled every 10 s). The target (issue 26): < 0.1 % lost, every
answer exact, memory flat, on 2 cores. ``--write`` writes the "ros_soak" section of
bench/BENCHMARKS.md (a run of the full 5 minutes only: on a shared machine it takes both
cores for that long).
"""
from __future__ import annotations

import argparse
import datetime
import os
import sys
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 50))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import rclpy  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

import serial_dynamics as sd  # noqa: E402
from serial_dynamics.ros.common import REQUEST_DEPTH, executor as new_executor  # noqa: E402
from serial_dynamics.ros.processes import NodeProcess  # noqa: E402

from _report import machine, write_section  # noqa: E402
from bench_ros_throughput import cpu_seconds  # noqa: E402

NS = "/soak"
HOME = [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]
ROBOT = sd.default_robot()
Q, QD = ROBOT.random_state(0, batch=64)
QDD = np.random.default_rng(1).uniform(-2, 2, Q.shape)
EXPECTED = ROBOT.inverse_dynamics(Q, QD, QDD)
NODES = {
    "simulator": {"sim_dt": 0.001, "publish_rate": 1000.0, "initial_positions": HOME,
                  "command_timeout": 0.0},
    "computed_torque_controller": {"control_rate": 1000.0},
    "external_torque_observer": {},
    "dynamics": {},
}


def rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("soak_client")
    executor = new_executor(True)         # the client's own CPU: the events executor too
    executor.add_node(node)
    counts = {"commands": 0, "estimates": 0}
    answers, wrong, node_received = {}, [0], [None]

    def on_answer(m):
        k = int(m.header.frame_id)
        answers[k] = True
        if not np.array_equal(np.asarray(m.points[0].effort), EXPECTED[k % len(Q)]):
            wrong[0] += 1

    def on_diagnostics(msg):
        for s in msg.status:
            if s.name == f"{NS}/dynamics":
                node_received[0] = node_received[0] or 0      # a report came (none counted yet)
                for v in s.values:
                    if v.key == "received inverse_dynamics/request":
                        node_received[0] = int(v.value)

    pub = node.create_publisher(JointTrajectory, f"{NS}/inverse_dynamics/request", REQUEST_DEPTH)
    node.create_subscription(JointTrajectory, f"{NS}/inverse_dynamics/response", on_answer,
                             REQUEST_DEPTH)
    node.create_subscription(Float64MultiArray, f"{NS}/effort_commands",
                             lambda m: counts.__setitem__("commands", counts["commands"] + 1), 10)
    node.create_subscription(JointState, f"{NS}/estimated_external_torques",
                             lambda m: counts.__setitem__("estimates", counts["estimates"] + 1), 10)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    procs = {name: NodeProcess(name, {"robot_description_timeout": 0.0, **p},
                               ros_args=["-r", f"__ns:={NS}"]) for name, p in NODES.items()}
    requests = [JointTrajectory(joint_names=ROBOT.joint_names, points=[JointTrajectoryPoint(
        positions=Q[i].tolist(), velocities=QD[i].tolist(), accelerations=QDD[i].tolist())])
        for i in range(len(Q))]
    try:
        deadline = time.monotonic() + 180
        while not (pub.get_subscription_count() > 0 and counts["commands"] > 0
                   and counts["estimates"] > 0 and node_received[0] is not None):
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the nodes did not come up (request subscribers "
                    f"{pub.get_subscription_count()}, commands {counts['commands']}, estimates "
                    f"{counts['estimates']}, dynamics report {node_received[0]}): " + "; ".join(
                        p.output()[-300:] for p in procs.values()))
            executor.spin_once(timeout_sec=0.05)
        time.sleep(1.0)
        before = node_received[0]
        pids = {name: p.proc.pid for name, p in procs.items()}
        cpu0 = {name: cpu_seconds(pid) for name, pid in pids.items()}
        rss = {name: [rss_kib(pid)] for name, pid in pids.items()}
        counts.update(commands=0, estimates=0)
        total = int(args.seconds * args.rate)
        stop = threading.Event()

        def sender():
            t0 = time.perf_counter()
            for k in range(total):
                due = t0 + k / args.rate
                while (now := time.perf_counter()) < due:
                    time.sleep(min(due - now, 0.0005))
                msg = requests[k % len(requests)]
                msg.header.frame_id = str(k)
                pub.publish(msg)
            stop.set()

        thread = threading.Thread(target=sender)
        t_start, next_sample = time.perf_counter(), time.monotonic() + 10
        thread.start()
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.01)
            if time.monotonic() > next_sample:
                next_sample += 10
                for name, pid in pids.items():
                    rss[name].append(rss_kib(pid))
                print(f"{time.perf_counter() - t_start:6.0f} s: answered {len(answers)}, "
                      f"wrong {wrong[0]}", flush=True)
        late = time.monotonic() + 2.0
        while len(answers) < total and time.monotonic() < late:
            executor.spin_once(timeout_sec=0.01)
        wall = time.perf_counter() - t_start
        cpu = {name: cpu_seconds(pid) - cpu0[name] for name, pid in pids.items()}
        for name, pid in pids.items():
            rss[name].append(rss_kib(pid))
        deadline = time.monotonic() + 2.5                 # a fresh /diagnostics report
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
        thread.join()
        alive = {name: p.running() for name, p in procs.items()}
    finally:
        for p in procs.values():
            p.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    lost = total - len(answers)
    result = dict(sent=total, answered=len(answers), lost=lost, lost_pct=100.0 * lost / total,
                  wrong=wrong[0], node_received=(node_received[0] or 0) - before, wall=wall,
                  commands_hz=counts["commands"] / wall, estimates_hz=counts["estimates"] / wall)
    print({k: round(float(v), 3) for k, v in result.items()})
    for name in NODES:
        print(f"{name:28s} CPU {100 * cpu[name] / wall:5.1f} % of a core, RSS (MiB) start "
              f"{rss[name][0] / 1024:.1f} max {max(rss[name]) / 1024:.1f} end "
              f"{rss[name][-1] / 1024:.1f}, running at the end: {alive[name]}")
    if args.write:
        write_section("ros_soak", report(result, cpu, rss, args))


def report(r, cpu, rss, args):
    load = os.getloadavg()
    lines = [
        "## ROS 2 nodes: the 1 kHz soak (`bench/bench_ros_soak.py`)", "",
        f"_Measured {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC on "
        f"{machine()}; load average {load[0]:.2f} at the end._", "",
        f"`python bench/bench_ros_soak.py --seconds {args.seconds:g} --write`: the simulator "
        "(1 ms steps, joint_states at 1 kHz), the controller at 1 kHz, the observer and the "
        f"dynamics node, one process each, and single-point requests at {args.rate:g} Hz.", "",
        f"- requests: {r['sent']} sent, {r['answered']} answered, **{r['lost']} lost "
        f"({r['lost_pct']:.3f} %)**, {r['wrong']} answers not equal to the library's "
        f"(the node received {r['node_received']})",
        f"- controller commands {r['commands_hz']:.0f} /s, observer estimates "
        f"{r['estimates_hz']:.0f} /s", "",
        "| node | CPU (% of a core) | RSS start / max / end (MiB) |", "|---|---|---|"]
    for name in NODES:
        lines.append(f"| {name} | {100 * cpu[name] / r['wall']:.0f} | {rss[name][0] / 1024:.1f}"
                     f" / {max(rss[name]) / 1024:.1f} / {rss[name][-1] / 1024:.1f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
