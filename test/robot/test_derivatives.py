"""Derivatives of inverse and forward dynamics (``Robot.inverse_dynamics_derivatives``,
``Robot.forward_dynamics_derivatives``) and of the joint friction
(``Dissipation.torque_derivative``), against two independent oracles:

- Pinocchio's ``computeRNEADerivatives`` and ``computeABADerivatives`` on the hand-picked
  chains of example-robot-data (test_pinocchio.CHAINS: arms, legs, prismatic and
  continuous joints, bases that are not the root, tilted gravity) and on every chain of
  every URDF there that loads, relative error <= 1e-9;
- 8th-order central finite differences of the reference inverse and forward dynamics
  (``backend="numpy"``, a different computation: no tangent is propagated) on synthetic
  chains with prismatic joints and tilted axes, with a tip wrench, armature, a payload and
  a moving base (truncation error ~h^8, round-off ~eps/h: 1e-11 relative at h = 0.01).

and: compiled against the reference at 1e-12, a state alone and in a batch bitwise,
mimic joints (the reduced system G^T (.) G), and the errors of bad inputs.
"""

import numpy as np
import pytest

from pin_reference import erd, pin
from test_mimic import mimic_chain
from test_pinocchio import CHAINS, URDFS, _branch_ends, _load, _tree, reference

import serial_dynamics as sd
from serial_dynamics.model import Dissipation
from serial_dynamics.builtin.synthetic import chain_urdf

RTOL = 1e-9
EPS = np.finfo(float).eps


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


# ---------------------------------------------------------------- Pinocchio
def _pin_derivatives(ref, q, qd, qdd, tau):
    """Pinocchio's d tau/d q, d tau/d qd at (q, qd, qdd) and d qdd/d (q, qd, tau) at
    (q, qd, tau), on our joints. A full-model reference (held joints at neutral, anymal_c)
    has no ABA of the locked chain: its forward derivatives are -M^-1 d tau/d x there."""
    m, d = ref.model, ref.data
    ix = np.ix_(ref.iv, ref.iv)
    dq, dv, _ = pin.computeRNEADerivatives(m, d, ref.q(q), ref.v(qd), ref.v(qdd))
    dq, dv = np.array(dq)[ix], np.array(dv)[ix]
    if m.nv == len(ref.iv):
        aq, av, at = pin.computeABADerivatives(m, d, ref.q(q), ref.v(qd), ref.v(tau))
        at = np.triu(at) + np.triu(at, 1).T
        return dq, dv, (np.array(aq)[ix], np.array(av)[ix], at[ix])
    Minv = np.linalg.inv(ref.mass_matrix(q))
    fq, fv, _ = pin.computeRNEADerivatives(m, d, ref.q(q), ref.v(qd), ref.v(ref.aba(q, qd, tau)))
    return dq, dv, (-Minv @ np.array(fq)[ix], -Minv @ np.array(fv)[ix], Minv)


@pytest.fixture(scope="module", params=sorted(CHAINS))
def chain(request):
    rel, base, tip, _ = CHAINS[request.param]
    path = erd(rel)
    robot = _load(path, base, tip)
    try:
        return robot, reference(robot, path)
    except ValueError as exc:       # Pinocchio cannot reduce the model (anymal_c)
        assert "Several frames match" in str(exc), exc
        return robot, reference(robot, path, full=True)


def test_against_pinocchio(chain):
    robot, ref = chain
    rng = np.random.default_rng(0)
    for _ in range(2):
        q, qd = robot.random_state(rng, speed=2.0)
        qdd, tau = rng.uniform(-3, 3, (2, robot.dof))
        dq, dv, (aq, av, at) = _pin_derivatives(ref, q, qd, qdd, tau)
        ours = robot.inverse_dynamics_derivatives(q, qd, qdd)
        assert rel_err(ours[0], dq) <= RTOL and rel_err(ours[1], dv) <= RTOL
        # forward dynamics is defined to cond(M) eps at best (test_pinocchio)
        tol = max(RTOL, 100 * np.linalg.cond(ref.mass_matrix(q)) * EPS)
        for a, b in zip(robot.forward_dynamics_derivatives(q, qd, tau), (aq, av, at)):
            assert rel_err(a, b) <= tol


