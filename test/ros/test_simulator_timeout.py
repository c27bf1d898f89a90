"""What the simulator node does when its command stream stops (issue 26 item 6), on the
test's clock: paused simulators stepped by ``~/step`` (no wall-clock race). The UR5e at
HOME held by its gravity torques; the commands stop; 0.5 s of simulated time later
(command_timeout) ``limp`` lets the arm fall, ``brake`` (the default) holds it where it was.
"""
import numpy as np
import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

import serial_dynamics as sd

from conftest import HOME, Latest, wait_for_log, stamp_ns

STEPS = 500                 # per ~/step call: 0.5 s


@pytest.mark.parametrize("action", ["limp", None])        # None: the default, brake
def test_a_lost_command_stream(ros, action):
    ns = f"/timeout_{action or 'default'}"
    params = {"initial_positions": HOME, "start_paused": True, "step_count": STEPS,
              "publish_clock": True}       # joint_states stamped with the simulated time
    if action:
        params["command_timeout_action"] = action
    proc = ros.start("simulator", params, ros_args=["-r", f"__ns:={ns}"])
    states = Latest(ros, JointState, f"{ns}/joint_states", depth=100)
    effort = ros.node.create_publisher(Float64MultiArray, f"{ns}/effort_commands", 10)
    step = ros.node.create_client(Trigger, f"{ns}/simulator/step")
    try:
        wait_for_log(ros, proc, "ready", timeout=150)
        ros.wait_matched(effort, also=lambda: states.msgs, what="the simulator")
        g = sd.default_robot().gravity_torques(np.array(HOME))
        effort.publish(Float64MultiArray(data=g.tolist()))
        held = states.wait(lambda m: np.allclose(m.effort, g, rtol=0, atol=1e-12),
                           what="the command")
        # the source stops: 0.5 s held, then the timeout, then 1 s of the timeout's action
        for _ in range(3):
            assert ros.call(step, Trigger.Request()).success
        # the state at the end of the steps, by its stamp (a state published during them may
        # still be on its way: under load it arrived last, in the braking transient)
        end = stamp_ns(held) + 3 * STEPS * 1_000_000
        last = states.wait(lambda m: stamp_ns(m) == end, what="joint_states after the steps")
        drift = np.max(np.abs(np.array(last.position) - HOME))
        if action == "limp":
            assert drift > 0.1 and not any(last.effort)            # it fell, no torque
            assert "applied effort back to zero" in proc.output()
        else:
            assert drift < 1e-2 and max(abs(x) for x in last.velocity) < 1e-3   # held
            assert "braking" in proc.output()
    finally:
        states.destroy()
        proc.stop()
