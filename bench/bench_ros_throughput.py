"""ROS throughput: single-point inverse-dynamics requests answered per CPU-second of the
dynamics node's process, over the topic pair (``inverse_dynamics/request`` ->
``inverse_dynamics/response``) and over the ``~/inverse_dynamics`` service, for the code path
before issue 26 (``bench/_ros_legacy.py``: SingleThreadedExecutor, the conversions of then)
and the node as it is, in one run.

    python bench/bench_ros_throughput.py [--seconds 8] [--rate 1000] [--rounds 2] [--no-write]

Each path runs as its own process (the node as users start it: ``python -m
serial_dynamics.ros.dynamics``; the old path: ``python bench/_ros_legacy.py``), on a ROS
domain of this run, with the Fast DDS RMW of the PyPI wheels. The client (this process, an
rclpy node) sends the UR5e request of bench_ros_latency.py at ``--rate`` on a wall-clock
schedule for ``--seconds``; the node's CPU time (user + system, every thread, from
/proc/<pid>/stat) is read just before the first request and once the last answer is in (or
1 s after the last request). Figure: answers received / node CPU seconds. Every answer is
checked against ``robot.inverse_dynamics`` (bit-exact: same kernel, same inputs). The old and
new paths alternate ``--rounds`` times so that the machine's load touches both alike.
Writes the "ros_throughput" section of bench/BENCHMARKS.md (unless ``--no-write``).
"""
from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
os.environ.setdefault("ROS_DOMAIN_ID", str(40 + os.getpid() % 50))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint  # noqa: E402

import serial_dynamics as sd  # noqa: E402
from serial_dynamics.ros.common import REQUEST_DEPTH  # noqa: E402
from serial_dynamics.ros.processes import NodeProcess, ros_value  # noqa: E402
from serial_dynamics_interfaces.srv import InverseDynamics  # noqa: E402

from _report import machine, write_section  # noqa: E402

ROBOT = sd.default_robot()
Q, QD = ROBOT.random_state(0)
QDD = np.full(ROBOT.dof, 0.5)
EXPECTED = ROBOT.inverse_dynamics(Q, QD, QDD)
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid``, all its threads (/proc/<pid>/stat)."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS     # utime, stime (fields 14, 15)


class LegacyProcess(NodeProcess):
    """The node of before, started through bench/_ros_legacy.py (same log and stop)."""

    def __init__(self, params, ros_args):
        self.module, self.stopped = "dynamics", False
        self.cmd = [sys.executable, os.path.join(HERE, "_ros_legacy.py"), "--ros-args"]
        for name, value in params.items():
            self.cmd += ["-p", f"{name}:={ros_value(value)}"]
        self.cmd += list(ros_args)
        fd, self.log_path = tempfile.mkstemp(prefix="dynamics-legacy-", suffix=".log")
        self._log = os.fdopen(fd, "w")
        self.proc = subprocess.Popen(self.cmd, stdout=self._log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL)


def spin_until(executor, done, timeout, what):
    deadline = time.monotonic() + timeout
    while not done():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        executor.spin_once(timeout_sec=0.01)


def paced(rate, count, send, stop):
    """Call ``send(k)`` for k < count at ``rate`` Hz of wall time, then set ``stop``."""
    t0, k = time.perf_counter(), 0
    while k < count:
        due = t0 + k / rate
        while (now := time.perf_counter()) < due:
            time.sleep(min(due - now, 0.0005))
        send(k)
        k += 1
    stop.set()


