"""The torque regressor: Y @ phi == inverse dynamics, and Pinocchio's regressor column by column.

- Identity: ``Y(q, qd, qdd) @ robot.inertial_parameters() == robot.inverse_dynamics(q, qd, qdd)``
  to 1e-12 relative, single states and batches, both backends, on the UR5e, on random
  spatial chains (tilted axes given as non-unit vectors, rotated joint origins and
  inertial frames, prismatic joints, fixed links carrying mass), with armature, a payload
  and friction (``Y @ phi == tau - dissipation_torques(qd)``), and on a mimic chain.
- The compiled kernels (projection form) against the NumPy reference (blocks carried
  inward): 1e-12; a state gives the same bits alone or in a batch.
- Oracle: ``pinocchio.computeJointTorqueRegressor`` on every hand-picked chain of
  example-robot-data of test_pinocchio.py (their parameters against Pinocchio's
  ``model.inertias[j].toDynamicParameters()``, their columns against ours), 1e-9.
"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.robot import regressor as reg
from serial_dynamics.algorithms import regressor as ref_reg

TOL = 1e-12


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def _rot(rpy):
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


def spatial_chain(kinds, seed=0, damping=0.0, friction=0.0):
    """URDF of a chain with random tilted axes (non-unit), rotated joint origins and inertial
    frames, a fixed link carrying mass after every other body, physical random inertias."""
    rng = np.random.default_rng(seed)
    f = lambda v: " ".join(repr(float(x)) for x in np.atleast_1d(v))   # noqa: E731

    def inertial():
        s = rng.uniform(0.001, 0.02, 3)                  # second moments along principal axes
        I = np.diag([s[1] + s[2], s[0] + s[2], s[0] + s[1]])
        return (f'<inertial><origin xyz="{f(rng.uniform(-0.2, 0.2, 3))}" '
                f'rpy="{f(rng.uniform(-3, 3, 3))}"/><mass value="{rng.uniform(0.5, 3)}"/>'
                f'<inertia ixx="{I[0, 0]}" iyy="{I[1, 1]}" izz="{I[2, 2]}" ixy="0" ixz="0" iyz="0"/>'
                '</inertial>')
    out = ['<robot name="spatial"><link name="base"/>']
    parent = "base"
    for i, kind in enumerate(kinds):
        axis = rng.normal(size=3) * rng.uniform(0.5, 3)
        lim = '<limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>' if kind == "prismatic" else \
            '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
        out.append(f'<link name="l{i}">{inertial()}</link>'
                   f'<joint name="j{i}" type="{kind}"><parent link="{parent}"/><child link="l{i}"/>'
                   f'<origin xyz="{f(rng.uniform(-0.3, 0.3, 3))}" rpy="{f(rng.uniform(-3, 3, 3))}"/>'
                   f'<axis xyz="{f(axis)}"/>{lim}'
                   f'<dynamics damping="{damping}" friction="{friction}"/></joint>')
        parent = f"l{i}"
        if i % 2 == 0:                                   # a fixed link with mass, lumped
            out.append(f'<link name="f{i}">{inertial()}</link>'
                       f'<joint name="fj{i}" type="fixed"><parent link="{parent}"/><child link="f{i}"/>'
                       f'<origin xyz="{f(rng.uniform(-0.2, 0.2, 3))}" rpy="{f(rng.uniform(-3, 3, 3))}"/></joint>')
            parent = f"f{i}"
    out.append("</robot>")
    return "".join(out)


def _mimic_robot():
    from test_mimic import mimic_chain
    return sd.load_urdf(mimic_chain("prismatic"))


ROBOTS = {
    "ur5e": lambda: sd.default_robot(),
    "spatial_rrprr": lambda: sd.load_urdf(spatial_chain(["revolute", "revolute", "prismatic", "revolute", "revolute"], 1)),
    "spatial_prp": lambda: sd.load_urdf(spatial_chain(["prismatic", "revolute", "prismatic"], 2)),
    "armature": lambda: sd.load_urdf(spatial_chain(["revolute", "prismatic", "revolute", "revolute"], 3),
                                     armature={"j0": 0.5, "j1": 2.0, "j3": 0.03}),
    "payload": lambda: sd.default_robot().with_payload(2.5, (0.01, -0.02, 0.08), (0.01, 0.02, 0.015, 0.001, -0.002, 0.0005)),
    "planar_3r": lambda: sd.builtin_robot("planar_3r"),
    "mimic": _mimic_robot,
}


@pytest.fixture(scope="module", params=list(ROBOTS))
def robots(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = ROBOTS[request.param]()
    return request.param, robot, sd.Robot(robot.model, backend="numpy")


def states(robot, seed=0, batch=None):
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, batch=batch, speed=2.0)
    return q, qd, rng.normal(size=q.shape) * 3


@pytest.mark.parametrize("batch", [None, 13])
def test_regressor_times_parameters_is_inverse_dynamics(robots, batch):
    _, robot, numpy_robot = robots
    q, qd, qdd = states(robot, batch=batch)
    tau = numpy_robot.inverse_dynamics(q, qd, qdd)
    for r in (robot, numpy_robot):
        Y, phi = r.regressor(q, qd, qdd), r.inertial_parameters()
        assert Y.shape == q.shape[:-1] + (robot.dof, phi.size)
        assert rel(Y @ phi, tau) <= TOL
        assert rel(r.regressor(q, 0 * qd, 0 * qdd) @ phi, numpy_robot.gravity_torques(q)) <= TOL


def test_compiled_equals_reference_and_batches_equal_single_states(robots):
    _, robot, numpy_robot = robots
    q, qd, qdd = states(robot, seed=1, batch=40)
    for friction in (False, True):
        for arm in (False, True):
            Yb = robot.regressor(q, qd, qdd, friction, arm)
            assert rel(Yb, numpy_robot.regressor(q, qd, qdd, friction, arm)) <= TOL
            for k in (0, 17, 39):                       # same bits alone or in a batch
                np.testing.assert_array_equal(robot.regressor(q[k], qd[k], qdd[k], friction, arm), Yb[k])
    # a row broadcast over the batch, and inputs of other kinds
    np.testing.assert_array_equal(robot.regressor(q, qd[0], qdd), robot.regressor(q, np.tile(qd[0], (40, 1)), qdd))
    Y0 = robot.regressor(q[0], qd[0], qdd[0])
    np.testing.assert_array_equal(robot.regressor(list(q[0]), tuple(qd[0]), list(qdd[0])), Y0)
    assert rel(robot.regressor(q[0], qd[0], qdd[0].astype(np.float32)),
               numpy_robot.regressor(q[0], qd[0], qdd[0].astype(np.float32).astype(float))) <= TOL
    assert robot.regressor(q[:1], qd[:1], qdd[:1]).shape == (1,) + Y0.shape


def test_large_batches_and_threads_give_the_single_state_bits():
    """A batch split over the cores (reg.PARALLEL_MIN states and more), and calls from
    several threads at once, give each state's own bits."""
    from concurrent.futures import ThreadPoolExecutor
    robot = sd.default_robot()
    q, qd, qdd = states(robot, seed=8, batch=reg.PARALLEL_MIN + 77)
    Yb = robot.regressor(q, qd, qdd, friction=True)
    with ThreadPoolExecutor(4) as pool:
        singles = list(pool.map(lambda k: robot.regressor(q[k], qd[k], qdd[k], friction=True),
                                range(0, q.shape[0], 37)))
    for k, Y in zip(range(0, q.shape[0], 37), singles):
        np.testing.assert_array_equal(Y, Yb[k])
    np.testing.assert_array_equal(robot.regressor(q[-3:], qd[-3:], qdd[-3:], friction=True), Yb[-3:])


