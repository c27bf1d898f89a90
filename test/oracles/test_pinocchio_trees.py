"""Agreement with Pinocchio on the trees of example-robot-data (issue 25), relative error
<= 1e-9: every URDF whose movable joints branch loads as the whole tree and is checked on a
fixed base (Pinocchio's ``buildModelFromUrdf``) and, without mimic joints, on a free-floating
base (its free-flyer root) at a random state with a unit quaternion: inverse dynamics, the
mass matrix, forward dynamics by each method, gravity torques, and the pose, Jacobian and
classical acceleration of every leaf link. Mimic joints (the Panda's, Baxter's and Talos's fingers, a follower on a
sibling branch of its leader) are checked through the map q_all = G q + o of their model.
Gravity is tilted, so that every component is exercised."""
import types
import warnings
import zlib

import numpy as np
import pytest

from pin_reference import PinReference, erd, pin

import serial_dynamics as sd

G_WORLD = np.array([0.8, -1.3, -9.7])
RTOL = 1e-9

# every URDF of example-robot-data that loads as a tree (the others are chains, or refused
# for their data: test_pinocchio.py's test_every_chain_of says why)
TREES = [
    "a1_description/urdf/a1.urdf",
    "alex_description/urdf/alex_nub_hands.urdf",
    "alex_description/urdf/alex_sake_hands.urdf",
    "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf",
    "anymal_b_simple_description/robots/anymal-kinova.urdf",
    "anymal_b_simple_description/robots/anymal.urdf",
    "anymal_c_simple_description/urdf/anymal.urdf",
    "b1_description/urdf/b1-z1.urdf",
    "b1_description/urdf/b1.urdf",
    "baxter_description/urdf/baxter.urdf",
    "bolt_description/robots/bolt.urdf",
    "centauro_description/urdf/centauro.urdf",
    "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    "go1_description/urdf/go1.urdf",
    "go2_description/urdf/go2.urdf",
    "human_description/robots/human.urdf",
    "icub_description/robots/icub.urdf",
    "icub_description/robots/icub_reduced.urdf",
    "iris_description/robots/iris.urdf",
    "laikago_description/urdf/laikago.urdf",
    "panda_description/urdf/panda.urdf",
    "panda_description/urdf/panda_collision.urdf",
    "quadruped_description/urdf/quadruped.urdf",
    "simple_humanoid_description/urdf/simple_humanoid.urdf",
    "simple_humanoid_description/urdf/simple_humanoid_classical.urdf",
    "solo_description/robots/solo.urdf",
    "solo_description/robots/solo12.urdf",
    "talos_data/robots/talos_full_v2.urdf",
    "talos_data/robots/talos_full_v2_box.urdf",
    "talos_data/robots/talos_reduced.urdf",
    "talos_data/robots/talos_reduced_box.urdf",
    "talos_data/robots/talos_reduced_corrected.urdf",
    "tiago_description/robots/tiago.urdf",
    "tiago_description/robots/tiago_dual.urdf",
    "tiago_description/robots/tiago_no_hand.urdf",
    "tiago_pro_description/robots/tiago_pro.urdf",
]


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(1.0, np.max(np.abs(b)))


def load(rel, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd(rel), gravity=G_WORLD, **kw)


def check_factor(robot, q, M, pm, pd, iv):
    """M = L^T D L (robot.mass_matrix_factor) with no fill-in: L is zero wherever M's
    branches put a zero; where Pinocchio numbers the coordinates as we do (and no mimic
    joint couples branches), its M = U D U^T (cholesky.decompose of the M its last crba
    left: U = L^T, the one such factor) to 1e-9."""
    L, d = robot.mass_matrix_factor(q)
    assert rel_err(L.T @ (d[:, None] * L), M) < RTOL and np.all(d > 0)
    if robot.model.has_mimic_joints:
        return
    parent = np.r_[np.arange(robot.nv - robot.dof) - 1, robot.model.parent + robot.nv - robot.dof]
    parent[robot.nv - robot.dof:][robot.model.parent < 0] = robot.nv - robot.dof - 1
    keep = np.eye(robot.nv, dtype=bool)
    for k in range(robot.nv):
        i = parent[k]
        while i >= 0:
            keep[k, i], i = True, parent[i]
    assert not np.any(L[~keep])
    if np.array_equal(iv, np.arange(pm.nv)):
        U = pin.cholesky.decompose(pm, pd)
        assert rel_err(U, L.T) < RTOL and rel_err(pd.D, d) < RTOL


