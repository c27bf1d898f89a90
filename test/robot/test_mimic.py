"""Mimic joints on the chain: the reduced system of the independent joints, against
Pinocchio's own mimic joints (``buildModel(..., mimic=True)``), to 1e-9 relative.

Synthetic chains (a revolute and a prismatic follower, tilted axes, offsets, a negative
multiplier) and a real one (PR2's right arm down to a gripper fingertip, whose joint
mimics the finger joint above it)."""
import warnings

import numpy as np
import pytest

from mimic_cases import mimic_chain
from pin_reference import PinReference, erd, pin

import serial_dynamics as sd

RTOL = 1e-9


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1.0)


class PinMimic(PinReference):
    """Pinocchio's model of the same chain with mimic joints (nv = independent joints)."""

    def __init__(self, robot, model):
        self.model, self.robot = model, robot
        self.model.gravity.linear[:] = robot.gravity
        self.data = model.createData()
        self.jid = [model.getJointId(n) for n in robot.joint_names]
        self.iv = np.array([model.idx_vs[j] for j in self.jid])
        assert model.nv == robot.dof


def synthetic(follower):
    xml = mimic_chain(follower)
    robot = sd.load_urdf(xml)
    return robot, PinMimic(robot, pin.buildModelFromXML(xml, mimic=True))