def test_armature_columns(robots):
    name, robot, _ = robots
    q, qd, qdd = states(robot, seed=2)
    n_all = robot.model.dof
    has = bool(np.any(robot.model.armature > 0))
    assert (name == "armature") == has
    Y, Ya = robot.regressor(q, qd, qdd, armature=False), robot.regressor(q, qd, qdd, armature=True)
    assert Ya.shape[-1] == Y.shape[-1] + n_all
    np.testing.assert_array_equal(Ya[:, :10 * n_all], Y)
    np.testing.assert_array_equal(robot.regressor(q, qd, qdd).shape[-1], (Ya if has else Y).shape[-1])
    if not robot.model.mimic_leader.max() >= 0:
        np.testing.assert_array_equal(Ya[:, 10 * n_all:], np.diag(qdd))     # the column qdd_i e_i
    phi_a = robot.inertial_parameters(armature=True)
    np.testing.assert_array_equal(phi_a[10 * n_all:], robot.model.armature)
    assert rel(Ya @ phi_a, robot.inverse_dynamics(q, qd, qdd)) <= TOL
    if has:       # the armature matters here: without its columns the identity fails
        assert rel(Y @ robot.inertial_parameters(armature=False), robot.inverse_dynamics(q, qd, qdd)) > 1e-3