@pytest.mark.parametrize("rel", TREES)
def test_a_fixed_tree_agrees_with_pinocchio(rel):
    robot = load(rel)
    model = robot.model
    assert not model.is_chain
    full = types.SimpleNamespace(joint_names=list(model.joint_names), gravity=model.gravity)
    ref = PinReference(full, erd(rel))                       # every joint, mimic ones free
    G, o = model.mimic_matrix
    rng = np.random.default_rng(zlib.crc32(rel.encode()))   # not hash(): salted per process
    q, qd = robot.random_state(rng)
    qdd = rng.uniform(-2, 2, robot.dof)
    qa, qda, qdda = G @ q + o, G @ qd, G @ qdd               # every joint of the tree
    tau = robot.inverse_dynamics(q, qd, qdd)
    assert rel_err(tau, G.T @ ref.rnea(qa, qda, qdda)) < RTOL
    assert rel_err(robot.gravity_torques(q), G.T @ ref.gravity(qa)) < RTOL
    M = robot.mass_matrix(q)
    assert rel_err(M, G.T @ ref.mass_matrix(qa) @ G) < RTOL
    check_factor(robot, q, M, ref.model, ref.data, ref.iv)
    # center of mass and centroidal momentum of the moving bodies (Pinocchio's leave the
    # universe's body, the base link, out too)
    c = pin.centerOfMass(ref.model, ref.data, ref.q(qa))
    assert rel_err(robot.center_of_mass(q), c) < RTOL
    h = robot.centroidal_momentum(q, qd)
    hp = pin.computeCentroidalMomentum(ref.model, ref.data, ref.q(qa), ref.v(qda))
    assert rel_err(h, np.r_[hp.linear, hp.angular]) < RTOL
    for method in ("cholesky", "aba"):
        assert rel_err(robot.forward_dynamics(q, qd, tau, method=method), qdd) < 1e3 * RTOL
    pin.forwardKinematics(ref.model, ref.data, ref.q(qa), ref.v(qda), ref.v(qdda))
    pin.updateFramePlacements(ref.model, ref.data)
    pin.computeJointJacobians(ref.model, ref.data, ref.q(qa))
    for i in (i for i in range(model.dof) if not model.children[i]):   # every leaf link
        link = model.link_names[i]
        fid = ref.model.getFrameId(link)
        X = ref.data.oMf[fid]
        assert rel_err(robot.forward_kinematics(q, link), X.homogeneous) < RTOL
        J = pin.getFrameJacobian(ref.model, ref.data, fid, pin.LOCAL_WORLD_ALIGNED)
        assert rel_err(robot.jacobian(q, link), J[:, ref.iv] @ G) < RTOL
        a = pin.getFrameClassicalAcceleration(ref.model, ref.data, fid, pin.LOCAL_WORLD_ALIGNED)
        assert rel_err(robot.frame_acceleration(q, qd, qdd, link), a.vector) < RTOL


# floating trees: quadrupeds and humanoids (iCub's floating mass matrix is singular in
# Pinocchio too: a joint that moves no mass: refused at load with the culprit named; Baxter's
# and the full Talos's grippers have mimic joints: FLOATING_MIMIC below). ANYmal B's and C's
# `base` links carry a placeholder inertia (ANYmal B's: 1e-6 kg, every entry 1e-6, "because
# KDL cannot have inertia on the base link"), the real body fixed to it: physical consistency
# is judged on the lumped base (issue 52), which is physical, and they load as they are.
FLOATING = ["solo_description/robots/solo12.urdf", "go2_description/urdf/go2.urdf",
            "a1_description/urdf/a1.urdf", "talos_data/robots/talos_reduced.urdf",
            "g1_description/urdf/g1_29dof_rev_1_0.urdf", "human_description/robots/human.urdf",
            "anymal_b_simple_description/robots/anymal.urdf",
            "anymal_c_simple_description/urdf/anymal.urdf"]


