"""``constrained_forward_dynamics`` (contacts/constrained.py, contacts/jacobians.py) against
Pinocchio 4's ``constraintDynamics`` (RigidConstraintModel CONTACT_3D and CONTACT_6D,
LOCAL_WORLD_ALIGNED, ProximalSettings at 1e-14 with mu 0): Solo12 floating with its four
feet in point contact, the fixed Panda with its hand in frame contact, loops between two
links, Baumgarte's terms; and the identities that need no oracle: M a + b = tau + J^T f,
every contact's acceleration zero (from ``frame_acceleration``), redundant and
over-constraining sets."""
import numpy as np
import pytest

from contact_cases import FEET, Panda, Solo, pin_constrained, rel_err
from pin_reference import pin

import serial_dynamics as sd

RTOL = 1e-9


@pytest.fixture(scope="module")
def solo():
    return Solo()


@pytest.fixture(scope="module")
def panda():
    return Panda()


def contact_acceleration(robot, q, v, a, c):
    """The acceleration the contact's constraint reads, from the facade's frame_acceleration
    alone (classical for a point, d/dt of the twist in the link's frame for a frame)."""
    X, J = robot.forward_kinematics(q, c.link), robot.jacobian(q, c.link)
    A = robot.frame_acceleration(q, v, a, c.link)
    r = X[:3, :3] @ np.array(c.point)
    w, vo = J[3:] @ v, J[:3] @ v
    if not c.frame:        # a + alpha x r + w x (w x r)
        return A[:3] + np.cross(A[3:], r) + np.cross(w, np.cross(w, r))
    return np.concatenate([A[:3] + np.cross(A[3:], r) - np.cross(w, vo), A[3:]])


def held(robot, q, v, tau, a, contacts):
    """Every contact's acceleration zero, relative to the accelerations the contacts would
    have without them (at a0 = forward_dynamics: the right-hand side the solver meets)."""
    a0 = robot.forward_dynamics(q, v, tau)
    for c in contacts:
        scale = max(1.0, np.max(np.abs(contact_acceleration(robot, q, v, a0, c))))
        assert np.max(np.abs(contact_acceleration(robot, q, v, a, c))) < RTOL * scale


def identities(robot, q, v, tau, contacts, a, f):
    """M a + b = tau + J^T f, with J the contacts' stacked Jacobian from jacobian()."""
    tau = np.r_[np.zeros(robot.nv - len(tau)), tau]
    Jtf = np.zeros(robot.nv)
    for c, fc in zip(contacts, f):
        X, J = robot.forward_kinematics(q, c.link), robot.jacobian(q, c.link)
        r = X[:3, :3] @ np.array(c.point)
        Jp = J[:3] - np.cross(r, J[3:].T).T                  # the point's velocity rows
        Jtf += Jp.T @ fc[:3] + (J[3:].T @ fc[3:] if c.frame else 0)
    lhs = robot.mass_matrix(q) @ a + robot.bias_torques(q, v)
    assert rel_err(lhs, tau + Jtf) < RTOL


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_solo12_four_feet_in_point_contact_agree_with_pinocchio(solo, seed):
    rng = np.random.default_rng(seed)
    robot = solo.robot
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, robot.dof)
    contacts = [sd.Contact(foot, point=(0.01, -0.02, 0.015)) for foot in FEET]
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
    pa, pf = pin_constrained(solo, q, v, np.r_[np.zeros(6), tau], contacts)
    assert f.shape == (4, 3)
    assert rel_err(a, pa) < RTOL and rel_err(f.ravel(), pf) < RTOL
    identities(robot, q, v, tau, contacts, a, f)
    held(robot, q, v, tau, a, contacts)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_fixed_arm_with_its_hand_in_frame_contact_agrees_with_pinocchio(panda, seed):
    rng = np.random.default_rng(seed)
    robot = panda.robot
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, robot.dof)
    contacts = [sd.Contact("panda_hand", point=(0.0, 0.02, 0.1), frame=True)]
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
    pa, pf = pin_constrained(panda, q, v, tau, contacts)
    assert f.shape == (1, 6)
    assert rel_err(a, pa) < RTOL and rel_err(f.ravel(), pf) < RTOL
    identities(robot, q, v, tau, contacts, a, f)
    held(robot, q, v, tau, a, contacts)


@pytest.mark.parametrize("frame", [True, False])
def test_a_loop_between_two_links_agrees_with_pinocchio(solo, frame):
    """Two links of the tree held together (a frame: Pinocchio's two-joint CONTACT_6D; a
    point: the point of one on the anchor point of the other), mixed with a foot. Against
    Pinocchio's LOCAL frames (forces in the link's axes, turned here into the world's): a
    frame loop's constraint is the time derivative of the relative twist in the link's frame,
    which LOCAL_WORLD_ALIGNED takes without the cross term of the two twists."""
    rng = np.random.default_rng(11)
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, solo.robot.dof)
    contacts = [sd.Contact("FL_FOOT", point=(0.0, 0.01, 0.02), frame=frame, other_link="FR_FOOT",
                           anchor=None if frame else (0.01, 0.0, -0.03)),
                sd.Contact("HL_FOOT")]
    a, f = solo.robot.constrained_forward_dynamics(q, v, tau, contacts)
    pa, pf = pin_constrained(solo, q, v, np.r_[np.zeros(6), tau], contacts,
                             ref=pin.ReferenceFrame.LOCAL)
    R1, R2 = (solo.robot.forward_kinematics(q, c.link)[:3, :3] for c in contacts)
    k = contacts[0].size
    theirs = np.r_[R1 @ pf[:3], R1 @ pf[3:6] if frame else [], R2 @ pf[k:]]
    ours = np.r_[f[0, :k], f[1, :3]]
    assert rel_err(a, pa) < RTOL and rel_err(ours, theirs) < RTOL


