"""Fixtures for the ROS tests: real rclpy, real nodes in separate processes, real topics.

Each test session gets its own ROS_DOMAIN_ID (derived from the pid) so that parallel
runs do not cross-talk; every process started here is stopped at the end of its fixture
(and gets SIGTERM if this process dies).
"""
import os
import time

import pytest

rclpy = pytest.importorskip("rclpy")

# Odd ids 1..99 (the demo tests use DOMAIN + 1): 2 (pid % 25) + worker picks one of 50, even
# for xdist's worker gw0 and odd for gw1, so the two workers of a session never share a
# graph; the pid keeps most other sessions apart.
_WORKER = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:] or 0)
DOMAIN = 1 + (((os.getpid() % 25) * 2 + _WORKER) % 50) * 2
os.environ["ROS_DOMAIN_ID"] = str(DOMAIN)
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.time import Time  # noqa: E402

from serial_dynamics.ros.processes import NodeProcess  # noqa: E402

# robot parameters for every node started here: the embedded UR5e, without waiting for a
# robot_description topic
NO_TOPIC = {"robot_description_timeout": 0.0}
MATCH_SETTLE = 0.5                                  # s, see Ros.wait_matched
HOME = [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]   # UR5e, elbow up


class Ros:
    """The test's own node and a spin helper."""

    def __init__(self):
        rclpy.init()
        self.node = rclpy.create_node(f"test_{os.getpid()}")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.procs = []
        self.settled = set()            # clients whose first call waited MATCH_SETTLE

    def spin_until(self, done, timeout=20.0, what="a condition"):
        deadline = time.monotonic() + timeout
        while not done():
            for p in self.procs:
                if p.expect_running and not p.stopped and not p.running():
                    raise AssertionError(f"{p.module} exited:\n{p.output()}")
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.02)

    def wait_matched(self, *publishers, also=lambda: True, timeout=150.0, what="a node"):
        """Until each publisher has a subscriber (and ``also()``), then MATCH_SETTLE s more:
        a publisher sees the match before the subscriber's side of discovery has matched it
        back, and a message sent in between can be lost."""
        self.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers)
                        and also(), timeout, what)
        self.spin_for(MATCH_SETTLE)

    def spin_for(self, seconds):
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)

    def start(self, module, params=None, ros_args=(), expect_running=True):
        p = NodeProcess(module, {**NO_TOPIC, **(params or {})}, ros_args)
        p.expect_running = expect_running
        self.procs.append(p)
        return p

    def call(self, client, request, timeout=20.0, resend=None):
        """The service's answer. A client's first call waits MATCH_SETTLE s once the service
        is ready: the client sees the service before the service has matched the client's
        response reader, and rmw_fastrtps drops an answer it cannot match yet ("client will
        not receive response"; an unanswered call, run 1 of a 10-run load check).
        ``resend`` (s): a request with no side effect goes out again after that long
        without an answer."""
        self.spin_until(client.service_is_ready, timeout, f"service {client.srv_name}")
        if client not in self.settled:
            self.spin_for(MATCH_SETTLE)
            self.settled.add(client)
        futures, sent = [client.call_async(request)], [time.monotonic()]

        def answered():
            if any(f.done() for f in futures):
                return True
            if resend is not None and time.monotonic() - sent[0] > resend:
                futures.append(client.call_async(request))
                sent[0] = time.monotonic()
            return False
        self.spin_until(answered, timeout, f"the answer of {client.srv_name}")
        return next(f for f in futures if f.done()).result()

    def close(self):
        for p in self.procs:
            p.stop()
        self.node.destroy_node()
        rclpy.try_shutdown()


@pytest.fixture(scope="session")
def ros():
    r = Ros()
    yield r
    r.close()


@pytest.fixture(scope="module", autouse=True)
def stop_the_module_nodes(ros):
    """Stop the nodes a test module started when it ends: a simulator left stepping at
    1 kHz would take a core from every later test (test_threads needs the threads of one
    process to interleave)."""
    started = len(ros.procs)
    yield
    for p in ros.procs[started:]:
        p.stop()


def stamp_ns(msg):
    """A message's header stamp in nanoseconds (the simulated time where the simulator
    publishes its clock), as the simulator reads a command's."""
    return Time.from_msg(msg.header.stamp).nanoseconds


def wait_for_log(ros, proc, text, timeout=20.0):
    ros.spin_until(lambda: text in proc.output(), timeout, f"{text!r} in the {proc.module} log")


class Latest:
    """Subscription that keeps every message (with its wall time of arrival)."""

    def __init__(self, ros, msg_type, topic, depth=50):
        self.msgs = []
        self.sub = ros.node.create_subscription(msg_type, topic, self.msgs.append, depth)
        self.ros = ros

    def clear(self):
        self.msgs.clear()

    def wait(self, pred=lambda m: True, timeout=90.0, what="a message"):
        """The first message received from now on that satisfies pred."""
        state = {"i": len(self.msgs), "found": None}

        def done():
            while state["i"] < len(self.msgs):
                m = self.msgs[state["i"]]
                state["i"] += 1
                if pred(m):
                    state["found"] = m
                    return True
            return False
        self.ros.spin_until(done, timeout, what)
        return state["found"]

    def destroy(self):
        self.ros.node.destroy_subscription(self.sub)
