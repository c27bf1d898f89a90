"""The compiled single-state path of ``constrained_forward_dynamics`` (contacts/compiled.py)
against the NumPy reference path (``constrained._one``) on the same robot: the tests' cases
(Solo12's feet in point contact, the Panda's hand in frame contact, a redundant set,
Baumgarte's terms, loops), each kind of robot that has a kernel (a chain, a tree, a
floating chain, a floating tree), and the refusal of a set that does not converge."""
import warnings

import numpy as np
import pytest

from contact_cases import FEET, Panda, Solo, rel_err
from pin_reference import erd, pin

import serial_dynamics as sd
from serial_dynamics.contacts import compiled, constrained
from serial_dynamics.core import NOT_CONVERGED

RTOL = 1e-12
SETTINGS = (1e-6, 1e-12, 100)        # mu, tolerance, max_iterations: the defaults


@pytest.fixture(scope="module")
def solo():
    return Solo()


@pytest.fixture(scope="module")
def panda():
    return Panda()


def both(robot, q, v, tau, contacts, gains=None):
    """(a, f) of the compiled path (checked to be the one that answered) and of the NumPy
    reference path, for one state."""
    contacts = tuple(contacts)
    kp, kd = (0.0, 0.0) if gains is None else gains
    _, cset = compiled.checked(robot, contacts)
    num = compiled.numbers(*SETTINGS, kp, kd, constrained.DIRECT)
    assert compiled.solve(robot, q, v, tau, cset, num, kp) is not None    # the kernel answered
    a, f = robot.constrained_forward_dynamics(q, v, tau, contacts, baumgarte=gains)
    full = np.r_[np.zeros(robot.nv - len(tau)), tau]
    a0, f0 = constrained._one(robot, q, v, full, contacts, *SETTINGS, kp, kd)
    return (a, f), (a0, f0)


def agree(ours, reference, rtol=RTOL, ftol=RTOL):
    (a, f), (a0, f0) = ours, reference
    assert f.shape == f0.shape
    assert rel_err(a, a0) < rtol and rel_err(f.ravel(), f0.ravel()) < ftol


@pytest.mark.parametrize("point", [(0.0, 0.0, 0.0), (0.01, -0.02, 0.015)])
def test_solo12_feet_in_point_contact(solo, point):
    rng = np.random.default_rng(1)
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, solo.robot.dof)
    agree(*both(solo.robot, q, v, tau, [sd.Contact(f, point=point) for f in FEET]))


def test_the_panda_hand_in_frame_contact(panda):
    rng = np.random.default_rng(2)
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, panda.robot.dof)
    agree(*both(panda.robot, q, v, tau, [sd.Contact("panda_hand", point=(0.0, 0.02, 0.1),
                                                    frame=True)]))


def test_a_redundant_set(solo):
    """Four feet welded flat at rest (24 rows on 18 velocities): the proximal iterations.
    Their forces drift along G's null space by the rounding of r over mu at each step
    (docs/contacts.md: about 1e-10 relative), the accelerations do not."""
    rng = np.random.default_rng(3)
    q, _ = solo.state(rng)
    v, tau = np.zeros(solo.robot.nv), rng.uniform(-2, 2, solo.robot.dof)
    agree(*both(solo.robot, q, v, tau, [sd.Contact(f, frame=True) for f in FEET]),
          rtol=1e-10, ftol=1e-9)


def test_baumgarte_terms(solo, panda):
    rng = np.random.default_rng(4)
    gains = (40.0, 9.0)
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, solo.robot.dof)
    points = [sd.Contact(f, anchor=rng.uniform(-1, 1, 3)) for f in FEET[:3]] + [sd.Contact(FEET[3])]
    agree(*both(solo.robot, q, v, tau, points, gains))
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, panda.robot.dof)
    hand = [sd.Contact("panda_hand", point=(0.0, 0.0, 0.1), frame=True,
                       anchor=pin.SE3.Random().homogeneous)]
    agree(*both(panda.robot, q, v, tau, hand, gains))
    agree(*both(panda.robot, q, v, tau, [sd.Contact("panda_hand", frame=True)], gains))