def test_friction_columns():
    urdf = spatial_chain(["revolute", "prismatic", "revolute"], 4, damping=0.7, friction=1.3)
    robot = sd.load_urdf(urdf)
    robot.dissipation = robot.dissipation.override(viscous={"j1": 2.0}, coulomb={"j2": 0.4})
    q, qd, qdd = states(robot, seed=3, batch=6)
    qd[0, 1] = 0.0                                       # sign(0) = 0
    Y, phi = robot.regressor(q, qd, qdd, friction=True), robot.inertial_parameters(friction=True)
    n = robot.dof
    assert Y.shape == (6, n, 10 * n + 3 * n)
    expected = robot.inverse_dynamics(q, qd, qdd) - robot.dissipation_torques(qd)
    assert rel(Y @ phi, expected) <= TOL
    np.testing.assert_array_equal(phi[-3 * n:], np.concatenate([[0.7, 2.0, 0.7], [1.3, 1.3, 0.4], np.zeros(3)]))
    F = Y[..., -3 * n:]
    np.testing.assert_array_equal(F[0], np.hstack([np.diag(qd[0]), np.diag(np.sign(qd[0])), np.eye(n)]))
    assert F[0, 1, n + 1] == 0.0
    # the offset column: a constant torque fo per joint
    phi_o = phi.copy()
    phi_o[-n:] = [0.5, -1.0, 2.0]
    assert rel(Y @ phi_o - Y @ phi, np.broadcast_to([0.5, -1.0, 2.0], (6, n))) <= TOL


def test_names():
    robot = sd.load_urdf(spatial_chain(["revolute", "prismatic"], 5), armature={"j1": 0.1})
    names = reg.parameter_names(robot, friction=True)
    assert names[:11] == ["m1", "mx1", "my1", "mz1", "Ixx1", "Ixy1", "Iyy1", "Ixz1", "Iyz1", "Izz1", "m2"]
    assert names[20:] == ["Ia1", "Ia2", "fv1", "fv2", "fc1", "fc2", "fo1", "fo2"]
    assert len(names) == robot.inertial_parameters(friction=True).size
    assert reg.parameter_names(robot, armature=False) == names[:20]


def test_mimic_is_the_reduced_regressor():
    """Y = G^T Y_all: the chain's columns (every body), the independent joints' rows."""
    import dataclasses
    robot = _mimic_robot()
    n = robot.model.dof
    free = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(n, -1)))
    G, o = robot.model.mimic_matrix
    q, qd, qdd = states(robot, seed=6)
    Y = robot.regressor(q, qd, qdd, friction=True)
    Y_all = free.regressor(G @ q + o, G @ qd, G @ qdd)
    assert rel(Y[:, :10 * n], G.T @ Y_all) <= TOL
    assert Y.shape == (robot.dof, 10 * n + 3 * robot.dof)
    assert reg.parameter_names(robot, friction=True)[-6:] == ["fv1", "fv2", "fc1", "fc2", "fo1", "fo2"]
    assert len(reg.parameter_names(robot, friction=True)) == Y.shape[-1]
    assert rel(Y @ robot.inertial_parameters(friction=True),
               robot.inverse_dynamics(q, qd, qdd) - robot.dissipation_torques(qd)) <= TOL


def test_link_frame_map():
    """The 10x10 map from link-frame to joint-frame parameters carries the parameters of the
    model as given (mass, com, inertia in the URDF link frames) to those the algorithms use
    (mass, h, I_O in joint frames): the columns are the link frame's."""
    robot = sd.load_urdf(spatial_chain(["revolute", "prismatic", "revolute", "revolute"], 7))
    m = robot.model
    assert not all(np.allclose(A, np.eye(3)) for A in m.A)         # tilted axes: A != 1
    phi_link = ref_reg.link_frame_parameters(m.mass, m.com, m.inertia)
    T = ref_reg.joint_frame_map(m.A)
    sym = [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)]
    phi_joint = np.column_stack([m.mass, m.h] + [m.I_O[:, a, b] for a, b in sym])
    assert rel(np.einsum("nij,nj->ni", T, phi_link), phi_joint) <= TOL
    np.testing.assert_array_equal(robot.inertial_parameters(), phi_link.ravel())