@pytest.mark.parametrize("rel", FLOATING)
def test_a_floating_tree_agrees_with_pinocchios_free_flyer(rel):
    robot = load(rel, floating_base=True)
    pm = pin.buildModelFromUrdf(erd(rel), pin.JointModelFreeFlyer())
    pm.gravity.linear[:] = robot.gravity
    pd = pm.createData()
    jid = [pm.getJointId(n) for n in robot.joint_names]
    iq, iv = [pm.idx_qs[j] for j in jid], [pm.idx_vs[j] for j in jid]
    rng = np.random.default_rng(7)
    quat = rng.standard_normal(4)
    q = np.concatenate([[0.1, -0.2, 0.3], quat / np.linalg.norm(quat),
                        rng.uniform(-1, 1, robot.dof)])
    v, a = rng.uniform(-1, 1, (2, robot.nv))
    qp = pin.neutral(pm)
    qp[:7], qp[iq] = q[:7], q[7:]
    idx = list(range(6)) + iv
    vp, ap = np.zeros(pm.nv), np.zeros(pm.nv)
    vp[idx], ap[idx] = v, a
    tau = robot.inverse_dynamics(q, v, a)
    assert rel_err(tau, pin.rnea(pm, pd, qp, vp, ap)[idx]) < RTOL
    Mp = pin.crba(pm, pd, qp)
    Mp = np.triu(Mp) + np.triu(Mp, 1).T
    assert rel_err(robot.mass_matrix(q), Mp[np.ix_(idx, idx)]) < RTOL
    check_factor(robot, q, robot.mass_matrix(q), pm, pd, np.array(idx))
    for method in ("cholesky", "aba"):
        assert rel_err(robot.forward_dynamics(q, v, tau, method=method), a) < 1e3 * RTOL
    # the Coriolis matrix: C v = b - g, and C differs from Pinocchio's (another valid one) by
    # a skew-symmetric D with D v = 0, so dM/dt - 2 C is skew-symmetric as Pinocchio's is
    C = robot.coriolis_matrix(q, v)
    assert rel_err(C @ v, robot.bias_torques(q, v) - robot.gravity_torques(q)) < RTOL
    D = C - pin.computeCoriolisMatrix(pm, pd, qp, vp)[np.ix_(idx, idx)]
    assert rel_err(D @ v, 0 * v) < RTOL and rel_err(D + D.T, 0 * D) < RTOL * np.max(np.abs(C))
    # the derivatives, d/dq along the tangent (q (+) dq, as Pinocchio's), against
    # computeRNEADerivatives and computeABADerivatives
    dq, dv = robot.inverse_dynamics_derivatives(q, v, a)
    pdq, pdv, _ = pin.computeRNEADerivatives(pm, pd, qp, vp, ap)
    assert rel_err(dq, pdq[np.ix_(idx, idx)]) < RTOL and rel_err(dv, pdv[np.ix_(idx, idx)]) < RTOL
    fq, fv, ft = robot.forward_dynamics_derivatives(q, v, tau)
    pfq, pfv, pft = pin.computeABADerivatives(pm, pd, qp, vp, pin.rnea(pm, pd, qp, vp, ap))
    for ours, theirs in ((fq, pfq), (fv, pfv), (ft, pft)):
        assert rel_err(ours, theirs[np.ix_(idx, idx)]) < 1e3 * RTOL
    # the regressor: tau = Y phi, the columns Pinocchio's (its joint 1 is the free-flyer: the
    # base's ten parameters), rows and columns in our order
    Y = robot.regressor(q, v, a)
    assert rel_err(Y @ robot.inertial_parameters(), tau) < RTOL
    cols = np.concatenate([np.arange(10)] + [10 * (j - 1) + np.arange(10) for j in jid])
    assert rel_err(Y, pin.computeJointTorqueRegressor(pm, pd, qp, vp, ap)[np.ix_(idx, cols)]) < RTOL


# a floating base with mimic joints (FloatingMimicRobot): the Panda's fingers, Baxter's and
# the full Talos's grippers, through q_all = G q + o with the base's coordinates their own
FLOATING_MIMIC = ["panda_description/urdf/panda.urdf", "baxter_description/urdf/baxter.urdf",
                  "talos_data/robots/talos_full_v2.urdf"]


