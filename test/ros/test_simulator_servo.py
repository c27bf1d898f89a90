"""The simulator's joint servo over real topics: joint_commands with position and/or
velocity targets, at stiff gains (Kp = 1e5 N m/rad, Kd = 1e3 N m s/rad on every joint) and
1 ms steps, where an explicit PD diverges (checked here with the library first); with
either integrator that has the implicit servo, and refused (logged) with one that has not.

Oracles: the targets themselves; statics at rest (the actuator torque published in
``effort`` balances gravity, g(q) from the library, and the offset of a PD without
feed-forward is Kp^-1 g(q)); the velocity target.
"""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger

import serial_dynamics as sd
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.methods import SimulationError

from conftest import HOME, Latest, wait_for_log

ROBOT = sd.default_robot()
NAMES = ROBOT.joint_names
KP, KD = 1e5, 1e3
TARGET = np.array([0.4, -1.2, 1.3, -1.4, -1.2, 0.3])


@pytest.fixture(scope="module", params=["semi_implicit_euler", "symplectic_euler"])
def sim(ros, request):
    NS = f"/srv_{request.param}"
    proc = ros.start("simulator", {"publish_clock": True, "initial_positions": HOME,
                                   "start_paused": True, "command_timeout": 0.0,
                                   "servo.kp": [KP], "servo.kd": [KD],
                                   "integrator": request.param},
                     ros_args=["-r", f"__ns:={NS}"])

    class S:
        pass
    s = S()
    s.ros, s.proc = ros, proc
    s.states = Latest(ros, JointState, f"{NS}/joint_states", depth=100)
    s.joint = ros.node.create_publisher(JointState, f"{NS}/joint_commands", 10)
    s.reset = ros.node.create_client(Trigger, f"{NS}/simulator/reset")
    s.pause = ros.node.create_client(SetBool, f"{NS}/simulator/pause")
    s.diag = {}

    def on(msg):
        for st in msg.status:
            if st.name == f"{NS}/simulator":
                s.diag.update({v.key: v.value for v in st.values})
    s.sub = ros.node.create_subscription(DiagnosticArray, "/diagnostics", on, 10)
    ros.wait_matched(s.joint, also=lambda: s.states.msgs, what="the simulator")
    assert ros.call(s.pause, SetBool.Request(data=False)).success
    yield s
    s.states.destroy()
    ros.node.destroy_subscription(s.sub)
    proc.stop()


def settled(m, tol=1e-7):
    return np.max(np.abs(m.velocity)) < tol


def test_an_explicit_pd_at_these_gains_diverges():
    """The premise: the same PD as a torque from the state at the start of each 1 ms step."""
    integ = FixedStepIntegrator(ROBOT, "semi_implicit_euler", 1e-3, True, position_limits=True)
    q, qd = np.array(HOME), np.zeros(6)
    with pytest.raises(SimulationError):
        for _ in range(2000):
            tau = ROBOT.gravity_torques(TARGET) + KP * (TARGET - q) - KD * qd
            q, qd = integ.step(q, qd, tau)


def test_position_targets_with_gravity_feedforward_converge(sim):
    g = ROBOT.gravity_torques(TARGET)
    sim.joint.publish(JointState(name=NAMES, position=TARGET.tolist(), effort=g.tolist()))
    m = sim.states.wait(lambda m: np.max(np.abs(np.array(m.position) - TARGET)) < 1e-9
                        and settled(m), what="the arm on its targets")
    # at rest on target the servo torque vanishes: the actuator torque is the feed-forward
    np.testing.assert_allclose(m.effort, g, rtol=0, atol=1e-4)


def test_position_targets_alone_sag_by_gravity_over_kp(sim):
    """No feed-forward: at rest Kp (q* - q) = g(q), the torque published is g(q)."""
    sim.joint.publish(JointState(name=NAMES, position=TARGET.tolist()))
    m = sim.states.wait(lambda m: settled(m, 1e-9) and not np.allclose(m.position, TARGET,
                                                                       atol=1e-6),
                        what="the arm at rest below its targets")
    q = np.array(m.position)
    g = ROBOT.gravity_torques(q)
    assert np.max(np.abs(g)) > 1.0                       # a real load: the test can fail
    np.testing.assert_allclose(m.effort, g, rtol=0, atol=1e-5)
    np.testing.assert_allclose(q, TARGET - g / KP, rtol=0, atol=1e-8)


def test_velocity_target_and_a_mix_of_joints(sim):
    """wrist_3 follows a velocity target (Kd only) while the others hold position; then
    a position target for wrist_3 alone brings it back, the others unchanged."""
    g = ROBOT.gravity_torques(TARGET)
    sim.joint.publish(JointState(name=NAMES[:5], position=TARGET[:5].tolist(),
                                 effort=g[:5].tolist()))
    sim.joint.publish(JointState(name=["wrist_3_joint"], velocity=[0.5]))
    m = sim.states.wait(lambda m: abs(m.velocity[5] - 0.5) < 1e-6, what="wrist_3 at 0.5 rad/s")
    assert np.max(np.abs(np.array(m.position[:5]) - TARGET[:5])) < 1e-3
    sim.joint.publish(JointState(name=["wrist_3_joint"], position=[TARGET[5]]))
    sim.states.wait(lambda m: np.max(np.abs(np.array(m.position) - TARGET)) < 1e-6
                    and settled(m, 1e-6), what="the arm back on its targets")
    assert sim.diag.get("divergence events", "0") == "0"
    sim.ros.spin_until(lambda: sim.diag.get("servoed joints") == "6", 30,
                       "6 servoed joints on /diagnostics")
    assert "paused at the last good state" not in sim.proc.output()


def test_reset_clears_the_servo(sim):
    assert sim.ros.call(sim.pause, SetBool.Request(data=True)).success
    assert sim.ros.call(sim.reset, Trigger.Request()).success
    sim.states.wait(lambda m: list(m.position) == HOME and not any(m.effort), what="the reset")
    sim.ros.spin_until(lambda: sim.diag.get("servoed joints") == "0", 30,
                       "no servoed joint on /diagnostics")


def test_targets_are_refused_by_an_integrator_without_the_servo(ros):
    proc = ros.start("simulator", {"integrator": "rk4", "start_paused": True},
                     ros_args=["-r", "__ns:=/srv_rk4"])
    states = Latest(ros, JointState, "/srv_rk4/joint_states")
    pub = ros.node.create_publisher(JointState, "/srv_rk4/joint_commands", 10)
    try:
        ros.wait_matched(pub, also=lambda: states.msgs, what="the simulator")
        pub.publish(JointState(name=NAMES, position=TARGET.tolist()))
        wait_for_log(ros, proc, "targets need an integrator with the implicit servo")
        pub.publish(JointState(name=["elbow_joint"], effort=[3.0]))     # effort still works
        states.wait(lambda m: m.effort[2] == 3.0, what="the effort command applied")
        assert proc.running()
    finally:
        states.destroy()
        proc.stop()
