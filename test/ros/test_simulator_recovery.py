"""Issue 52 item 0: a running simulator whose step diverges after a warning pauses at the last
good state and comes back on ~/reset and ~/pause false. Before the fix, the step's warning
(command_timeout) and then its error (the divergence) went through one log call site; rclpy
refuses a call site at a second severity ("Logger severity cannot be changed between
calls."), the exception ended the simulation thread, and no joint_states came again."""
import numpy as np
import pytest
from sensor_msgs.msg import JointState
from rclpy.logging import get_logger
from std_srvs.srv import SetBool, Trigger

import serial_dynamics as sd
from serial_dynamics.ros import common

from conftest import HOME, Latest, wait_for_log

NAMES = sd.default_robot().joint_names
NS = "/recover"
EXTREME = 1e6             # in bound: common.MAX_VALUE, the most a message may carry


def test_log_takes_any_severity_at_one_call_site():
    logger = get_logger("test_log_helper")

    def at(level):                # one call site, two severities: what the node did
        getattr(logger, level)(f"a line at {level}")
    at("warning")
    with pytest.raises(ValueError, match="severity cannot be changed"):
        at("error")
    for level in ("warning", "error", "info", "debug", "warning"):
        common.log(logger, level, f"a line at {level}")
    with pytest.raises(ValueError, match="log level 'warn' unknown; use error, warning"):
        common.log(logger, "warn", "a line")


def test_the_simulator_resumes_after_a_divergence_that_follows_a_warning(ros):
    proc = ros.start("simulator", {"initial_positions": HOME}, ros_args=["-r", f"__ns:={NS}"])
    states = Latest(ros, JointState, f"{NS}/joint_states", depth=100)
    joint = ros.node.create_publisher(JointState, f"{NS}/joint_commands", 10)
    reset = ros.node.create_client(Trigger, f"{NS}/simulator/reset")
    pause = ros.node.create_client(SetBool, f"{NS}/simulator/pause")
    try:
        wait_for_log(ros, proc, "ready", timeout=150)
        ros.wait_matched(joint, also=lambda: states.msgs, what="the simulator")
        # one valid position target, then its stream lapses: command_timeout warns, brakes
        joint.publish(JointState(name=NAMES, position=HOME))
        wait_for_log(ros, proc, "(command_timeout): braking")
        # in-bound extreme targets: the step diverges and logs an error
        for _ in range(3):
            joint.publish(JointState(name=NAMES, position=[EXTREME] * 6))
        for _ in range(3):
            joint.publish(JointState(name=NAMES, velocity=[EXTREME] * 6))
        wait_for_log(ros, proc, "paused at the last good state")
        assert "simulation stopped" not in proc.output()
        assert ros.call(reset, Trigger.Request()).message.startswith("state reset")
        assert ros.call(pause, SetBool.Request(data=False)).message == "running"
        # the thread steps again: from the reset state (HOME, at rest, no command) the arm
        # falls under gravity, so every state published now is a new one
        states.clear()
        seen = set()
        states.wait(lambda m: seen.add(tuple(m.position)) or len(seen) >= 20, timeout=60,
                    what="20 distinct joint_states after ~/pause false")
        assert np.all(np.isfinite([m.position for m in states.msgs]))
        assert "simulation stopped" not in proc.output() and proc.running()
    finally:
        states.destroy()
        proc.stop()
