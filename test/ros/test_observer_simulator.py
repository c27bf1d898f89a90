"""End to end, in three processes: the simulator holds the UR5e with its joint servo, the
test pushes the tip through the simulator's ``external_wrench``, and the external-torque
observer, which sees only the simulator's ``joint_states`` (position, velocity and the
actuator torque in ``effort``), estimates the push: its joint torques within 2 % of
J(q)^T w and its wrench within 2 % of w, and its collision flag turns on with the push
and off after it.

The arm comes to rest against the push, held by the servo, so the estimate converges to
the true external torque with the observer's lag (gain 100 1/s: e^-100 after 1 s); here it
meets it to round-off (measured 7e-16 relative), well inside the issue's 2 %. A sign
error, a missing gravity term, the effort read as the net torque, or a wrong Jacobian in
the wrench estimate leave errors of the size of the push or of gravity. (The arm is at
rest when the estimate is read, so this test does not see the C^T qd term: the library's
tests against a moving arm do, test/test_observers.py.)
"""
import numpy as np
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

import serial_dynamics as sd

from conftest import Latest

ROBOT = sd.default_robot()
Q1 = [0.3, -1.2, 1.4, -1.0, -1.3, 0.4]            # away from singular poses
W = np.array([25.0, -15.0, 20.0, 1.0, -1.5, 0.5])  # N, N m: on the tip, base frame
NS = ["-r", "__ns:=/push"]


def stamp_s(msg):
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def test_the_observer_estimates_a_push_on_the_simulated_arm(ros):
    ros.start("simulator", {"publish_clock": True, "initial_positions": Q1,
                            "publish_rate": 500.0, "command_timeout": 0.0,
                            "dissipation.enabled": False}, NS)
    ros.start("external_torque_observer", {"gain": 100.0, "collision_thresholds": [3.0],
                                           "collision_release": 0.5}, NS)
    hold = ros.node.create_publisher(JointState, "/push/joint_commands", 10)
    push = ros.node.create_publisher(WrenchStamped, "/push/external_wrench", 10)
    states = Latest(ros, JointState, "/push/joint_states", depth=50)
    tau_ext = Latest(ros, JointState, "/push/estimated_external_torques", depth=50)
    wrench = Latest(ros, WrenchStamped, "/push/estimated_external_wrench", depth=50)
    collision = Latest(ros, Bool, "/push/collision", depth=2000)
    try:
        ros.wait_matched(hold, push, also=lambda: tau_ext.msgs, what="the two nodes")
        # the servo holds Q1, with gravity fed forward
        hold.publish(JointState(name=ROBOT.joint_names, position=Q1,
                                effort=ROBOT.gravity_torques(np.array(Q1)).tolist()))

        def after(seconds):           # the first estimate `seconds` of simulated time on
            t0 = stamp_s(tau_ext.wait())
            return tau_ext.wait(lambda m: stamp_s(m) >= t0 + seconds,
                                timeout=120.0, what=f"{seconds} s more of estimates")

        def flag(on, what):           # the latest collision flag is `on` (its own topic: it
            ros.spin_until(lambda: collision.msgs and collision.msgs[-1].data == on,
                           30.0, what)    # may trail the estimates on a loaded machine)

        quiet = np.array(after(0.5).effort)
        assert np.max(np.abs(quiet)) < 0.05          # nothing pushes yet: ~0
        flag(False, "no collision before the push")
        msg = WrenchStamped()
        f, m = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, m.x, m.y, m.z = W.tolist()
        push.publish(msg)
        r = np.array(after(1.0).effort)
        q = np.array(states.wait().position)
        truth = ROBOT.jacobian(q).T @ W
        assert np.max(np.abs(q - Q1)) < 0.02         # held: the servo stays near Q1
        assert np.linalg.norm(r - truth) <= 0.02 * np.linalg.norm(truth)
        est = wrench.msgs[-1].wrench
        w = np.array([est.force.x, est.force.y, est.force.z,
                      est.torque.x, est.torque.y, est.torque.z])
        assert np.linalg.norm(w - W) <= 0.02 * np.linalg.norm(W)
        flag(True, "a collision with the push")       # |r| is far beyond 3 N m
        push.publish(WrenchStamped())                 # a zero wrench: the push ends
        after(0.5)
        flag(False, "no collision after it")          # below 0.5 x 3 N m everywhere again
    finally:
        for sub in (states, tau_ext, wrench, collision):
            sub.destroy()