def measure(node, executor, ns, pid, kind, seconds, rate):
    """One run of ``kind`` ('topic' or 'service') against the node of namespace ``ns``."""
    count = int(seconds * rate)
    answers, wrong = [0], [0]

    def check(efforts):
        if not np.array_equal(np.asarray(efforts), EXPECTED):
            wrong[0] += 1
        answers[0] += 1

    if kind == "topic":
        pub = node.create_publisher(JointTrajectory, f"{ns}/inverse_dynamics/request",
                                    REQUEST_DEPTH)
        sub = node.create_subscription(JointTrajectory, f"{ns}/inverse_dynamics/response",
                                       lambda m: check(m.points[0].effort), REQUEST_DEPTH)
        request = JointTrajectory(joint_names=ROBOT.joint_names, points=[JointTrajectoryPoint(
            positions=Q.tolist(), velocities=QD.tolist(), accelerations=QDD.tolist())])
        spin_until(executor, lambda: pub.get_subscription_count() > 0
                   and sub.get_publisher_count() > 0, 150, "the node's topics")
        for _ in range(100):                   # warm the path (and let discovery settle)
            pub.publish(request)
            executor.spin_once(timeout_sec=0.002)

        def send(k):
            pub.publish(request)
    else:
        client = node.create_client(InverseDynamics, f"{ns}/dynamics/inverse_dynamics",
                                    qos_profile=QoSProfile(depth=REQUEST_DEPTH))
        request = InverseDynamics.Request(joint_names=ROBOT.joint_names, positions=Q.tolist(),
                                          velocities=QD.tolist(), accelerations=QDD.tolist())
        spin_until(executor, client.service_is_ready, 150, "the node's service")
        for _ in range(100):
            future = client.call_async(request)
            spin_until(executor, future.done, 10, "a warm-up call")
        pending = []

        def send(k):
            future = client.call_async(request)
            future.add_done_callback(lambda f: check(f.result().efforts))
            pending.append(future)
    deadline = time.monotonic() + 0.5          # the warm-up's answers drained
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
    answers[0], wrong[0] = 0, 0
    stop = threading.Event()
    thread = threading.Thread(target=paced, args=(rate, count, send, stop))
    cpu0, t0 = cpu_seconds(pid), time.perf_counter()
    thread.start()
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.01)
    late = time.monotonic() + 1.0
    while answers[0] < count and time.monotonic() < late:
        executor.spin_once(timeout_sec=0.01)
    cpu, wall = cpu_seconds(pid) - cpu0, time.perf_counter() - t0
    thread.join()
    if kind == "topic":
        node.destroy_publisher(pub)
        node.destroy_subscription(sub)
    else:
        for future in pending:
            if not future.done():
                client.remove_pending_request(future)
        node.destroy_client(client)
    return dict(sent=count, answered=answers[0], wrong=wrong[0], cpu=cpu, wall=wall,
                per_cpu_s=answers[0] / cpu if cpu else float("nan"),
                core=cpu / wall)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--paths", default="old,new")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("bench_throughput")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    params = {"robot_description_timeout": 0.0}
    procs, rows = {}, {}
    try:
        for path in args.paths.split(","):
            ns = f"/bench_tp_{path}"
            ros_args = ["-r", f"__ns:={ns}"]
            procs[path] = (LegacyProcess(params, ros_args) if path == "old"
                           else NodeProcess("dynamics", params, ros_args=ros_args))
        for _ in range(args.rounds):
            for path, proc in procs.items():
                for kind in ("topic", "service"):
                    r = measure(node, executor, f"/bench_tp_{path}", proc.proc.pid, kind,
                                args.seconds, args.rate)
                    rows.setdefault((path, kind), []).append(r)
                    print(f"{path:3s} {kind:7s}", {k: round(float(v), 3) for k, v in r.items()},
                          flush=True)
    finally:
        for proc in procs.values():
            proc.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    for (path, kind), rs in rows.items():
        assert all(r["wrong"] == 0 for r in rs), f"{path} {kind}: an answer differs"
    if not args.no_write:
        write_section("ros_throughput", report(rows, args))


