"""``sim.Session``, without ROS: the steps are FixedStepIntegrator's bits under the commands
held; edits land at the next step; reset, pause, forced steps; divergence pauses at the last
good state and says why; a lost command stream goes limp or brakes (within the effort
limits); a new plant; a floating base and a mimic chain through the same calls."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.session import Session

HOME = np.array([0.0, -1.571, 1.571, -1.571, -1.571, 0.0])


@pytest.fixture(scope="module")
def ur5e():
    return sd.default_robot()


def test_steps_are_the_integrators_under_the_held_command(ur5e):
    s = Session(ur5e, HOME, position_limits=True, effort_limits=ur5e.effort_limit)
    integ = FixedStepIntegrator(ur5e, "semi_implicit_euler", 1e-3, True, position_limits=True)
    tau = np.array([1.0, 2.0, 1.0, 0.5, 0.25, 0.1])
    assert s.command(np.arange(6), tau) is None
    q, v = HOME, np.zeros(6)
    for _ in range(20):
        assert s.step() == (True, [])
        q, v = integ.step(q, v, tau)
    k, qs, vs, applied, pose, twist = s.snapshot()
    assert k == 20 and s.time == pytest.approx(0.02) and pose is None and twist is None
    np.testing.assert_array_equal(qs, q)
    np.testing.assert_array_equal(vs, v)
    np.testing.assert_array_equal(applied, tau)
    # an effort beyond the limit is clamped, and the joint named
    j, asked = s.command([2], [1e6])
    assert (j, asked) == (2, 1e6) and s.hold.tau[2] == ur5e.effort_limit[2]


def test_edits_land_at_the_next_step_and_reset_pause_step(ur5e):
    s = Session(ur5e, HOME, paused=True)
    s.set_state(np.array([1, 3]), np.array([-1.0, -1.2]), np.array([0.5, 0.0]))
    assert s.step() == (True, []) and s.k == 0               # paused: nothing moves
    np.testing.assert_array_equal(s.q, HOME)                  # the edit waits for a step
    assert s.step(force=True)[0] and s.k == 1
    assert s.q[1] == pytest.approx(-1.0 + 1e-3 * s.qd[1]) and s.q[3] == pytest.approx(-1.2 + 1e-3 * s.qd[3])
    s.pause(False)
    assert s.step()[0] and s.k == 2
    s.reset()
    np.testing.assert_array_equal(s.q, HOME)
    assert not np.any(s.qd) and s.pending is None


def test_divergence_pauses_at_the_last_good_state_and_says_why(ur5e):
    s = Session(ur5e, HOME, dissipation=False)
    s.command(np.arange(6), np.full(6, 1e12))                 # no limits: a kick to infinity
    ok, notes, last = True, [], None
    while ok and s.k < 100:
        last = s.q.copy()
        ok, notes = s.step()
    assert not ok and s.paused and s.divergences == 1
    level, text = notes[-1]
    assert level == "error" and "diverged" in text and "paused at the last good state" in text
    np.testing.assert_array_equal(s.q, last)
    assert np.all(np.isfinite(s.q))


@pytest.mark.parametrize("action", ["limp", "brake"])
def test_a_lost_command_stream(ur5e, action):
    """The arm held at HOME by its gravity torques; the commands stop: after 50 ms limp lets
    it fall, brake holds it at the positions of the timeout."""
    limits = np.full(6, 150.0)
    s = Session(ur5e, HOME, command_timeout=0.05, command_timeout_action=action,
                effort_limits=limits)
    s.command(np.arange(6), ur5e.gravity_torques(HOME))
    notes = []
    for _ in range(1000):
        notes += s.step()[1]
    assert [t for t in notes if "command_timeout" in t[1]] == [notes[0]] and len(notes) == 1
    k, q, v, applied, _, _ = s.snapshot()
    if action == "limp":
        assert "back to zero" in notes[0][1] and not np.any(applied)
        assert np.max(np.abs(q - HOME)) > 0.1                    # it fell
    else:
        assert "braking" in notes[0][1]
        assert np.max(np.abs(q - HOME)) < 1e-2 and np.max(np.abs(v)) < 1e-3
        np.testing.assert_allclose(applied, ur5e.gravity_torques(q), atol=1.0)
        # a command releases the brake
        s.command(np.arange(6), np.zeros(6))
        s.step()
        assert s.hold.servo is None and not s.braking


def test_the_brake_stays_within_the_effort_limits(ur5e):
    limits = np.full(6, 5.0)                        # too weak to hold the arm: it sags
    s = Session(ur5e, HOME, command_timeout=0.01, command_timeout_action="brake",
                effort_limits=limits)
    s.command(np.arange(6), np.zeros(6))
    peak = 0.0
    for _ in range(300):
        assert s.step()[0]
        peak = max(peak, np.max(np.abs(s.snapshot()[3])))
    assert s.braking and 4.9 < peak <= 5.0


def test_a_new_plant_between_two_steps(ur5e):
    s = Session(ur5e, HOME)
    heavy = ur5e.with_payload(2.0, [0.0, 0.0, 0.05])
    s.set_robot(heavy)
    s.step()
    q, v = FixedStepIntegrator(heavy, "semi_implicit_euler", 1e-3, True).step(HOME, np.zeros(6),
                                                                              np.zeros(6))
    np.testing.assert_array_equal(s.snapshot()[1], q)


def test_a_floating_base_and_a_mimic_chain_through_the_same_calls():
    sat = sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))
    pose = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0])
    s = Session(sat, np.zeros(sat.dof), base_pose=pose, command_timeout_action="brake")
    assert s.timeout_action == "brake"               # the servo on a floating base too
    s.set_base_state(pose, np.array([0.1, 0, 0, 0, 0, 0.2]))
    s.set_state(np.array([0]), np.array([0.3]), np.array([0.0]))
    s.step()
    k, q, v, tau, p, tw = s.snapshot()
    assert q.shape == (sat.dof,) and p.shape == (7,) and tw.shape == (6,)
    assert p[0] == pytest.approx(1.0 + 1e-3 * 0.1) and q[0] == pytest.approx(0.3)
    # a lost command stream on the floating base: the brake stops the swinging arm
    s = Session(sat, np.zeros(sat.dof), base_pose=pose, command_timeout=0.05,
                command_timeout_action="brake", dissipation=False)
    s.command(np.arange(sat.dof), np.diag(sat.mass_matrix(sat.neutral()))[6:])
    notes = sum((s.step()[1] for _ in range(50)), [])
    swing = np.max(np.abs(s.snapshot()[2]))                  # the joints' speed at the timeout
    notes += sum((s.step()[1] for _ in range(550)), [])
    assert len(notes) == 1 and "braking" in notes[0][1] and s.braking
    k, q, v, applied, p, tw = s.snapshot()
    assert swing > 0.05 and np.max(np.abs(v)) < 0.02 * swing       # moving, then held
    np.testing.assert_allclose(applied, s.integrator.servo_torque, rtol=0, atol=0)
    from test_mimic import mimic_chain
    mim = sd.load_urdf(mimic_chain())
    s = Session(mim, np.full(mim.dof, 0.2), dissipation=False)
    s.command(np.arange(mim.dof), mim.gravity_torques(np.full(mim.dof, 0.2)))
    for _ in range(50):
        s.step()
    np.testing.assert_allclose(s.snapshot()[1], 0.2, atol=1e-12)
    with pytest.raises(ValueError, match="command_timeout_action 'stop' unknown"):
        Session(mim, np.zeros(mim.dof), command_timeout_action="stop")