def test_pinocchio_oracle_is_not_trivial():
    """The comparison above can fail: Pinocchio's derivatives change with the state, and
    d tau/d qdd = M (ours: the mass matrix)."""
    rel, base, tip, _ = CHAINS["panda"]
    path = erd(rel)
    robot = _load(path, base, tip)
    ref = reference(robot, path)
    rng = np.random.default_rng(1)
    q, qd = robot.random_state(rng, speed=2.0)
    qdd = rng.uniform(-3, 3, robot.dof)
    dq, dv, _ = _pin_derivatives(ref, q, qd, qdd, qdd)
    assert rel_err(robot.inverse_dynamics_derivatives(q + 0.1, qd, qdd)[0], dq) > 1e-3
    assert rel_err(robot.inverse_dynamics_derivatives(q, qd + 0.1, qdd)[1], dv) > 1e-3
    _, _, da = pin.computeRNEADerivatives(ref.model, ref.data, ref.q(q), ref.v(qd), ref.v(qdd))
    da = np.triu(da) + np.triu(da, 1).T
    assert rel_err(robot.mass_matrix(q), np.array(da)[np.ix_(ref.iv, ref.iv)]) <= RTOL


def _every_chain(rel):
    """(robot, reference) of every chain of ``rel`` that loads (test_pinocchio checks the
    refusals); a chain with mimic joints as the chain with every joint free."""
    import dataclasses
    path = erd(rel)
    try:
        ends = _branch_ends(_tree(path))
    except Exception:
        return
    for tip in ends:
        try:
            robot = _load(path, None, tip)
        except (sd.URDFError, sd.ModelError):
            continue
        if robot.dof != robot.model.dof:
            robot = sd.Robot(dataclasses.replace(robot.model,
                                                 mimic_leader=np.full(robot.model.dof, -1)))
        try:
            yield robot, reference(robot, path)
        except ValueError:                       # anymal_c: the full model, others held
            yield robot, reference(robot, path, full=True)


@pytest.mark.parametrize("rel", URDFS)
def test_every_chain_against_pinocchio(rel):
    """Every chain from the root to a branch end of every URDF of example-robot-data."""
    checked = 0
    rng = np.random.default_rng(2)
    for robot, ref in _every_chain(rel):
        q, qd = robot.random_state(rng, speed=2.0)
        qdd, tau = rng.uniform(-3, 3, (2, robot.dof))
        dq, dv, (aq, av, at) = _pin_derivatives(ref, q, qd, qdd, tau)
        # relative to the largest entry of both, or of M (in N m / (rad/s^2)): a rotor or
        # wheel alone about a vertical axis has every derivative 0 (Pinocchio: round-off)
        scale = max(np.max(np.abs(dq)), np.max(np.abs(dv)), np.max(np.abs(ref.mass_matrix(q))))
        for a, b in zip(robot.inverse_dynamics_derivatives(q, qd, qdd), (dq, dv)):
            assert np.max(np.abs(a - b)) <= RTOL * scale, robot.tip_link
        tol = max(RTOL, 100 * np.linalg.cond(ref.mass_matrix(q)) * EPS)
        scale = max(np.max(np.abs(aq)), np.max(np.abs(av)), np.max(np.abs(at)) * scale)
        fd = robot.forward_dynamics_derivatives(q, qd, tau)
        for a, b in zip(fd[:2], (aq, av)):
            assert np.max(np.abs(a - b)) <= tol * scale, robot.tip_link
        assert rel_err(fd[2], at) <= tol, robot.tip_link
        checked += 1
    if checked == 0:
        pytest.skip(f"{rel}: no chain loads (test_pinocchio.KNOWN_INVALID)")


