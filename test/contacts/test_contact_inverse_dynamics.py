"""``contact_inverse_dynamics`` (contacts/inverse.py, contacts/friction.py): Solo12 standing
on its four feet (base rows of tau zero, M a + b = tau + J^T f, the forces' vertical sum the
weight; with friction 0.7 every force in its cone), a round trip through the constrained
forward dynamics, what cannot be realised (no force distribution, a robot that would slip or
tip), and a fixed base (every joint actuated: no force needed)."""
import numpy as np
import pytest

from contact_cases import FEET, Panda, Solo, rel_err

import serial_dynamics as sd

RTOL = 1e-9


@pytest.fixture(scope="module")
def solo():
    return Solo(gravity=np.array([0.0, 0.0, -9.81]))


def standing(solo):
    """Solo12 with its knees bent (front legs forward, hind legs back), base level, still."""
    robot = solo.robot
    legs = np.r_[np.tile([0.0, 0.8, -1.6], 2), np.tile([0.0, -0.8, 1.6], 2)]
    q = np.r_[0.2, -0.1, 0.3, 0.0, 0.0, np.sin(0.2), np.cos(0.2), legs]
    return q, np.zeros(robot.nv), np.zeros(robot.nv)


def weight(robot):
    return 9.81 * (robot.model.base_mass + robot.model.mass.sum())


def check(robot, q, v, a, contacts, tau, f):
    """Base rows zero and M a + b = tau + J^T f (J from jacobian(), forces at the points)."""
    assert np.array_equal(tau[:6], np.zeros(6))
    Jtf = sum(robot.jacobian(q, c.link)[:3].T @ fc for c, fc in zip(contacts, f))
    assert rel_err(robot.mass_matrix(q) @ a + robot.bias_torques(q, v), tau + Jtf) < RTOL


def in_cones(f, mu, normal=(0.0, 0.0, 1.0)):
    fn = f @ np.asarray(normal)
    ft = np.linalg.norm(f - fn[:, None] * np.asarray(normal), axis=1)
    return np.all(fn > 0) and np.all(ft <= mu * fn + 1e-9 * np.max(np.abs(f)))


def test_standing_solo12_carries_its_weight(solo):
    robot = solo.robot
    q, v, a = standing(solo)
    contacts = [sd.Contact(foot) for foot in FEET]
    tau, f = robot.contact_inverse_dynamics(q, v, a, contacts)
    check(robot, q, v, a, contacts, tau, f)
    assert abs(f[:, 2].sum() - weight(robot)) < RTOL * weight(robot)
    assert np.max(np.abs(f[:, :2].sum(axis=0))) < RTOL * weight(robot)


def test_with_friction_every_force_is_inside_its_cone(solo):
    """Standing, and with the base accelerating (a turn the minimum-norm forces meet only by
    leaving a cone): the friction ones are inside every cone, and balance."""
    robot = solo.robot
    q, v, a = standing(solo)
    contacts = [sd.Contact(foot) for foot in FEET]
    turn = np.r_[1.4, -2.3, -2.8, -19.3, 12.5, 16.5, np.zeros(robot.dof)]
    assert not in_cones(robot.contact_inverse_dynamics(q, v, turn, contacts)[1], 0.7)
    for a in (np.zeros(robot.nv), turn):
        tau, f = robot.contact_inverse_dynamics(q, v, a, contacts, friction=0.7)
        check(robot, q, v, a, contacts, tau, f)
        assert in_cones(f, 0.7)
    tau, f = robot.contact_inverse_dynamics(q, v, np.zeros(robot.nv), contacts, friction=0.7)
    assert abs(f[:, 2].sum() - weight(robot)) < RTOL * weight(robot)


def test_a_round_trip_through_the_constrained_dynamics(solo):
    """a from constrained_forward_dynamics with tau: contact_inverse_dynamics gives the same
    forces and tau back where the forces are unique (one foot flat: 6 for the 6 base rows)."""
    robot = solo.robot
    rng = np.random.default_rng(1)
    q, v = solo.state(rng)
    contacts = [sd.Contact("FL_FOOT", point=(0.0, 0.0, -0.01), frame=True)]
    tau = rng.uniform(-1, 1, robot.dof)
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
    tau2, f2 = robot.contact_inverse_dynamics(q, v, a, contacts)
    assert rel_err(f2, f) < RTOL and rel_err(tau2[6:], tau) < RTOL


def test_no_force_distribution_is_refused_naming_the_contacts(solo):
    robot = solo.robot
    q, v, a = standing(solo)
    with pytest.raises(ValueError, match=r"\['FL_FOOT'\] cannot exert the base wrench.*"
                                         r"span 3 of its 6 directions"):
        robot.contact_inverse_dynamics(q, v, a, [sd.Contact("FL_FOOT")])


def test_a_robot_that_would_slip_or_tip_is_refused_naming_the_contacts(solo):
    robot = solo.robot
    q, v, _ = standing(solo)
    contacts = [sd.Contact(foot) for foot in FEET]
    sideways = np.r_[0.0, 8.0, 0.0, 0.0, 0.0, 0.0, np.zeros(robot.dof)]    # 8 m/s^2 sideways
    with pytest.raises(ValueError, match=r"friction cones \(friction 0.2\).*Would slip.*FL_FOOT"):
        robot.contact_inverse_dynamics(q, v, sideways, contacts, friction=0.2)
    falling = np.r_[0.0, 0.0, -20.0, 0.0, 0.0, 0.0, np.zeros(robot.dof)]   # faster than g
    with pytest.raises(ValueError, match=r"would lift off.*FL_FOOT.*FR_FOOT.*HL_FOOT.*HR_FOOT"):
        robot.contact_inverse_dynamics(q, v, falling, contacts, friction=0.7)
    # on the two left feet the center of mass is off the line through them: it tips over
    with pytest.raises(ValueError, match=r"friction cones"):
        robot.contact_inverse_dynamics(q, v, np.zeros(robot.nv),
                                       [sd.Contact(f) for f in FEET[::2]], friction=0.7)


def test_a_fixed_base_needs_no_contact_force():
    panda = Panda()
    robot = panda.robot
    rng = np.random.default_rng(0)
    q, v = robot.random_state(rng)
    a = rng.uniform(-1, 1, robot.dof)
    contacts = [sd.Contact("panda_hand", frame=True)]
    for friction in (None, 0.5):
        tau, f = robot.contact_inverse_dynamics(q, v, a, contacts, friction=friction)
        assert np.array_equal(f, np.zeros((1, 6)))
        assert rel_err(tau, robot.inverse_dynamics(q, v, a)) < RTOL


def test_a_batch_is_row_by_row(solo):
    robot = solo.robot
    q, v, a = standing(solo)
    A = np.array([a, a + 0.1])
    contacts = [sd.Contact(foot) for foot in FEET]
    T, F = robot.contact_inverse_dynamics(q, v, A, contacts)
    assert T.shape == (2, robot.nv) and F.shape == (2, 4, 3)
    tau, f = robot.contact_inverse_dynamics(q, v, A[1], contacts)
    assert np.array_equal(T[1], tau) and np.array_equal(F[1], f)