@pytest.mark.parametrize("frame", [True, False])
@pytest.mark.parametrize("gains", [None, (40.0, 9.0)])
def test_loops_between_two_links(solo, frame, gains):
    rng = np.random.default_rng(5)
    q, v = solo.state(rng)
    tau = rng.uniform(-2, 2, solo.robot.dof)
    contacts = [sd.Contact("FL_FOOT", point=(0.0, 0.01, 0.02), frame=frame, other_link="FR_FOOT",
                           anchor=None if frame else (0.01, 0.0, -0.03)), sd.Contact("HL_FOOT")]
    agree(*both(solo.robot, q, v, tau, contacts, gains))


@pytest.mark.parametrize("kind", ["tree", "floating"])
def test_the_other_kinds_of_robot(kind):
    """A fixed-base tree (Solo12 on a fixed base) and a floating chain (the UR5e): each kind
    has its own kernel (its mass-matrix and Newton-Euler kernels)."""
    rng = np.random.default_rng(6)
    if kind == "tree":
        robot = sd.load_urdf(erd("solo_description/robots/solo12.urdf"))
        contacts = [sd.Contact(f, point=(0.0, 0.0, 0.01)) for f in FEET[:2]]
    else:
        robot = sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True)
        contacts = [sd.Contact("base_link", frame=True), sd.Contact("tool0")]
    assert robot.is_floating == (kind == "floating") and robot.model.is_chain == (kind != "tree")
    q, v = robot.random_state(rng)
    tau = rng.uniform(-2, 2, robot.dof)
    agree(*both(robot, q, v, tau, contacts))
    agree(*both(robot, q, v, tau, contacts, (10.0, 2.0)))


def test_other_argument_types_take_the_same_path_row_by_row(panda):
    """Lists, read-only arrays and batches reach the kernel row by row (the same bits); a
    NaN is refused naming its argument."""
    rng = np.random.default_rng(7)
    robot = panda.robot
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, robot.dof)
    hand = [sd.Contact("panda_hand", frame=True)]
    a, f = robot.constrained_forward_dynamics(q, v, tau, hand)
    frozen = tau.copy()
    frozen.flags.writeable = False
    for args in [(list(q), list(v), list(tau)), (q, v, frozen)]:
        a1, f1 = robot.constrained_forward_dynamics(*args, hand)
        assert np.array_equal(a1, a) and np.array_equal(f1, f)
    with pytest.raises(ValueError, match="v has a NaN"):
        robot.constrained_forward_dynamics(q, np.r_[np.nan, v[1:]], tau, hand)


def test_a_set_that_does_not_converge_is_refused_naming_the_contacts(panda):
    """Two frame contacts on the 7-joint arm, moving: the kernel reports NOT_CONVERGED and
    the call raises the reference's refusal, which names the contacts, rows and rank."""
    robot = panda.robot
    rng = np.random.default_rng(4)
    q, v = panda.state(rng)
    tau = rng.uniform(-5, 5, robot.dof)
    contacts = (sd.Contact("panda_link4", frame=True), sd.Contact("panda_hand", frame=True))
    _, cset = compiled.checked(robot, contacts)
    num = compiled.numbers(*SETTINGS, 0.0, 0.0, constrained.DIRECT)
    table = compiled.contact_table(robot, contacts, True)
    e, kernel = cset.robot, compiled.kernel(cset.robot.kind)
    a, F = np.empty(robot.nv), np.empty(cset.shape)
    assert kernel(e.Pd, e.Pk, q, v, tau, table, num, e.flags, a, F) == NOT_CONVERGED
    with pytest.raises(ValueError, match=r"the contacts \['panda_link4', 'panda_hand'\] ask for "
                                         r"accelerations no motion meets: 12 constraint rows of "
                                         r"rank 7 on 7 velocities"):
        robot.constrained_forward_dynamics(q, v, tau, contacts)


def test_mimic_joints_keep_the_reference_path():
    """A robot with mimic joints has no kernel (its Jacobians are reduced on the facade)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = sd.load_urdf(erd("panda_description/urdf/panda.urdf"))
    assert robot.model.has_mimic_joints
    assert compiled.checked(robot, [sd.Contact("panda_hand")])[1] is None
