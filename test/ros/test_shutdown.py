"""Clean shutdown (issue 20 item 4): every node, busy (states at 250 Hz, commands, estimates,
requests), stops within 2 s of SIGINT and of SIGTERM, with exit status 0, no traceback, no
"internal error" and, as its last log line, ``stopped (SIGINT)`` / ``stopped (SIGTERM)``.

The 2 s bound is the issue's functional requirement (a launch file or systemd escalates to
SIGKILL after a grace period), not a speed measurement: a clean stop takes a few tens of
milliseconds; the bound is generous for a loaded 2-core machine and still fails a node
that hangs in its spin.
"""
import signal
import time

import pytest

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd

from serial_dynamics.ros import common

from conftest import HOME, Latest, wait_for_log

NODES = ("simulator", "inverse_dynamics", "computed_torque_controller",
         "external_torque_observer")
BOUND = 2.0      # s from the signal to the exit (issue 20 item 4)
RATE = 250.0     # Hz: the simulator's states and the controller's commands
BUSY = 25        # commands and estimates seen per set before the signals


def _request():
    return JointTrajectory(joint_names=sd.default_robot().joint_names,
                           points=[JointTrajectoryPoint(positions=HOME)])


_last_sent = [0.0]


def _paced(requests, period=0.01):
    """One request to each set every ``period`` s (the spin loop turns once per message
    received, thousands of times a second: a request each turn would flood the nodes)."""
    if time.monotonic() - _last_sent[0] >= period:
        _last_sent[0] = time.monotonic()
        for r in requests:
            r.publish(_request())
    return True


def test_every_node_stops_cleanly_on_a_signal(ros):
    """Two sets of the four nodes, started together; SIGINT to one set, SIGTERM to the
    other, at once."""
    # 250 Hz: eight busy nodes on two cores at 1 kHz starve each other, and what is tested
    # is the stop, not the pace (the 1 kHz pace is bench/bench_controller_load.py's)
    params = {"simulator": {"publish_rate": RATE, "initial_positions": HOME},
              "computed_torque_controller": {"control_rate": RATE},
              "inverse_dynamics": {}, "external_torque_observer": {}}
    sets = {sig: {name: ros.start(name, params[name],
                                  ros_args=["-r", f"__ns:=/shutdown_{sig.name.lower()}"])
                  for name in NODES} for sig in (signal.SIGINT, signal.SIGTERM)}
    for procs in sets.values():
        for p in procs.values():
            wait_for_log(ros, p, "ready", timeout=150)
    # every node busy: the controller commanding, the observer estimating, requests answered
    watched, requests = [], []
    for sig in sets:
        ns = f"/shutdown_{sig.name.lower()}"
        commands = Latest(ros, Float64MultiArray, f"{ns}/effort_commands")
        estimates = Latest(ros, JointState, f"{ns}/estimated_external_torques")
        answers = Latest(ros, JointTrajectory, f"{ns}/inverse_dynamics/response")
        watched += [commands, estimates, answers]
        requests.append(ros.node.create_publisher(JointTrajectory,
                                                  f"{ns}/inverse_dynamics/request", 100))
        busy = (lambda c, e, a: lambda: a.msgs and len(c.msgs) > BUSY and len(e.msgs) > BUSY)(
            commands, estimates, answers)
        ros.spin_until(lambda: _paced(requests) and busy(), 120,
                       f"commands, estimates and answers in {ns}")
    for sig, procs in sets.items():
        for p in procs.values():
            p.stopped = True                     # from here on an exit is expected
            p.proc.send_signal(sig)
    start, exited = time.monotonic(), {}
    everyone = [(sig, name, p) for sig, procs in sets.items() for name, p in procs.items()]
    while len(exited) < len(everyone) and time.monotonic() - start < 10.0:
        _paced(requests)
        for sig, name, p in everyone:
            if (sig, name) not in exited and not p.running():
                exited[sig, name] = time.monotonic() - start
        ros.spin_for(0.005)
    for x in watched:
        x.destroy()
    for r in requests:
        ros.node.destroy_publisher(r)
    for sig, name, p in everyone:
        code = p.stop(timeout=0.1)               # kills what is still running
        out = p.output()
        assert (sig, name) in exited and exited[sig, name] < BOUND, (
            f"{name} still running {BOUND} s after {sig.name}:\n{out}")
        assert code == 0, f"{name} exited with {code} on {sig.name}:\n{out}"
        for bad in ("Traceback", "internal error", "Error", "context is invalid"):
            assert bad not in out, f"{name} printed {bad!r} on {sig.name}:\n{out}"
        assert out.rstrip().splitlines()[-1].endswith(f"stopped ({sig.name})"), out


class _Log:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(("info", text))

    def debug(self, text):
        self.lines.append(("debug", text))


def _signalled(*signals, said=False):
    """A stop request (a 50 ms deadline, its exit recorded) sent ``signals`` while spinning."""
    exits = []
    stop = common._StopRequest(deadline=0.05, exit=exits.append)
    stop.logger, stop.spinning = _Log(), True
    for sig in signals:
        stop(sig, None)
    if said:
        stop.said_stopped()
    time.sleep(0.5)
    return stop, exits


def test_a_teardown_that_hangs_is_cut_short_after_saying_stopped():
    """The deadline (rclpy's teardown once hung over 10 s in a run of this file): exit 0,
    the first signal's name in the last line, said once, what was cut short at DEBUG."""
    stop, exits = _signalled(signal.SIGTERM, signal.SIGINT)   # the second starts no deadline
    assert exits == [0]
    assert stop.logger.lines == [
        ("debug", "the stop was still spinning 0.05 s after SIGTERM: exiting without it"),
        ("info", "stopped (SIGTERM)")]


def test_a_stop_that_said_stopped_is_not_said_again_by_the_deadline():
    stop, exits = _signalled(signal.SIGINT, said=True)
    assert exits == [0]
    assert [x for x in stop.logger.lines if x[0] == "info"] == [("info", "stopped (SIGINT)")]


def test_a_signal_before_the_spin_interrupts_the_start_up():
    exits = []
    stop = common._StopRequest(deadline=0.05, exit=exits.append)
    with pytest.raises(KeyboardInterrupt):
        stop(signal.SIGINT, None)
    time.sleep(0.5)
    assert exits == [0] and stop.signal == "SIGINT"