# ---------------------------------------------------------------- finite differences
def tilted_chain():
    """Six joints, revolute and prismatic, axes tilted off the link axes, joint origins
    turned (rpy), inertias with products of inertia and off-origin centers of mass."""
    axes = ["0 0 1", "0.6 0 0.8", "0.2 -0.7 0.3", "1 0 0", "0.3 0.4 -0.5", "0 1 0"]
    kinds = ["revolute", "prismatic", "revolute", "revolute", "prismatic", "revolute"]
    out = ['<robot name="tilted"><link name="base"/>']
    parent = "base"
    for i, (axis, kind) in enumerate(zip(axes, kinds)):
        m = 2.0 - 0.25 * i
        out.append(
            f'<link name="l{i}"><inertial><origin xyz="{0.05 + 0.02 * i} 0.01 -0.02" '
            f'rpy="0.2 -0.1 0.3"/><mass value="{m}"/><inertia ixx="{0.03 * m}" '
            f'iyy="{0.025 * m}" izz="{0.02 * m}" ixy="0.001" ixz="-0.002" iyz="0.0015"/>'
            '</inertial></link>')
        out.append(
            f'<joint name="j{i}" type="{kind}"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="{0.1 + 0.03 * i} 0.02 {0.05 * (i % 2)}" rpy="{0.3 * i} -0.2 0.1"/>'
            f'<axis xyz="{axis}"/><limit lower="-1" upper="1" effort="100" velocity="5"/>'
            '</joint>')
        parent = f"l{i}"
    out.append('<link name="tip"/><joint name="tip_joint" type="fixed"><parent link="l5"/>'
               '<child link="tip"/><origin xyz="0.1 0.05 -0.03" rpy="0.4 0.1 -0.2"/></joint>')
    return "".join(out) + "</robot>"


SYNTHETIC = {
    "tilted": lambda: sd.load_urdf(tilted_chain(), gravity=(0.5, -1.0, -9.81),
                                   armature={"j0": 0.3, "j1": 0.5, "j3": 0.05}),
    "prismatic_chain": lambda: sd.load_urdf(chain_urdf(
        5, kinds=["prismatic", "revolute", "prismatic", "revolute", "revolute"],
        masses=[2.0, 1.5, 1.0, 0.7, 0.4], lengths=[0.3, 0.25, 0.2, 0.15, 0.1]),
        gravity=(0.5, -1.0, -9.81)),
    "ur5e_payload": lambda: sd.default_robot().with_payload(
        2.0, com=(0.01, 0.02, 0.05), inertia=(0.01, 0.012, 0.008, 0.001, -0.002, 0.0005)),
}
BASE = sd.BaseMotion(angular_velocity=(0.3, -0.2, 0.5), angular_acceleration=(1.0, 2.0, -1.0),
                     linear_acceleration=(0.5, 0.1, 2.0))
C8 = ((1, 4 / 5), (2, -1 / 5), (3, 4 / 105), (4, -1 / 280))    # 8th-order central weights


def fd8(f, x, h):
    """Columns d f / d x_j by the 8th-order central difference."""
    cols = []
    for j in range(x.shape[0]):
        e = np.zeros_like(x)
        e[j] = h
        cols.append(sum(c * (f(x + k * e) - f(x - k * e)) for k, c in C8) / h)
    return np.array(cols).T


@pytest.fixture(scope="module", params=sorted(SYNTHETIC))
def synthetic(request):
    robot = SYNTHETIC[request.param]()
    return robot, sd.Robot(robot.model, backend="numpy")


def _inputs(robot, seed):
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, speed=1.5)
    return q, qd, rng.uniform(-2, 2, robot.dof), rng.normal(size=6) * [20, 20, 20, 2, 2, 2]


@pytest.mark.parametrize("terms", ["plain", "wrench", "base", "wrench+base"])
def test_inverse_dynamics_derivatives_by_finite_differences(synthetic, terms):
    robot, ref = synthetic
    q, qd, qdd, w = _inputs(robot, 3)
    w = w if "wrench" in terms else None
    base = BASE if "base" in terms else None
    dq, dqd = robot.inverse_dynamics_derivatives(q, qd, qdd, w, base)
    h = 1e-2
    assert rel_err(dq, fd8(lambda x: ref.inverse_dynamics(x, qd, qdd, w, base), q, h)) <= 1e-10
    assert rel_err(dqd, fd8(lambda x: ref.inverse_dynamics(q, x, qdd, w, base), qd, h)) <= 1e-10


