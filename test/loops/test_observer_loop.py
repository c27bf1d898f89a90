"""The external-torque observer's loop without ROS (serial_dynamics/loops/observer.py): the
stamps it refuses, the restarts on a jump, the collision flag with hysteresis, against
MomentumObserver's own numbers."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.loops.observer import CollisionMonitor
from serial_dynamics.model.errors import Rejected
from serial_dynamics.observers import MomentumObserver

ROBOT = sd.default_robot()
Q = np.array([0.1, -1.2, 1.4, -1.5, -1.5, 0.2])
ZERO = np.zeros(6)
PUSH = np.array([0.0, 0.0, 6.0, 0.0, 0.0, 0.0])    # N m at the elbow the model does not explain
THRESHOLDS = np.full(6, 3.0)


def monitor(**kw):
    return CollisionMonitor(ROBOT, 50.0, THRESHOLDS, **{"release": 0.5, "max_gap": 0.1, **kw})


def test_the_estimates_are_the_momentum_observer_s():
    m, ref = monitor(), MomentumObserver(ROBOT, 50.0)
    tau = ROBOT.gravity_torques(Q) - PUSH              # the actuators hold against the push
    for k in range(1, 150):                            # 3 time constants
        s = m.update(1.0 + 1e-3 * k, Q, ZERO, tau)
        r = ref.update(1.0 + 1e-3 * k, Q, ZERO, tau)
        np.testing.assert_array_equal(s.tau_ext, r)
        np.testing.assert_array_equal(s.wrench, ref.wrench(Q, r)[0])
    assert abs(s.tau_ext[2] - PUSH[2]) < 0.05 and np.all(np.abs(np.delete(s.tau_ext, 2)) < 0.05)


def test_collision_flagged_past_the_threshold_and_cleared_below_the_release():
    m = monitor()
    g = ROBOT.gravity_torques(Q)
    events, flags = [], []
    t = 1.0
    for k in range(400):
        push = PUSH if k < 200 else ZERO
        t += 1e-3
        s = m.update(t, Q, ZERO, g - push)
        flags.append(s.collision)
        if s.event:
            events.append((k, s.event, abs(s.tau_ext[2])))
    (k_on, on, r_on), (k_off, off, r_off) = events
    assert on.startswith("collision: estimated external torque") and "elbow_joint" in on
    assert r_on > 3.0 and off == "collision cleared" and r_off < 1.5
    assert 0 < k_on < 200 < k_off and flags == [k_on <= k < k_off for k in range(400)]
    # e^-Kt: the estimate of a 6 N m step passes 3 N m after ln 2 / 50 s (14 ms)
    assert abs(k_on - np.log(2) / 50.0 / 1e-3) <= 2


def test_zero_and_repeated_stamps_are_refused_and_jumps_restart():
    m = monitor()
    g = ROBOT.gravity_torques(Q)
    with pytest.raises(Rejected) as zero:
        m.update(0.0, Q, ZERO, g)
    assert zero.value.cause == "zero stamp"
    for k in range(1, 20):
        s = m.update(2.0 + 1e-3 * k, Q, ZERO, g - PUSH)
    with pytest.raises(Rejected) as repeated:
        m.update(2.0 + 1e-3 * 19, Q, ZERO, g)
    assert repeated.value.cause == "stamp repeated"
    assert np.any(s.tau_ext != 0)
    for t, way in ((0.5, "back"), (0.5 + 0.2, "forward")):
        s = m.update(t, Q, ZERO, g - PUSH)
        assert np.all(s.tau_ext == 0.0)                 # from the current momentum
        (key, text, repeats), = s.notes
        assert key == ("restart", way) and f"jumped {way}" in text and "{}" in repeats
    assert m.restarts == 2 and m.update(0.701, Q, ZERO, g - PUSH).notes == []


def test_a_new_model_starts_a_new_estimate():
    m = monitor()
    m.update(1.0, Q, ZERO, ROBOT.gravity_torques(Q))
    heavier = ROBOT.with_payload(2.0, (0.0, 0.0, 0.05))
    m.set_robot(heavier)
    assert m.robot is heavier and m.observer.t is None
    s = m.update(1.001, Q, ZERO, heavier.gravity_torques(Q))
    assert s.notes == [] and np.all(s.tau_ext == 0.0)


@pytest.mark.parametrize("kw, word", [
    (dict(thresholds=[0.0] * 6), "collision_thresholds"), (dict(max_gap=0.0), "max_sample_gap"),
    (dict(release=1.5), "collision_release"), (dict(gain=-1.0), "gain")])
def test_parameters_out_of_range_are_refused(kw, word):
    args = {**dict(robot=ROBOT, gain=50.0, thresholds=THRESHOLDS), **kw}
    with pytest.raises(ValueError, match=word):
        CollisionMonitor(**args)