@pytest.mark.parametrize("bad, match", [
    (dict(q=np.zeros(5)), r"q has shape \(5,\)"),
    (dict(qd=np.array([0, np.nan, 0, 0, 0, 0.0])), "qd has a NaN"),
    (dict(qdd=np.zeros((3, 7))), r"qdd has shape \(3, 7\)"),
    (dict(q=np.zeros((2, 6)), qd=np.zeros((3, 6))), "batch sizes differ"),
    (dict(friction="yes"), "friction must be True or False"),
    (dict(armature=1), "armature must be None"),
])
def test_bad_inputs(bad, match):
    robot = sd.default_robot()
    args = dict(q=np.zeros(6), qd=np.zeros(6), qdd=np.zeros(6), friction=False, armature=None) | bad
    for r in (robot, sd.Robot(robot.model, backend="numpy")):
        with pytest.raises(ValueError, match=match):
            r.regressor(**args)


# ---------------------------------------------------------------- Pinocchio, real robots
from test_pinocchio import CHAINS, reference, _load  # noqa: E402
from pin_reference import erd, pin  # noqa: E402


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_against_pinocchio(name):
    rel_path, base, tip, _ = CHAINS[name]
    path = erd(rel_path)
    robot = _load(path, base, tip)
    try:
        ref = reference(robot, path)
    except ValueError as exc:                      # Pinocchio cannot reduce anymal_c's model
        assert "Several frames match" in str(exc), exc
        ref = reference(robot, path, full=True)
    n = robot.dof
    pin_phi = np.concatenate([ref.model.inertias[j].toDynamicParameters() for j in ref.jid])
    phi = robot.inertial_parameters(armature=False)
    assert rel(phi, pin_phi) <= 1e-9
    cols = np.concatenate([np.arange(10 * (j - 1), 10 * j) for j in ref.jid])
    rng = np.random.default_rng(0)
    qs, qds = robot.random_state(rng, batch=3, speed=2.0)
    qdds = rng.uniform(-3, 3, (3, n))
    Yb = robot.regressor(qs, qds, qdds, armature=False)
    for q, qd, qdd, Y in zip(qs, qds, qdds, Yb):
        Yp = pin.computeJointTorqueRegressor(ref.model, ref.data, ref.q(q), ref.v(qd), ref.v(qdd))
        assert rel(Y, Yp[np.ix_(ref.iv, cols)]) <= 1e-9
        assert rel(Y @ phi, ref.rnea(q, qd, qdd)) <= 1e-9


@pytest.mark.parametrize("rel_path", __import__("test_pinocchio").URDFS)
def test_every_chain_of(rel_path):
    """Every chain of every URDF of example-robot-data that loads (test_pinocchio.py checks the
    refusals): Y against Pinocchio's regressor, one state per chain. Where Pinocchio cannot
    reduce the model (a joint and a link share a name) its full model is the reference: there
    the held joints' bodies are bodies of their own in Pinocchio and lumped in ours, so
    Y @ phi is compared with Pinocchio's inverse dynamics instead of column by column.
    Chains with mimic joints: the chain with every joint free (test_mimic_is_the_reduced_regressor
    checks the reduction)."""
    import dataclasses
    from test_pinocchio import _branch_ends, _tree
    path = erd(rel_path)
    try:
        ends = _branch_ends(_tree(path))
    except Exception:
        pytest.skip("not parsed (test_pinocchio.py)")
    checked = 0
    for tip in ends:
        try:
            robot = _load(path, None, tip)
        except (sd.URDFError, sd.ModelError):
            continue                                   # refused: checked in test_pinocchio.py
        if robot.dof != robot.model.dof:
            robot = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(robot.model.dof, -1)))
        try:
            ref, full = reference(robot, path), False
        except ValueError as exc:
            assert "Several frames match" in str(exc), exc
            ref, full = reference(robot, path, full=True), True
        rng = np.random.default_rng(1)
        q, qd = robot.random_state(rng, speed=2.0)
        qdd = rng.uniform(-3, 3, robot.dof)
        Y = robot.regressor(q, qd, qdd, armature=False)
        assert rel(Y @ robot.inertial_parameters(armature=False), ref.rnea(q, qd, qdd)) <= 1e-9, tip
        if not full:
            cols = np.concatenate([np.arange(10 * (j - 1), 10 * j) for j in ref.jid])
            Yp = np.atleast_2d(     # eigenpy gives a one-joint chain's 1 x p matrix as a vector
                pin.computeJointTorqueRegressor(ref.model, ref.data, ref.q(q), ref.v(qd), ref.v(qdd)))
            assert rel(Y, Yp[np.ix_(ref.iv, cols)]) <= 1e-9, tip
        checked += 1
    if checked == 0:
        pytest.skip("no chain loads (test_pinocchio.py)")