@pytest.mark.parametrize("terms", ["plain", "wrench+base"])
def test_forward_dynamics_derivatives_by_finite_differences(synthetic, terms):
    robot, ref = synthetic
    q, qd, tau, w = _inputs(robot, 4)
    w, base = (w, BASE) if terms != "plain" else (None, None)
    aq, av, at = robot.forward_dynamics_derivatives(q, qd, tau, w, base)
    fd = lambda *s: ref.forward_dynamics(*s, wrench=w, base_motion=base)   # noqa: E731
    h = 1e-2
    assert rel_err(aq, fd8(lambda x: fd(x, qd, tau), q, h)) <= 1e-9
    assert rel_err(av, fd8(lambda x: fd(q, x, tau), qd, h)) <= 1e-9
    assert rel_err(at, fd8(lambda x: fd(q, qd, x), tau, h)) <= 1e-9
    np.testing.assert_array_equal(at, at.T)                  # M^-1, exactly symmetric


def test_terms_change_the_derivatives(synthetic):
    """Each term of the finite-difference tests above is felt by the derivatives (so that
    a derivative that ignored it would fail there)."""
    robot, _ = synthetic
    q, qd, qdd, w = _inputs(robot, 3)
    dq, dqd = robot.inverse_dynamics_derivatives(q, qd, qdd)
    assert rel_err(robot.inverse_dynamics_derivatives(q, qd, qdd, w)[0], dq) > 1e-3
    for a, b in zip(robot.inverse_dynamics_derivatives(q, qd, qdd, base_motion=BASE), (dq, dqd)):
        assert rel_err(a, b) > 1e-3


def test_armature_and_payload_enter_as_modelled():
    """Armature: no term in d tau/d q, d tau/d qd (I_a qdd), but in M, hence in the forward
    derivatives; a payload changes both."""
    plain = sd.load_urdf(tilted_chain(), gravity=(0.5, -1.0, -9.81))
    arm = SYNTHETIC["tilted"]()
    q, qd, qdd, _ = _inputs(plain, 5)
    for a, b in zip(arm.inverse_dynamics_derivatives(q, qd, qdd),
                    plain.inverse_dynamics_derivatives(q, qd, qdd)):
        assert rel_err(a, b) <= 1e-14
    assert rel_err(arm.forward_dynamics_derivatives(q, qd, qdd)[2],
                   plain.forward_dynamics_derivatives(q, qd, qdd)[2]) > 1e-3
    ur = sd.default_robot()
    pay = SYNTHETIC["ur5e_payload"]()
    q, qd, qdd, _ = _inputs(ur, 6)
    assert rel_err(pay.inverse_dynamics_derivatives(q, qd, qdd)[0],
                   ur.inverse_dynamics_derivatives(q, qd, qdd)[0]) > 1e-2


# ---------------------------------------------------------------- compiled, batches, mimic
LONG = {"chain_30": lambda: sd.load_urdf(chain_urdf(30, kinds=["revolute", "prismatic", "revolute"] * 10)),
        "planar_3r": lambda: sd.builtin_robot("planar_3r"),
        **SYNTHETIC}


@pytest.mark.parametrize("name", sorted(LONG))
def test_compiled_equals_reference(name):
    robot = LONG[name]()
    ref = sd.Robot(robot.model, backend="numpy")
    rng = np.random.default_rng(7)
    Q, V = robot.random_state(rng, batch=3, speed=2.0)
    A = rng.uniform(-2, 2, Q.shape)
    W = rng.normal(size=(3, 6)) * 10
    for w, base in ((None, None), (W, BASE)):
        for a, b in zip(robot.inverse_dynamics_derivatives(Q, V, A, w, base),
                        ref.inverse_dynamics_derivatives(Q, V, A, w, base)):
            assert rel_err(a, b) <= 1e-12
        cond = max(np.linalg.cond(M) for M in robot.mass_matrix(Q))
        for a, b in zip(robot.forward_dynamics_derivatives(Q, V, A, w, base),
                        ref.forward_dynamics_derivatives(Q, V, A, w, base)):
            assert rel_err(a, b) <= max(1e-12, 10 * cond * EPS)