def test_baumgarte_terms_agree_with_pinocchio(solo, panda):
    """J a + J-dot v = -kd J v - kp e: anchored point feet (e their offset from the anchor)
    and an anchored hand frame (e = log6 of the pose error, Pinocchio's)."""
    rng = np.random.default_rng(5)
    gains = (40.0, 9.0)
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, solo.robot.dof)
    contacts = [sd.Contact(foot, anchor=rng.uniform(-1, 1, 3)) for foot in FEET[:3]]
    a, f = solo.robot.constrained_forward_dynamics(q, v, tau, contacts, baumgarte=gains)
    pa, pf = pin_constrained(solo, q, v, np.r_[np.zeros(6), tau], contacts, gains)
    assert rel_err(a, pa) < RTOL and rel_err(f.ravel(), pf) < RTOL
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, panda.robot.dof)
    anchor = pin.SE3.Random().homogeneous
    contacts = [sd.Contact("panda_hand", point=(0.0, 0.0, 0.1), frame=True, anchor=anchor)]
    a, f = panda.robot.constrained_forward_dynamics(q, v, tau, contacts, baumgarte=gains)
    pa, pf = pin_constrained(panda, q, v, tau, contacts, gains)
    assert rel_err(a, pa) < RTOL and rel_err(f.ravel(), pf) < RTOL


def test_a_redundant_set_is_answered_with_the_minimum_norm_forces(solo):
    """Four feet welded flat (24 rows on 18 velocities) at rest: consistent, so answered, and
    the forces are the minimum-norm ones: orthogonal to the null space of J^T."""
    rng = np.random.default_rng(2)
    robot = solo.robot
    q, _ = solo.state(rng)
    v, tau = np.zeros(robot.nv), rng.uniform(-2, 2, robot.dof)
    contacts = [sd.Contact(foot, frame=True) for foot in FEET]
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
    identities(robot, q, v, tau, contacts, a, f)
    held(robot, q, v, tau, a, contacts)
    J = np.vstack([robot.jacobian(q, c.link) for c in contacts])     # the rows at each origin
    null = np.linalg.svd(J.T)[2][np.linalg.matrix_rank(J):]           # J^T x = 0
    assert null.shape[0] == 24 - np.linalg.matrix_rank(J) > 0
    assert np.max(np.abs(null @ f.ravel())) < 1e-7 * np.max(np.abs(f))


def test_an_over_constraining_set_is_refused_with_the_reason(panda):
    """Two frame contacts on a 7-joint arm (12 rows): moving, no motion meets them (refused,
    naming the rows and the rank); at rest they hold it still (answered: a = 0)."""
    robot = panda.robot
    rng = np.random.default_rng(4)
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, robot.dof)
    contacts = [sd.Contact("panda_link4", frame=True), sd.Contact("panda_hand", frame=True)]
    with pytest.raises(ValueError, match=r"12 constraint rows of rank 7 on 7 velocities.*"
                                         r"over-constrains"):
        robot.constrained_forward_dynamics(q, v, tau, contacts)
    a, f = robot.constrained_forward_dynamics(q, np.zeros(7), tau, contacts)
    assert np.max(np.abs(a)) < 1e-9
    identities(robot, q, np.zeros(7), tau, contacts, a, f)


def test_a_batch_is_row_by_row_and_the_base_may_take_every_force(solo):
    robot = solo.robot
    rng = np.random.default_rng(8)
    states = [solo.state(rng) for _ in range(3)]
    Q, V = np.array([s[0] for s in states]), np.array([s[1] for s in states])
    T = rng.uniform(-1, 1, (3, robot.dof))
    contacts = [sd.Contact(foot) for foot in FEET]
    A, F = robot.constrained_forward_dynamics(Q, V, T, contacts)
    assert A.shape == (3, robot.nv) and F.shape == (3, 4, 3)
    for i in range(3):
        a, f = robot.constrained_forward_dynamics(Q[i], V[i], T[i], contacts)
        assert np.array_equal(a, A[i]) and np.array_equal(f, F[i])
    # generalized forces (n + 6,) with zero base rows are joint torques (n,)
    a6, f6 = robot.constrained_forward_dynamics(Q[0], V[0], np.r_[np.zeros(6), T[0]], contacts)
    assert np.array_equal(a6, A[0]) and np.array_equal(f6, F[0])


@pytest.mark.parametrize("floating", [False, True])
def test_mimic_joints_take_the_reduced_coordinates(floating):
    """The Panda with its fingers (a mimic pair), fixed or floating (its base then welded by
    a frame contact): a fingertip in point contact, checked by the identities in the
    independent coordinates."""
    from pin_reference import erd
    robot = sd.load_urdf(erd("panda_description/urdf/panda.urdf"), floating_base=floating)
    assert robot.model.has_mimic_joints and robot.is_floating == floating
    rng = np.random.default_rng(3)
    q, v = robot.random_state(rng)
    tau = rng.uniform(-2, 2, robot.dof)
    contacts = [sd.Contact("panda_leftfinger", point=(0.0, 0.01, 0.04)),
                sd.Contact("panda_link0", frame=True) if floating else
                sd.Contact("panda_link4", point=(0.05, 0.0, 0.0))]
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
    identities(robot, q, v, tau, contacts, a, f)
    held(robot, q, v, tau, a, contacts)