def test_a_floating_base_with_mimic_joints_has_the_reduced_regressor():
    """FloatingMimicRobot: Y = G_v^T Y_all of the floating regressor (the base's ten
    columns first), the friction columns of the independent joints; Y phi is the reduced
    inverse dynamics (less the friction torques), for one state and a batch."""
    import dataclasses
    from pin_reference import erd
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(erd("panda_description/urdf/panda.urdf"), floating_base=True,
                             armature={"panda_joint2": 0.1, "panda_finger_joint2": 0.02})
    assert robot.model.has_mimic_joints and robot.is_floating
    free = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(robot.model.dof, -1)))
    rng = np.random.default_rng(3)
    q, v = robot.random_state(rng, batch=4)
    a = rng.uniform(-1, 1, (4, robot.nv))
    Y = robot.regressor(q, v, a, friction=True)
    phi = robot.inertial_parameters(friction=True)
    assert Y.shape == (4, robot.nv, phi.size) and len(reg.parameter_names(robot, friction=True)) == phi.size
    tau = robot.inverse_dynamics(q, v, a) - np.concatenate(
        [np.zeros((4, 6)), robot.dissipation_torques(v[:, 6:])], axis=1)
    assert rel(np.einsum("nij,j->ni", Y, phi), tau) <= 1e-11
    G, o = robot.model.mimic_matrix
    Gv = np.zeros((6 + G.shape[0], robot.nv))
    Gv[:6, :6], Gv[6:, 6:] = np.eye(6), G
    qa = np.concatenate([q[0, :7], G @ q[0, 7:] + o])
    Y_all = free.regressor(qa, Gv @ v[0], Gv @ a[0])
    assert rel(Y[0, :, :Y_all.shape[1]], Gv.T @ Y_all) <= TOL
    assert rel(robot.regressor(q[1], v[1], a[1], friction=True), Y[1]) <= TOL


@pytest.mark.parametrize("tree", [False, True])
def test_the_compiled_floating_regressor(tree):
    """A floating base in one compiled call (core/regressor.floating_regressor, on the
    instantaneous chain or tree): Y phi is inverse dynamics (less the friction torques), the
    columns are the reference's (the NumPy regressor on the same instantaneous tree; both
    against Pinocchio's in test/oracles/test_pinocchio_trees.py) with armature and friction,
    and a state gives the same bits alone or in a batch (a quaternion of any length)."""
    from serial_dynamics.builtin.synthetic import two_arm_urdf
    source = two_arm_urdf(3, base_mass=4.0, kinds=["revolute", "prismatic", "revolute"]) if tree \
        else sd.builtin_path("ur5e")
    names = sd.load_urdf(source).joint_names
    robot = sd.load_urdf(source, floating_base=True, armature={j: 0.05 for j in names[1:]})
    ref = sd.Robot(robot.model, backend="numpy")
    assert robot.model.is_chain != tree
    rng = np.random.default_rng(5)
    q, v = robot.random_state(rng, batch=6, speed=2.0)
    q[:, 3:7] *= 0.6
    a = rng.uniform(-2, 2, (6, robot.nv))
    Y = robot.regressor(q, v, a, friction=True)
    phi = robot.inertial_parameters(friction=True)
    tau = robot.inverse_dynamics(q, v, a) - np.concatenate(
        [np.zeros((6, 6)), robot.dissipation_torques(v[:, 6:])], axis=1)
    assert rel(np.einsum("nij,j->ni", Y, phi), tau) <= TOL
    assert rel(Y, ref.regressor(q, v, a, friction=True)) <= TOL
    for k in range(6):
        np.testing.assert_array_equal(robot.regressor(q[k], v[k], a[k], friction=True), Y[k])
    assert robot.regressor(q[0], v[0], a[0], armature=False).shape == (robot.nv, 10 * (robot.dof + 1))
    with pytest.raises(ValueError, match="a has a NaN"):
        robot.regressor(q[0], v[0], np.full(robot.nv, np.inf))
