"""Clean shutdown (issue 20 item 4): every node, busy (states at 1 kHz, commands, estimates,
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

from conftest import HOME, Latest, wait_for_log

NODES = ("simulator", "inverse_dynamics", "computed_torque_controller",
         "external_torque_observer")
BOUND = 2.0      # s from the signal to the exit (issue 20 item 4)


def _request():
    return JointTrajectory(joint_names=sd.default_robot().joint_names,
                           points=[JointTrajectoryPoint(positions=HOME)])


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_every_node_stops_cleanly_on_a_signal(ros, sig):
    ns = f"/shutdown_{sig.name.lower()}"
    params = {"simulator": {"publish_rate": 1000.0, "initial_positions": HOME},
              "computed_torque_controller": {"control_rate": 1000.0},
              "inverse_dynamics": {}, "external_torque_observer": {}}
    procs = {name: ros.start(name, params[name], ros_args=["-r", f"__ns:={ns}"])
             for name in NODES}
    for p in procs.values():
        wait_for_log(ros, p, "ready", timeout=150)
    # every node busy: the controller commanding, the observer estimating, requests answered
    commands = Latest(ros, Float64MultiArray, f"{ns}/effort_commands")
    estimates = Latest(ros, JointState, f"{ns}/estimated_external_torques")
    answers = Latest(ros, JointTrajectory, f"{ns}/inverse_dynamics/response")
    requests = ros.node.create_publisher(JointTrajectory, f"{ns}/inverse_dynamics/request", 100)
    ros.spin_until(lambda: (requests.publish(_request()) or True) and answers.msgs
                   and len(commands.msgs) > 100 and len(estimates.msgs) > 100, 60,
                   "commands, estimates and answers")
    for p in procs.values():
        p.stopped = True                         # from here on an exit is expected
        p.proc.send_signal(sig)
    start, exited = time.monotonic(), {}
    while len(exited) < len(procs) and time.monotonic() - start < 10.0:
        requests.publish(_request())
        for name, p in procs.items():
            if name not in exited and not p.running():
                exited[name] = time.monotonic() - start
        ros.spin_for(0.005)
    for x in (commands, estimates, answers):
        x.destroy()
    ros.node.destroy_publisher(requests)
    for name, p in procs.items():
        code = p.stop(timeout=0.1)               # kills what is still running
        out = p.output()
        assert name in exited and exited[name] < BOUND, (
            f"{name} still running {BOUND} s after {sig.name}:\n{out}")
        assert code == 0, f"{name} exited with {code} on {sig.name}:\n{out}"
        for bad in ("Traceback", "internal error", "Error", "context is invalid"):
            assert bad not in out, f"{name} printed {bad!r} on {sig.name}:\n{out}"
        assert out.rstrip().splitlines()[-1].endswith(f"stopped ({sig.name})"), out