def report(rows, args):
    load = os.getloadavg()
    lines = [
        "## ROS 2 nodes: requests per CPU-second of the dynamics node "
        "(`bench/bench_ros_throughput.py`)", "",
        f"_Measured {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC on "
        f"{machine()}; load average {load[0]:.2f} at the end of the run (the 2 cores were "
        "shared with other work)._", "",
        f"`python bench/bench_ros_throughput.py --seconds {args.seconds:g} --rate "
        f"{args.rate:g} --rounds {args.rounds}`: single-point UR5e requests at "
        f"{args.rate:g} Hz for {args.seconds:g} s, paths alternating, {args.rounds} rounds; "
        "answers / CPU seconds of the node's process (every thread). Every answer equal to "
        "`robot.inverse_dynamics` to the bit.", "",
        "| path | transport | answered / sent | node CPU (% of a core) | requests per CPU-second |",
        "|---|---|---|---|---|"]
    names = {"old": "before (SingleThreadedExecutor, old conversions)",
             "new": "now (EventsExecutor, array conversions)"}
    for (path, kind), rs in rows.items():
        answered, sent = sum(r["answered"] for r in rs), sum(r["sent"] for r in rs)
        cpu, wall = sum(r["cpu"] for r in rs), sum(r["wall"] for r in rs)
        per = [f"{r['per_cpu_s']:.0f}" for r in rs]
        lines.append(f"| {names.get(path, path)} | {kind} | {answered} / {sent} | "
                     f"{100 * cpu / wall:.0f} | **{answered / cpu:.0f}** (rounds: "
                     f"{', '.join(per)}) |")
    lines += ["", WHERE]
    return "\n".join(lines) + "\n"


WHERE = """Where a request's CPU went, and what changed (cProfile of the node in-process, a client \
process at 1 kHz; `rclpy` 7.1 wheels, Fast DDS):

- **Before, about 1 ms of CPU per request**, two thirds of it in rclpy's \
`SingleThreadedExecutor`: every `spin_once` rebuilds its wait set in Python \
(`_wait_for_ready_callbacks`: the node's ~30 entities -- 6 services of its own, rclpy's 7 \
parameter and type-description services, 3 subscriptions, publishers' event handlers, the \
/diagnostics timer -- each added, checked and context-managed, for every request). The rest: \
the request's conversion (`trajectory_arrays`: a set of lengths, a list comprehension and \
two NumPy reductions per field, the name checks), building the answer message field by \
field from Python lists, `publish` (serialization), `take_message` (deserialization).
- **Now** (`ros/common.py` `executor`, `ros/requests.py`): the dynamics node spins Jazzy's \
`rclpy.experimental.EventsExecutor` (in C++: the middleware's "new message" callback goes \
straight to the entity's handler, no wait set). Two things it needed here: its subscription \
callbacks get `(message, info)` as one argument (`common.subscribe` takes both forms, so the \
lost-message counts stay), and it holds the node's entities in use until `shutdown()`: a \
node destroyed before that left its endpoints in the graph for the DDS lease (a test, \
`test_a_stopped_node_leaves_the_graph`, failed before the fix). It installs its own \
SIGINT/SIGTERM handlers; `run` puts its own back. Falls back to `SingleThreadedExecutor` \
where rclpy has no `EventsExecutor`. The conversions: joint names equal to the robot's skip \
the name checks; each float64[] field is read through the buffer protocol \
(`np.asarray(array.array)`), checked with one comparison; the answer is written into the \
request message itself (its header and times kept), each field an `array.array('d')` made \
from the NumPy bytes; service answers are `array.array` too.
- **What is left** (about 0.4 ms of the process's CPU per request, all threads): the \
Python callback about 40 us (conversion, one `inverse_dynamics` call of ~2 us, the \
counts), `publish` with serialization ~70-90 us, `take_message` building the request's \
Python objects (`JointTrajectory`, its point, `Header`, `Time`, `Duration`) ~50 us, and Fast \
DDS's own threads (reception, shared-memory notification). Going further means fewer Python \
message objects per request (a raw subscription with `rclpy.serialization`, or a C++ node).
- Hosting several nodes in one process (one executor) was not needed for the target and is \
not done: the four nodes stay separate processes (a stalled node cannot stall the others)."""


if __name__ == "__main__":
    main()
