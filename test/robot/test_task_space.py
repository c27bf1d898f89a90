"""Task-space dynamics (robot/task_space.py, algorithms/task_space.py): the frame
acceleration, J-dot qd, the operational-space inertia Lambda and J-bar.

Oracles: Pinocchio on example-robot-data arms (getFrameClassicalAcceleration and
getFrameJacobianTimeVariation in LOCAL_WORLD_ALIGNED, Lambda composed from its M and J), and
its free-flyer for a floating base, to 1e-9; central finite differences of J along the motion
for every kind of robot (plain, armature, payload, mimic, planar, floating); the identities
Lambda J M^-1 J^T = 1, J J-bar = 1, J-bar^T M J-bar = Lambda.
"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import PinReference, erd, pin
from test_floating import PinFloating
from test_mimic import mimic_chain

RTOL = 1e-9
ARMS = {   # id: (URDF, base_link, tip_link, a link in the middle of the chain)
    "panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8", "panda_link4"),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "base_link", "tool0", "forearm_link"),
    "kinova": ("kinova_description/robots/kinova.urdf", None, None, None),
    "tiago_torso_arm": ("tiago_description/robots/tiago_no_hand.urdf", "torso_fixed_link",
                        "wrist_ft_tool_link", "arm_3_link"),
}


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def _load(path, base=None, tip=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(path, base, tip, **kw)


@pytest.fixture(scope="module", params=sorted(ARMS))
def arm(request):
    rel, base, tip, mid = ARMS[request.param]
    robot = _load(erd(rel), base, tip, gravity=(0.8, -1.3, -9.7))
    return robot, PinReference(robot, erd(rel)), mid


def states(robot, count=3, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, qd = robot.random_state(rng, speed=2.0)
        yield q, qd, rng.uniform(-3, 3, robot.nv)


def test_against_pinocchio(arm):
    robot, ref, mid = arm
    m, d = ref.model, ref.data
    for q, qd, qdd in states(robot):
        pin.forwardKinematics(m, d, ref.q(q), ref.v(qd), ref.v(qdd))
        pin.updateFramePlacements(m, d)
        pin.computeJointJacobiansTimeVariation(m, d, ref.q(q), ref.v(qd))
        Rb = d.oMf[m.getFrameId(robot.base_link, pin.BODY)].rotation.T   # world -> base axes
        M = ref.mass_matrix(q)
        for link in (None, mid):
            fid = m.getFrameId(robot.tip_link if link is None else link, pin.BODY)
            A = pin.getFrameClassicalAcceleration(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
            expect = np.r_[Rb @ A.linear, Rb @ A.angular]
            assert rel_err(robot.frame_acceleration(q, qd, qdd, link), expect) <= RTOL
            dJ = pin.getFrameJacobianTimeVariation(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
            expect = np.r_[Rb @ dJ[:3], Rb @ dJ[3:]][:, ref.iv] @ qd
            assert rel_err(robot.jacobian_dot_qd(q, qd, link), expect) <= RTOL
        # Lambda of the tip composed from Pinocchio's M and J (base axes), and J-bar
        link, fid = None, m.getFrameId(robot.tip_link, pin.BODY)
        Jw = pin.computeFrameJacobian(m, d, ref.q(q), fid, pin.LOCAL_WORLD_ALIGNED)
        J = np.r_[Rb @ Jw[:3], Rb @ Jw[3:]][:, ref.iv]
        if robot.dof >= 6:
            Lam = np.linalg.inv(J @ np.linalg.solve(M, J.T))
            assert rel_err(robot.operational_space_inertia(q, link), Lam) <= RTOL
            Jbar = np.linalg.solve(M, J.T) @ Lam
            assert rel_err(robot.dynamically_consistent_inverse(q, link), Jbar) <= RTOL
        Lam = np.linalg.inv(J @ np.linalg.solve(M, J.T) + 0.1 ** 2 * np.eye(6))
        assert rel_err(robot.operational_space_inertia(q, link, damping=0.1), Lam) <= RTOL


def test_floating_base_against_pinocchio_free_flyer():
    path = erd("panda_description/urdf/panda.urdf")
    robot = _load(path, "panda_link0", "panda_link8", floating_base=True)
    ref = PinFloating(robot, path)
    m, d = ref.model, ref.data
    for q, v, a in states(robot, seed=1):
        pin.forwardKinematics(m, d, ref.q(q), ref.v(v), ref.v(a))
        pin.updateFramePlacements(m, d)
        for link in ("panda_link8", "panda_link3", "panda_link0"):
            fid = m.getFrameId(link, pin.BODY)
            A = pin.getFrameClassicalAcceleration(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
            assert rel_err(robot.frame_acceleration(q, v, a, link), A.vector) <= RTOL, link
        pin.computeJointJacobiansTimeVariation(m, d, ref.q(q), ref.v(v))
        dJ = pin.getFrameJacobianTimeVariation(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
        assert rel_err(robot.jacobian_dot_qd(q, v, "panda_link0"), dJ @ ref.v(v)) <= RTOL
        M = pin.crba(m, d, ref.q(q))
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(ref.iv, ref.iv)]
        Jw = pin.computeFrameJacobian(m, d, ref.q(q), m.getFrameId("panda_link8", pin.BODY),
                                      pin.LOCAL_WORLD_ALIGNED)[:, ref.iv]
        Lam = np.linalg.inv(Jw @ np.linalg.solve(M, Jw.T))
        assert rel_err(robot.operational_space_inertia(q), Lam) <= RTOL


# ----------------------------------------------------------------- every kind of robot
def _kinds():
    ur5e = sd.load_urdf(sd.builtin_path("ur5e"))
    arm = sd.load_urdf(sd.builtin_path("ur5e"),
                       armature={n: 0.05 * (k + 1) for k, n in enumerate(ur5e.joint_names)})
    return {
        "plain": ur5e,
        "armature": arm,
        "payload": ur5e.with_payload(2.0, (0.01, 0.02, 0.1), (0.01, 0.02, 0.015, 0, 0, 0)),
        "mimic": sd.load_urdf(mimic_chain()),
        "planar": sd.load_urdf(sd.builtin.planar_3r_urdf()),
        "floating": sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True),
        "numpy": sd.Robot(ur5e.model, backend="numpy"),
    }


KINDS = _kinds()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_finite_differences_and_identities(kind):
    robot = KINDS[kind]
    h = 1e-6
    for q, qd, qdd in states(robot, count=2, seed=3):
        for link in (None, robot.link_names[len(robot.link_names) // 2]):
            J = robot.jacobian(q, link)
            Jp = robot.jacobian(robot.integrate(q, qd, h), link)
            Jm = robot.jacobian(robot.integrate(q, qd, -h), link)
            fd = (Jp - Jm) @ qd / (2 * h)          # d/dt J along q(t) = integrate(q, qd, t)
            jdqd = robot.jacobian_dot_qd(q, qd, link)
            assert np.max(np.abs(jdqd - fd)) <= 1e-6 * max(1.0, np.max(np.abs(fd))), link
            A = robot.frame_acceleration(q, qd, qdd, link)
            np.testing.assert_allclose(A, J @ qdd + jdqd, rtol=1e-12, atol=1e-12)
        damping = 0.0 if robot.dof >= 6 and kind != "planar" else 0.05
        Lam = robot.operational_space_inertia(q, damping=damping)
        M, J = robot.mass_matrix(q), robot.jacobian(q)
        A = J @ np.linalg.solve(M, J.T) + damping ** 2 * np.eye(6)
        np.testing.assert_allclose(Lam @ A, np.eye(6), atol=1e-9)
        np.testing.assert_allclose(Lam, Lam.T, atol=0)
        Jbar = robot.dynamically_consistent_inverse(q, damping=damping)
        np.testing.assert_allclose(Jbar, np.linalg.solve(M, J.T) @ Lam,
                                   rtol=1e-9, atol=1e-9 * np.max(np.abs(Jbar)))
        if damping == 0.0:
            np.testing.assert_allclose(J @ Jbar, np.eye(6), atol=1e-9)
            np.testing.assert_allclose(Jbar.T @ M @ Jbar, Lam, rtol=1e-9,
                                       atol=1e-9 * np.max(np.abs(Lam)))


@pytest.mark.parametrize("kind", ["plain", "mimic", "floating"])
def test_batches_are_the_rows_of_single_calls(kind):
    robot = KINDS[kind]
    Q, QD = robot.random_state(4, batch=5)
    QDD = np.random.default_rng(5).uniform(-2, 2, QD.shape)
    A = robot.frame_acceleration(Q, QD, QDD)
    B = robot.jacobian_dot_qd(Q, QD)
    L = robot.operational_space_inertia(Q, damping=0.01)
    Jb = robot.dynamically_consistent_inverse(Q, damping=0.01)
    assert A.shape == B.shape == (5, 6) and L.shape == (5, 6, 6) and Jb.shape == (5, robot.nv, 6)
    for k in range(5):
        np.testing.assert_allclose(A[k], robot.frame_acceleration(Q[k], QD[k], QDD[k]), rtol=1e-13)
        np.testing.assert_allclose(B[k], robot.jacobian_dot_qd(Q[k], QD[k]), rtol=1e-13)
        np.testing.assert_allclose(L[k], robot.operational_space_inertia(Q[k], damping=0.01),
                                   rtol=1e-12)


def test_refusals_name_the_culprit_and_the_fix():
    planar = KINDS["planar"]
    q = np.array([0.3, 0.5, -0.4])
    with pytest.raises(ValueError, match=r"link 'tip' is singular \(rank 3 of 6\).*damping > 0"):
        planar.operational_space_inertia(q)
    with pytest.raises(ValueError, match=r"singular \(rank 5 of 6, state 1\)"):
        KINDS["plain"].operational_space_inertia([np.ones(6), np.zeros(6)])  # stretched out
    with pytest.raises(ValueError, match="damping is -1.0; give a finite number >= 0"):
        planar.operational_space_inertia(q, damping=-1.0)
    ur5e = KINDS["plain"]
    with pytest.raises(ValueError, match="link 'nowhere' is not a link of the model"):
        ur5e.jacobian_dot_qd(np.zeros(6), np.ones(6), "nowhere")
    with pytest.raises(ValueError, match=r"qd has shape \(5,\)"):
        ur5e.frame_acceleration(np.zeros(6), np.ones(5), np.zeros(6))
    with pytest.raises(ValueError, match="qdd has a NaN"):
        KINDS["mimic"].frame_acceleration(*KINDS["mimic"].random_state(0), [np.nan] * 2)