def test_a_state_gives_the_same_bits_alone_and_in_a_batch():
    robot = SYNTHETIC["tilted"]()
    rng = np.random.default_rng(8)
    N = 300                                   # more than derivatives.PARALLEL_MIN: split
    Q, V = robot.random_state(rng, batch=N, speed=2.0)
    A = rng.uniform(-2, 2, Q.shape)
    W = rng.normal(size=(N, 6))
    for w, base in ((None, None), (W, None), (W, BASE)):
        batch_id = robot.inverse_dynamics_derivatives(Q, V, A, w, base)
        batch_fd = robot.forward_dynamics_derivatives(Q, V, A, w, base)
        for k in (0, 1, 150, N - 1):
            wk = None if w is None else w[k]
            for a, b in zip(robot.inverse_dynamics_derivatives(Q[k], V[k], A[k], wk, base), batch_id):
                np.testing.assert_array_equal(a, b[k])
            for a, b in zip(robot.forward_dynamics_derivatives(Q[k], V[k], A[k], wk, base), batch_fd):
                np.testing.assert_array_equal(a, b[k])
    # a row broadcast over the batch, and lists, take the general path with the same bits
    one = robot.inverse_dynamics_derivatives(Q[0], V[0], A[0])
    bc = robot.inverse_dynamics_derivatives(Q[:1], V[:3], A[:3])
    np.testing.assert_array_equal(bc[0][0], one[0])
    np.testing.assert_array_equal(robot.inverse_dynamics_derivatives(
        list(Q[0]), list(V[0]), list(A[0]))[1], one[1])


def test_shapes_and_numpy_backend():
    robot = sd.default_robot()
    ref = sd.Robot(robot.model, backend="numpy")
    q, qd, qdd, _ = _inputs(robot, 9)
    for r in (robot, ref):
        dq, dqd = r.inverse_dynamics_derivatives(q, qd, qdd)
        assert dq.shape == dqd.shape == (6, 6)
        out = r.forward_dynamics_derivatives(np.stack([q, q]), np.stack([qd, qd]), np.stack([qdd, qdd]))
        assert len(out) == 3 and all(x.shape == (2, 6, 6) for x in out)


def test_mimic_chain_is_the_reduced_system():
    """d tau/d q = G^T (d tau_all/d q_all) G, and finite differences of the mimic robot's own
    inverse and forward dynamics (q_all = G q + o)."""
    import dataclasses
    for follower in ("revolute", "prismatic"):
        robot = sd.load_urdf(mimic_chain(follower))
        assert robot.dof < robot.model.dof
        free = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(robot.model.dof, -1)))
        G, o = robot.model.mimic_matrix
        q, qd, qdd, w = _inputs(robot, 10)
        dq, dqd = robot.inverse_dynamics_derivatives(q, qd, qdd, w)
        fq, fv = free.inverse_dynamics_derivatives(G @ q + o, G @ qd, G @ qdd, w)
        assert rel_err(dq, G.T @ fq @ G) <= 1e-14 and rel_err(dqd, G.T @ fv @ G) <= 1e-14
        h = 1e-2
        assert rel_err(dq, fd8(lambda x: robot.inverse_dynamics(x, qd, qdd, w), q, h)) <= 1e-10
        aq, av, at = robot.forward_dynamics_derivatives(q, qd, qdd, w)
        assert rel_err(aq, fd8(lambda x: robot.forward_dynamics(x, qd, qdd, w), q, h)) <= 1e-9
        assert rel_err(av, fd8(lambda x: robot.forward_dynamics(q, x, qdd, w), qd, h)) <= 1e-9
        assert rel_err(at, np.linalg.inv(robot.mass_matrix(q))) <= 1e-12
        batch = robot.inverse_dynamics_derivatives(np.stack([q, q]), np.stack([qd, qd]), np.stack([qdd, qdd]), w)
        np.testing.assert_array_equal(batch[0][1], dq)
        n = robot.model.dof                  # every joint's coordinates are not the robot's
        with pytest.raises(ValueError, match=rf"q has shape \({n},\); expected \({robot.dof},\)"):
            robot.inverse_dynamics_derivatives(np.zeros(n), np.zeros(n), np.zeros(n))
        with pytest.raises(ValueError, match=rf"q has shape \({n},\); expected \({robot.dof},\)"):
            robot.forward_dynamics_derivatives(np.zeros(n), np.zeros(n), np.zeros(n))