@pytest.mark.parametrize("rel", FLOATING_MIMIC)
def test_a_floating_tree_with_mimic_joints_agrees_with_pinocchio(rel):
    robot = load(rel, floating_base=True)
    assert robot.model.has_mimic_joints and robot.nv == robot.dof + 6
    pm = pin.buildModelFromUrdf(erd(rel), pin.JointModelFreeFlyer())
    pm.gravity.linear[:] = robot.gravity
    pd = pm.createData()
    jid = [pm.getJointId(n) for n in robot.all_joint_names]
    iq, iv = [pm.idx_qs[j] for j in jid], [pm.idx_vs[j] for j in jid]
    G, o = robot.model.mimic_matrix
    Gv = np.zeros((6 + G.shape[0], robot.nv))               # v_all = Gv v
    Gv[:6, :6], Gv[6:, 6:] = np.eye(6), G
    rng = np.random.default_rng(11)
    q, v = robot.random_state(rng)
    a = rng.uniform(-1, 1, robot.nv)
    qp = pin.neutral(pm)
    qp[:7], qp[iq] = q[:7], G @ q[7:] + o
    idx = list(range(6)) + iv
    vp, ap = np.zeros(pm.nv), np.zeros(pm.nv)
    vp[idx], ap[idx] = Gv @ v, Gv @ a
    tau = robot.inverse_dynamics(q, v, a)
    assert rel_err(tau, Gv.T @ pin.rnea(pm, pd, qp, vp, ap)[idx]) < RTOL
    Mp = pin.crba(pm, pd, qp)
    Mp = np.triu(Mp) + np.triu(Mp, 1).T
    M = robot.mass_matrix(q)
    assert rel_err(M, Gv.T @ Mp[np.ix_(idx, idx)] @ Gv) < RTOL
    check_factor(robot, q, M, pm, pd, np.array(idx))
    assert rel_err(robot.forward_dynamics(q, v, tau), a) < 1e3 * RTOL
    assert rel_err(robot.center_of_mass(q), pin.centerOfMass(pm, pd, qp)) < RTOL
    h = pin.computeCentroidalMomentum(pm, pd, qp, vp)
    assert rel_err(robot.centroidal_momentum(q, v), np.r_[h.linear, h.angular]) < RTOL
    C = robot.coriolis_matrix(q, v)                           # G^T C_all G
    assert rel_err(C @ v, robot.bias_torques(q, v) - robot.gravity_torques(q)) < RTOL
    dq, dv = robot.inverse_dynamics_derivatives(q, v, a)      # G^T (d tau_all) G
    pdq, pdv, _ = pin.computeRNEADerivatives(pm, pd, qp, vp, ap)
    assert rel_err(dq, Gv.T @ pdq[np.ix_(idx, idx)] @ Gv) < RTOL
    assert rel_err(dv, Gv.T @ pdv[np.ix_(idx, idx)] @ Gv) < RTOL
    batch = robot.inverse_dynamics(np.stack([q, q]), np.stack([v, 0 * v]), np.stack([a, a]))
    assert batch[0].tobytes() == tau.tobytes()
    # the regressor (G_v^T Y_all): Y phi = tau, and the base's ten columns are Pinocchio's
    # root joint's (base link frame, inertia about its origin), rows reduced
    Y = robot.regressor(q, v, a)
    assert rel_err(Y @ robot.inertial_parameters(), tau) < RTOL
    Yp = pin.computeJointTorqueRegressor(pm, pd, qp, vp, ap)
    assert rel_err(Y[:, :10], Gv.T @ Yp[idx, :10]) < RTOL


@pytest.mark.parametrize("rel", TREES)
def test_the_derivatives_on_a_tree_agree_with_pinocchio(rel):
    """d tau/d q and d tau/d qd (core/tree_derivatives.py) against
    pinocchio.computeRNEADerivatives on every tree (mimic fingers through G: d tau/d q =
    G^T (d tau_all/d q_all) G), and those of forward dynamics (-M^-1 d tau/d x, M^-1)."""
    robot = load(rel)
    model = robot.model
    full = types.SimpleNamespace(joint_names=list(model.joint_names), gravity=model.gravity)
    ref = PinReference(full, erd(rel))
    G, o = model.mimic_matrix
    rng = np.random.default_rng(11)
    q, qd = robot.random_state(rng)
    qdd = rng.uniform(-2, 2, robot.dof)
    dq, dqd = robot.inverse_dynamics_derivatives(q, qd, qdd)
    pq, pv, pa = ref.q(G @ q + o), ref.v(G @ qd), ref.v(G @ qdd)
    Pq, Pv, _ = pin.computeRNEADerivatives(ref.model, ref.data, pq, pv, pa)
    iv = np.ix_(ref.iv, ref.iv)
    assert rel_err(dq, G.T @ Pq[iv] @ G) < RTOL
    assert rel_err(dqd, G.T @ Pv[iv] @ G) < RTOL
    tau = robot.inverse_dynamics(q, qd, qdd)
    aq, av, at = robot.forward_dynamics_derivatives(q, qd, tau)
    Minv = np.linalg.inv(robot.mass_matrix(q))
    assert rel_err(at, Minv) < RTOL and rel_err(aq, -Minv @ dq) < 1e3 * RTOL
    assert rel_err(av, -Minv @ dqd) < 1e3 * RTOL
