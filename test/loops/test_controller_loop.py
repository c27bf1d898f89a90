"""The computed-torque controller's loop without ROS (serial_dynamics/loops/controller.py),
driven by the test's clock: the reference it holds and follows, the error taken at the
state's stamp, the modes, refusals and what it reports, against the library's numbers."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import control
from serial_dynamics.loops.controller import MAX_STATE_AGE, Controller, check_mode
from serial_dynamics.model.errors import Rejected

ROBOT = sd.default_robot()
KP, KD, H = np.full(6, 400.0), np.full(6, 40.0), 0.002
Q = np.array([0.1, -1.2, 1.4, -1.5, -1.5, 0.2])
QD = np.array([0.3, -0.2, 0.1, 0.0, 0.4, -0.1])


def controller(**kw):
    return Controller(ROBOT, H, KP, KD, **kw)


def test_no_command_before_a_state_then_it_holds_the_first_position():
    c = controller()
    assert c.torque(10.0) is None
    assert c.set_state(10.0, 10.0, Q, QD) == []
    # e = 0, ed = -qd, no feed-forward: tau = ID(q, qd, -Kd qd), bit for bit
    np.testing.assert_array_equal(c.torque(10.001), ROBOT.inverse_dynamics(Q, QD, -KD * QD))
    c.set_state(10.002, 10.002, Q + 0.01, QD)     # the reference stays at the first state
    np.testing.assert_array_equal(c.desired(50.0)[0], Q)


def test_the_error_is_taken_at_the_state_stamp_and_the_feed_forward_now():
    c = controller()
    c.set_state(1.0, 1.0, Q, np.zeros(6))
    t = np.array([1.0, 2.0])                            # a ramp from the held position
    q = np.vstack([Q + 0.5, Q + 1.0])
    c.set_trajectory(1.0, t, q)
    c.set_state(1.4, 1.45, Q, np.zeros(6))              # a state stamped 50 ms before now
    tau = c.torque(1.45)
    q_ref, qd_ref, _ = c.desired(1.4)
    qdd_ff = c.desired(1.45)[2]
    expected = ROBOT.inverse_dynamics(Q, np.zeros(6), qdd_ff + KP * (q_ref - Q) + KD * qd_ref)
    np.testing.assert_array_equal(tau, expected)
    assert np.all(q_ref > Q) and not np.array_equal(c.desired(1.45)[0], q_ref)


@pytest.mark.parametrize("stamp", [0.0, 5.0 - 2 * MAX_STATE_AGE, 5.0 + 2 * MAX_STATE_AGE])
def test_a_missing_or_far_stamp_is_taken_as_now(stamp):
    c = controller()
    c.set_state(stamp, 5.0, Q, QD)
    assert c.state[0] == 5.0


def test_a_trajectory_starts_from_the_current_reference_and_holds_its_last_point():
    c = controller()
    c.set_state(2.0, 2.0, Q, np.zeros(6))
    goal = Q + np.linspace(0.1, 0.6, 6)
    c.set_trajectory(3.0, [1.0], goal[None])            # one point, 1 s after the start
    np.testing.assert_array_equal(c.desired(3.0)[0], Q)
    np.testing.assert_allclose(c.desired(4.0)[0], goal, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(c.desired(100.0)[0], c.desired(4.0)[0])


def test_refusals_keep_what_was_in_force():
    c = controller()
    with pytest.raises(Rejected) as no_state:
        c.set_trajectory(0.0, [1.0], Q[None])
    assert no_state.value.cause == "no joint state yet" and c.reference is None
    c.set_state(1.0, 1.0, Q, QD)
    before = c.reference
    with pytest.raises(Rejected) as acc:
        c.set_trajectory(1.0, [1.0], Q[None], None, np.zeros((1, 6)))
    assert acc.value.cause == "accelerations without velocities" and c.reference is before
    with pytest.raises(Rejected) as close:                     # times that go back
        c.set_trajectory(1.0, [1.0, 0.5], np.vstack([Q, Q + 1]))
    assert close.value.cause == "waypoints" and c.reference is before


def test_gravity_compensation_follows_the_arm_refuses_trajectories_and_hands_back_a_hold():
    c = controller()
    c.set_state(1.0, 1.0, Q, QD)
    assert c.set_mode("gravity_compensation") and not c.set_mode("gravity_compensation")
    np.testing.assert_array_equal(c.torque(1.0), ROBOT.gravity_torques(Q))
    with pytest.raises(Rejected) as gc:
        c.set_trajectory(1.0, [1.0], Q[None])
    assert gc.value.cause == "gravity_compensation"
    moved = Q + 0.3
    c.set_state(1.5, 1.5, moved, np.zeros(6))
    assert c.set_mode("pd_gravity")
    np.testing.assert_array_equal(c.desired(9.0)[0], moved)   # holds where it was left
    kp, kd = control.pd_gains(ROBOT, moved, KP, KD)
    np.testing.assert_array_equal(c.torque(1.5), ROBOT.gravity_torques(moved))   # e = 0
    assert np.all(kp > 0) and np.all(kd > 0)
    with pytest.raises(ValueError, match="must be one of computed_torque, pd_gravity, "
                                         "gravity_compensation; got 'impedance'"):
        c.set_mode("impedance")
    assert c.mode == "pd_gravity"


def test_the_modes_are_control_modes():
    assert [m for m in control.MODES if check_mode(m) is None] == list(control.MODES)
    assert check_mode("torque") is not None


def test_a_non_finite_command_is_refused_with_its_cause():
    c = Controller(ROBOT, H, np.full(6, 1e306), KD)
    c.set_state(1.0, 1.0, np.full(6, -1e5), np.zeros(6))
    c.set_trajectory(1.0, [0.0], np.full((1, 6), 1e5))    # at once: e = 2e5, Kp e = inf
    with pytest.raises(Rejected) as refused:
        c.torque(1.0)
    assert refused.value.cause == "not finite" and c.error_max is None


def test_the_report_counts_since_the_last_one_and_names_saturated_joints():
    c = controller()
    c.set_state(1.0, 1.0, Q, np.zeros(6))
    c.set_trajectory(1.0, [0.5], (Q + [0.0, 0.0, 0.0, 0.0, 0.0, 2.0])[None])
    c.set_state(1.2, 1.2, Q, np.zeros(6))
    tau = c.torque(1.2)
    values, notes = c.report()
    values = {v[0]: v[1:] for v in values}
    e = c.desired(1.2)[0] - Q
    assert values["tracking error max (rad)"][0] == f"{np.max(np.abs(e)):.6g}"
    saturated = [ROBOT.joint_names[j] for j in np.flatnonzero(np.abs(tau) > ROBOT.effort_limit)]
    assert values["saturated joints"] == (", ".join(saturated) or "none", bool(saturated))
    assert values["mode"] == ("computed_torque",) and notes == []
    again = {v[0]: v[1:] for v in c.report()[0]}
    assert again["tracking error max (rad)"] == ("no command",)


def test_gains_beyond_the_bound_are_noted_once_per_joint():
    c = Controller(ROBOT, 0.01, np.full(6, 400.0), np.full(6, 250.0))   # 2 kd h = 5 > 4
    notes = c.startup_notes()
    assert [key for key, _ in notes] == [("bound", "kp, kd (computed_torque)", j)
                                         for j in range(6)]
    assert "Scale both by less than" in notes[0][1]
    pd = Controller(ROBOT, 0.01, KP, KD, pd_kp=np.full(6, 1e6), pd_kd=np.full(6, 1.0))
    assert pd.startup_notes() == []
    notes = pd.set_state(1.0, 1.0, Q, QD)          # pd_gravity's, at the first state
    assert [key for key, _ in notes] == [("bound", "pd.kp, pd.kd (pd_gravity)", j)
                                         for j in range(6)]
    assert pd.set_state(1.1, 1.1, Q, QD) == []     # checked again at each report only