def pr2():
    path = erd("pr2_description/urdf/pr2.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(path, "r_shoulder_pan_link", "r_gripper_l_finger_tip_link")
    full = pin.buildModelFromUrdf(path, mimic=True)
    keep = set(robot.all_joint_names)
    lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
    model = pin.buildReducedModel(full, lock, pin.neutral(full))
    # our base is r_shoulder_pan_link, Pinocchio's the world: give it our base-frame gravity
    # by expressing it in its world (the base at neutral is a fixed pose of the world)
    ref = PinMimic(robot, model)
    return robot, ref


CHAINS = {"revolute follower": lambda: synthetic("revolute"),
          "prismatic follower": lambda: synthetic("prismatic"), "pr2 fingertip": pr2}


@pytest.fixture(scope="module", params=sorted(CHAINS))
def chain(request):
    return CHAINS[request.param]()


def states(robot, count=3, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, qd = robot.random_state(rng, speed=2.0)
        yield q, qd, rng.uniform(-3, 3, robot.dof)


def test_the_coordinates_are_the_independent_joints(chain):
    robot, ref = chain
    assert robot.dof == ref.model.nv < len(robot.all_joint_names)
    assert set(robot.joint_names) < set(robot.all_joint_names)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_against_pinocchio_mimic_joints(chain, backend):
    robot, ref = chain
    if robot.base_link != "base":     # PR2: our base frame is not Pinocchio's world
        R0 = pin.SE3.Identity()
        data = ref.model.createData()
        pin.forwardKinematics(ref.model, data, pin.neutral(ref.model))
        ref.model.gravity.linear[:] = robot.gravity   # set below from the base's pose
        parent = ref.model.getFrameId(robot.base_link)
        pin.updateFramePlacements(ref.model, data)
        R0 = data.oMf[parent].rotation
        ref.model.gravity.linear[:] = R0 @ robot.gravity
        ref.data = ref.model.createData()
    r = sd.Robot(robot.model, backend=backend)
    assert type(r) is type(robot)
    Q, V, A = (np.array(x) for x in zip(*states(robot)))
    for q, qd, qdd in zip(Q, V, A):
        tau = ref.rnea(q, qd, qdd)
        assert rel_err(r.inverse_dynamics(q, qd, qdd), tau) <= RTOL
        assert rel_err(r.mass_matrix(q), ref.mass_matrix(q)) <= RTOL
        assert rel_err(r.gravity_torques(q), ref.rnea(q, 0 * qd, 0 * qd)) <= RTOL
        for method in ("auto", "cholesky", "aba"):
            assert rel_err(r.forward_dynamics(q, qd, tau, method=method), qdd) <= RTOL
    # batches: row k is the single state's (bitwise, compiled: the reduction is ordered sums)
    T = r.inverse_dynamics(Q, V, A)
    for k in range(len(Q)):
        single = r.inverse_dynamics(Q[k], V[k], A[k])
        if backend == "numba":
            np.testing.assert_array_equal(T[k], single)
            np.testing.assert_array_equal(r.mass_matrix(Q)[k], r.mass_matrix(Q[k]))
        assert rel_err(T[k], single) <= 1e-14
    np.testing.assert_allclose(r.forward_dynamics(Q, V, T), A, rtol=0, atol=1e-9 * np.max(np.abs(A)))


def test_energy_coriolis_and_jacobian_of_the_reduced_system(chain):
    robot, _ = chain
    G, o = robot.model.mimic_matrix
    for q, qd, _ in states(robot, seed=4):
        M = robot.mass_matrix(q)
        assert abs(robot.kinetic_energy(q, qd) - 0.5 * qd @ M @ qd) <= 1e-13 * (qd @ M @ qd)
        # C qd + g = b, and the tip velocity J qd of the reduced Jacobian is the chain's
        np.testing.assert_allclose(robot.coriolis_matrix(q, qd) @ qd + robot.gravity_torques(q),
                                   robot.bias_torques(q, qd), atol=1e-10)
        np.testing.assert_allclose(robot.all_joint_positions(q), G @ q + o)
        assert robot.jacobian(q).shape == (6, robot.dof)


def test_friction_of_a_mimic_joint_acts_on_its_leader():
    robot, _ = synthetic("revolute")
    # j1 <- j4 (m = -0.7), j2 <- j3 (m = 1.5); every joint: damping 0.3, friction 0.1
    np.testing.assert_allclose(robot.dissipation.viscous, 0.3 * np.array([1 + 0.49, 1 + 2.25]))
    np.testing.assert_allclose(robot.dissipation.coulomb, 0.1 * np.array([1 + 0.7, 1 + 1.5]))


def test_simulation_of_a_mimic_chain_keeps_its_energy_balance():
    robot, _ = synthetic("prismatic")
    res = sd.simulate(robot, 1.0, [0.3, -0.4], [1.0, 0.5], method="DOP853", rtol=1e-10,
                      atol=1e-12, dissipation=False)
    assert res.q.shape[1] == 2
    assert res.relative_energy_error() < 1e-8
    semi = sd.simulate(robot, 0.2, [0.3, -0.4], [1.0, 0.5], method="semi_implicit_euler",
                       dt=1e-4, dissipation=True)
    assert np.all(np.isfinite(semi.q)) and semi.relative_energy_error() < 1e-2


@pytest.mark.parametrize("rel, floating, branches", [
    ("panda_description/urdf/panda.urdf", False, 0),      # one hand: a reduced chain
    ("talos_data/robots/talos_full_v2.urdf", True, 4)])  # arms, legs, head off the torso
def test_the_compiled_reduced_system_of_a_tree(rel, floating, branches):
    """core/mimic.py on trees with mimic joints (the Panda's second finger on another
    branch than its leader; Talos's grippers, floating): one compiled call a state, the
    general path's bits for every row of a batch, the reference's numbers, and a sparse
    factor of G^T M G on the reduced tree (robot/mimic.mimic_layout)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(erd(rel), floating_base=floating)
    ref = sd.Robot(robot.model, backend="numpy")
    assert set(robot.kernels()) >= {"mimic_rnea", "mimic_crba", "mimic_fd"}
    rng = np.random.default_rng(4)
    Q, V = robot.random_state(rng, batch=5)
    # rows of random states and of integrate's are C-contiguous (each a single fast call)
    assert Q.flags.c_contiguous and V.flags.c_contiguous
    assert robot.integrate(Q, V, 0.01).flags.c_contiguous
    A = rng.uniform(-1, 1, (5, robot.nv))
    T = robot.inverse_dynamics(Q, V, A)
    calls = {"inverse_dynamics": (Q, V, A), "bias_torques": (Q, V), "mass_matrix": (Q,),
             "forward_dynamics": (Q, V, T)}
    for name, args in calls.items():
        batch = getattr(robot, name)(*args)
        for k in range(5):
            one = getattr(robot, name)(*(x[k] for x in args))
            assert one.tobytes() == batch[k].tobytes(), name      # the general path's bits
            want = getattr(ref, name)(*(x[k] for x in args))
            assert rel_err(one, want) <= 1e-12 * (1e3 if name == "forward_dynamics" else 1)
    np.testing.assert_allclose(robot.forward_dynamics(Q, V, T), A, atol=1e-9)
    # the reduced tree: each coordinate's parent above it, and branches that stay apart
    parent = robot._v_parent
    assert np.all(parent < np.arange(robot.nv))
    assert np.sum(parent != np.arange(robot.nv) - 1) == branches
    L, d = robot.mass_matrix_factor(Q[0])
    keep = np.eye(robot.nv, dtype=bool)
    for k in range(robot.nv):
        i = parent[k]
        while i >= 0:
            keep[k, i], i = True, parent[i]
    M = robot.mass_matrix(Q[0])
    assert not np.any(M[~(keep | keep.T)])                 # M's zeros: the reduced tree's
    assert not np.any(L[~keep]) and rel_err(L.T @ (d[:, None] * L), M) <= 1e-12
    assert robot._Gm[-1, 0] == 1.0                         # core/mimic.py: SPARSE


def test_a_mimic_chain_keeps_the_dense_factor(chain):
    """On a chain the reduced system keeps dense Cholesky (its bits: the hash test)."""
    robot, _ = chain
    assert robot._Gm[-1, 0] == 0.0
    np.testing.assert_array_equal(robot._v_parent, np.arange(robot.nv) - 1)


def test_a_follower_that_couples_two_branches_makes_the_reduced_system_dense():
    """joint2 (arm a) mimics b_joint2 (arm b): the reduced b_joint2 couples with a1 and b1,
    which are on no one path, so the reduced M is no tree's: mimic_layout falls back to a
    dense factor (SPARSE 0, parents k - 1) and the answers stay the reference's."""
    from serial_dynamics.builtin.synthetic import two_arm_urdf
    xml = two_arm_urdf(3)
    start = xml.index('<joint name="joint2"')
    end = xml.index("</joint>", start)
    robot = sd.load_urdf(xml[:end] + '<mimic joint="b_joint2" multiplier="0.5"/>' + xml[end:])
    assert robot.dof == 5 and robot._Gm[-1, 0] == 0.0
    np.testing.assert_array_equal(robot._v_parent, np.arange(5) - 1)
    ref = sd.Robot(robot.model, backend="numpy")
    q, qd = robot.random_state(np.random.default_rng(2), speed=1.0)
    tau = np.linspace(-1, 1, 5)
    M = robot.mass_matrix(q)
    assert rel_err(M, ref.mass_matrix(q)) <= 1e-12
    assert rel_err(robot.forward_dynamics(q, qd, tau), ref.forward_dynamics(q, qd, tau)) <= 1e-10
    L, d = robot.mass_matrix_factor(q)
    assert rel_err(L.T @ (d[:, None] * L), M) <= 1e-12


@pytest.mark.parametrize("urdf, floating", [("panda_description/urdf/panda.urdf", False),
                                            ("baxter_description/urdf/baxter.urdf", False),
                                            ("talos_data/robots/talos_full_v2.urdf", True)])
def test_every_batch_row_is_its_single_call(urdf, floating):
    """A batch runs the whole model's batch kernels (SIMD lanes) between NumPy's gather and
    sum, and the reduced M and qdd state by state: each row bitwise its single call, rows
    given or broadcast (the Panda's fingers: one coordinate on two branches; Baxter's
    grippers; Talos's on a floating base)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = sd.load_urdf(erd(urdf), floating_base=floating)
    assert r.nv < len(r.all_joint_names) + (6 if floating else 0)    # reduced
    rng = np.random.default_rng(5)
    Q, V = r.random_state(rng, batch=9)
    A = rng.normal(size=(9, r.nv))
    calls = {"inverse_dynamics": lambda q, v, a: r.inverse_dynamics(q, v, a),
             "bias_torques": lambda q, v, a: r.bias_torques(q, v),
             "gravity_torques": lambda q, v, a: r.gravity_torques(q),
             "mass_matrix": lambda q, v, a: r.mass_matrix(q),
             "forward_dynamics": lambda q, v, a: r.forward_dynamics(q, v, a)}
    for name, f in calls.items():
        for v, a in ((V, A), (V[3], A[3])):                          # rows, one row broadcast
            B = f(Q, v, a)
            for k in range(len(Q)):
                row = f(Q[k], V[k] if v.ndim == 2 else v, A[k] if a.ndim == 2 else a)
                np.testing.assert_array_equal(B[k], row, err_msg=f"{name}, state {k}")
