"""The contacts' fast paths give what the general ones give: contact rows from the compiled
kernels at the contact point (``jacobians.world_rows``) against the rows moved there from the
link's origin on the facade, the ground's contact kinematics likewise, the direct Delassus
solve against the proximal iterations, a state that is a strided view, and the ground's
solve of contacts that all stick against projected Gauss-Seidel."""
import numpy as np
import pytest

from contact_cases import FEET, Panda, Solo, rel_err

import serial_dynamics as sd
from serial_dynamics.contacts import constrained, stepping
from serial_dynamics.contacts.jacobians import contact_rows, point_frames
from serial_dynamics.contacts.stepping import GroundContacts

OFFSET = (0.012, -0.021, 0.033)          # m, in the link's frame: the point is not the origin


def cases():
    solo, panda = Solo(), Panda()
    return [(solo, [sd.Contact(f, point=OFFSET) for f in FEET]),
            (panda, [sd.Contact("panda_hand", point=OFFSET, frame=True)]),
            (solo, [sd.Contact("FL_FOOT", point=OFFSET, frame=True), sd.Contact("HR_FOOT")])]


@pytest.mark.parametrize("i", range(3))
def test_world_rows_equal_the_rows_moved_from_the_link(i):
    case, contacts = cases()[i]
    rng = np.random.default_rng(i)
    for _ in range(3):
        q, v = case.state(rng)
        fast = contact_rows(case.robot, q, v, contacts, positions=False)
        general = contact_rows(case.robot, q, v, contacts, positions=True)
        for a, b in zip(fast[:3], general[:3]):            # J, J-dot v, J v
            assert rel_err(a, b) < 1e-12


def test_the_ground_reads_the_same_points_and_jacobians():
    case = Solo()
    feet = [sd.Contact(f, point=OFFSET) for f in FEET]
    fast = GroundContacts(case.robot, sd.Ground(), feet, 1e-3)
    slow = GroundContacts(case.robot, sd.Ground(), feet, 1e-3)
    slow.frames = None                                    # the facade's kinematics
    assert fast.frames is not None
    q, _ = case.state(np.random.default_rng(5))
    for a, b in zip(fast._kinematics(q), slow._kinematics(q)):
        assert rel_err(a, b) < 1e-12


def test_the_direct_solve_is_the_proximal_fixed_point(monkeypatch):
    case = Solo()
    feet = [sd.Contact(f) for f in FEET]
    q, v = case.state(np.random.default_rng(7))
    tau = np.random.default_rng(8).normal(size=case.robot.dof)
    a, f = case.robot.constrained_forward_dynamics(q, v, tau, feet)
    monkeypatch.setattr(constrained, "DIRECT", np.inf)    # never direct: iterate
    a_it, f_it = case.robot.constrained_forward_dynamics(q, v, tau, feet)
    assert rel_err(a, a_it) < 1e-9 and rel_err(f, f_it) < 1e-9


def test_a_strided_state_is_answered_as_a_contiguous_one():
    case = Solo()
    feet = [sd.Contact(f) for f in FEET]
    q, v = case.state(np.random.default_rng(9))
    tau = np.random.default_rng(10).normal(size=case.robot.dof)
    a, f = case.robot.constrained_forward_dynamics(q, v, tau, feet)
    strided = np.repeat(q, 2)[::2]                        # a view with stride 16 bytes
    assert not strided.flags.c_contiguous
    a2, f2 = case.robot.constrained_forward_dynamics(strided, v, tau, feet)
    assert rel_err(a, a2) < 1e-12 and rel_err(f, f2) < 1e-12


def test_the_numpy_backend_takes_the_facade_path():
    arm = sd.load_urdf(sd.builtin_path("ur5e"))
    reference = sd.Robot(arm.model, backend="numpy")
    tip = [sd.Contact("tool0", point=OFFSET)]
    assert point_frames(arm, tip) is not None and point_frames(reference, tip) is None
    q, v = arm.random_state(np.random.default_rng(11))
    tau = arm.gravity_torques(q)
    a, f = arm.constrained_forward_dynamics(q, v, tau, tip)
    a_ref, f_ref = reference.constrained_forward_dynamics(q, v, tau, tip)
    assert rel_err(a, a_ref) < 1e-9 and rel_err(f, f_ref) < 1e-9


def test_the_sticking_solve_is_the_pgs_fixed_point():
    rng = np.random.default_rng(12)
    A = rng.normal(size=(12, 12))
    G = A @ A.T / 12 + 0.5 * np.eye(12)                   # four contacts, positive definite
    target = np.zeros(4)
    lam_true = np.c_[rng.uniform(1, 2, 4), rng.uniform(-0.2, 0.2, (4, 2))]   # in the cones
    u0 = -G @ lam_true.reshape(-1)                         # so that u = 0 at lam_true
    lam = stepping.sticking(G, u0, target, 0.5)
    assert lam is not None and rel_err(lam, lam_true) < 1e-12
    ref, _ = stepping.pgs(G, u0, target, 0.5, np.zeros((4, 3)), tolerance=1e-14,
                          max_iterations=5000)
    assert rel_err(lam, ref) < 1e-9
    # one contact pulled up (it would need a negative normal impulse), one slipping: PGS's
    for pulled in (np.r_[-1.0, 0.0, 0.0], np.r_[1.0, 2.0, 0.0]):
        bad = lam_true.copy()
        bad[2] = pulled
        assert stepping.sticking(G, -G @ bad.reshape(-1), target, 0.5) is None
    # a redundant set (G singular): PGS's
    J = rng.normal(size=(12, 6))
    assert stepping.sticking(J @ J.T, u0, target, 0.5) is None