# ---------------------------------------------------------------- bad inputs
def test_bad_inputs_name_the_culprit():
    robot = sd.default_robot()
    ref = sd.Robot(robot.model, backend="numpy")
    z = np.zeros(6)
    for r in (robot, ref):
        with pytest.raises(ValueError, match=r"qd has shape \(5,\); expected \(6,\)"):
            r.inverse_dynamics_derivatives(z, z[:5], z)
        with pytest.raises(ValueError, match=r"tau has a NaN or Inf entry \(joint 'wrist_1_joint'\)"):
            r.forward_dynamics_derivatives(z, z, np.array([0, 0, 0, np.nan, 0, 0]))
        with pytest.raises(ValueError, match="wrench has shape"):
            r.inverse_dynamics_derivatives(z, z, z, wrench=np.zeros(5))
        with pytest.raises(ValueError, match="wrench has a NaN"):
            r.forward_dynamics_derivatives(z, z, z, wrench=np.array([np.inf, 0, 0, 0, 0, 0]))
        with pytest.raises(ValueError, match="batch sizes differ"):
            r.inverse_dynamics_derivatives(np.zeros((2, 6)), np.zeros((3, 6)), z)
        with pytest.raises(TypeError, match="base_motion must be"):
            r.inverse_dynamics_derivatives(z, z, z, base_motion=(0, 0, 0))


# ---------------------------------------------------------------- friction
def test_friction_derivative_by_finite_differences():
    diss = Dissipation(("a", "b", "c", "d"), [0.3, 0.1, 0.0, 0.2], [1.0, 0.5, 2.0, 0.0],
                       [0.4, 0.0, 0.7, 0.0], [3.0, 1.0, 10.0, 0.0])
    rng = np.random.default_rng(11)
    h = 1e-6
    # exact: away from qd = 0 (where sgn jumps)
    qd = rng.choice([-1, 1], (5, 4)) * rng.uniform(0.05, 2.0, (5, 4))
    fd = (diss.torque(qd + h) - diss.torque(qd - h)) / (2 * h)      # delta_i depends on qd_i
    assert rel_err(diss.torque_derivative(qd), fd) <= 1e-7
    assert diss.torque_derivative(qd).shape == (5, 4)
    # smooth, across zero, at the smoothing speed's scale
    v_eps = 1e-3
    qd = rng.uniform(-5e-3, 5e-3, (5, 4))
    h = 1e-9
    fd = (diss.smooth_torque(qd + h, v_eps) - diss.smooth_torque(qd - h, v_eps)) / (2 * h)
    assert rel_err(diss.torque_derivative(qd, smooth=True, v_eps=v_eps), fd) <= 1e-5
    # fixed sliding signs (the simulator's stick-slip steps): -beta qd - (tau_c + eps e^..) s
    s = np.array([1.0, -1.0, 0.0, 1.0])
    qd = rng.uniform(-1, 1, 4)
    h = 1e-6
    f = lambda x: -diss.viscous * x - diss.sliding_friction(x) * s    # noqa: E731
    assert rel_err(diss.torque_derivative(qd, sign=s), (f(qd + h) - f(qd - h)) / (2 * h)) <= 1e-7
    # at rest (exact mode) the Coulomb jump has no derivative: -beta
    np.testing.assert_array_equal(diss.torque_derivative(np.zeros(4)), -diss.viscous)
