"""A free-floating base (FloatingRobot) against Pinocchio's free-flyer, and its identities."""
import dataclasses
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import erd, pin

# (URDF, base_link, tip_link): the default robot, an arm, a humanoid's leg and a quadruped's
# leg from the pelvis / trunk (the other limbs held at zero and lumped into the base)
CHAINS = {
    "ur5e": (None, None, None),
    "panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8"),
    "talos_leg": ("talos_data/robots/talos_reduced.urdf", "base_link", "leg_left_6_link"),
    "solo12_leg": ("solo_description/robots/solo12.urdf", "base_link", "FL_FOOT"),
}


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


class PinFloating:
    """Pinocchio's model of the same chain on a JointModelFreeFlyer root, the joints off the
    chain locked at zero; our (q, v) in its layout (continuous joints: cos, sin)."""

    def __init__(self, robot, path):
        full = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
        keep = set(robot.joint_names) | {"root_joint"}
        lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.data = self.model.createData()
        jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iq = [self.model.idx_qs[j] for j in jid]
        self.nqs = [self.model.nqs[j] for j in jid]
        self.iv = np.r_[0:6, [self.model.idx_vs[j] for j in jid]]
        assert self.model.nv == robot.nv

    def q(self, q):
        out = pin.neutral(self.model)
        out[:7] = q[:7]
        for k, (i, nq) in enumerate(zip(self.iq, self.nqs)):
            out[i:i + nq] = (np.cos(q[7 + k]), np.sin(q[7 + k])) if nq == 2 else q[7 + k]
        return out

    def v(self, x):
        out = np.zeros(self.model.nv)
        out[self.iv] = x
        return out


def load(name, **kw):
    rel, base, tip = CHAINS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        if rel is None:
            return sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True, **kw), \
                sd.builtin_path("ur5e")
        return sd.load_urdf(erd(rel), base, tip, floating_base=True, **kw), erd(rel)


@pytest.fixture(scope="module", params=sorted(CHAINS))
def chain(request):
    robot, path = load(request.param)
    return robot, PinFloating(robot, path)


def states(robot, count=3, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, v = robot.random_state(rng, speed=2.0)
        yield q, v, rng.uniform(-3, 3, robot.nv), rng.uniform(-5, 5, robot.dof)


def test_the_floating_robot_is_a_free_flyer(chain):
    robot, ref = chain
    assert robot.is_floating and robot.nq == robot.dof + 7 and robot.nv == robot.dof + 6
    m, d = ref.model, ref.data
    for q, v, a, tau in states(robot):
        qp, vp = ref.q(q), ref.v(v)
        M = np.triu(pin.crba(m, d, qp))
        M = (M + np.triu(M, 1).T)[np.ix_(ref.iv, ref.iv)]
        assert rel_err(robot.mass_matrix(q), M) <= 1e-9
        assert rel_err(robot.inverse_dynamics(q, v, a), pin.rnea(m, d, qp, vp, ref.v(a))[ref.iv]) <= 1e-9
        a_pin = pin.aba(m, d, qp, vp, ref.v(np.r_[np.zeros(6), tau]))[ref.iv]
        for method in ("aba", "cholesky"):
            assert rel_err(robot.forward_dynamics(q, v, tau, method=method), a_pin) <= 1e-9
        hg = pin.computeCentroidalMomentum(m, d, qp, vp)
        assert rel_err(robot.centroidal_momentum(q, v), np.r_[hg.linear, hg.angular]) <= 1e-9
        assert rel_err(robot.center_of_mass(q), pin.centerOfMass(m, d, qp)) <= 1e-12
        assert rel_err(robot.gravity_torques(q), pin.computeGeneralizedGravity(m, d, qp)[ref.iv]) <= 1e-9


def test_batches_give_the_single_results():
    robot, _ = load("ur5e")
    q, v = robot.random_state(3, batch=37)     # more than one SIMD block, and a short tail
    a = np.random.default_rng(4).normal(size=(37, robot.nv))
    tau = robot.inverse_dynamics(q, v, a)
    M = robot.mass_matrix(q)
    w = np.array([1.0, -2.0, 3.0, 0.1, 0.2, -0.3])
    tau_w = robot.inverse_dynamics(q, v, a, wrench=w)
    for k in range(37):
        np.testing.assert_array_equal(tau[k], robot.inverse_dynamics(q[k], v[k], a[k]))
        np.testing.assert_array_equal(tau_w[k], robot.inverse_dynamics(q[k], v[k], a[k], wrench=w))
        np.testing.assert_array_equal(M[k], robot.mass_matrix(q[k]))
    np.testing.assert_allclose(robot.forward_dynamics(q, v, tau), a, rtol=0, atol=1e-9)
    w = np.array([1.0, -2.0, 3.0, 0.1, 0.2, -0.3])
    for method in ("aba", "cholesky"):                   # same bits alone or in a batch
        A = robot.forward_dynamics(q, v, tau[:, 6:], wrench=w, method=method)
        for k in range(37):
            np.testing.assert_array_equal(
                A[k], robot.forward_dynamics(q[k], v[k], tau[k, 6:], wrench=w, method=method))


def test_a_tip_wrench_in_the_world_is_minus_J_transpose_w():
    robot, _ = load("ur5e")
    for q, v, a, _ in states(robot, seed=5):
        w = np.array([10.0, -20.0, 5.0, 1.0, -2.0, 3.0])
        J = robot.jacobian(q)
        np.testing.assert_allclose(robot.inverse_dynamics(q, v, a, wrench=w),
                                   robot.inverse_dynamics(q, v, a) - J.T @ w, atol=1e-10)
        # the Jacobian is the tip's world twist: finite differences of the tip's pose
        dt = 1e-7
        X0, X1 = robot.forward_kinematics(q), robot.forward_kinematics(robot.integrate(q, v, dt))
        np.testing.assert_allclose((X1[:3, 3] - X0[:3, 3]) / dt, (J @ v)[:3], atol=1e-5)


def test_the_mass_matrix_does_not_depend_on_the_base_pose_and_energy_is_half_vMv():
    robot, _ = load("panda")
    q, v = robot.random_state(6)
    q2 = q.copy()
    q2[:7] = robot.random_state(7)[0][:7]
    np.testing.assert_allclose(robot.mass_matrix(q2), robot.mass_matrix(q), atol=1e-14)
    assert robot.kinetic_energy(q, v) == pytest.approx(0.5 * v @ robot.mass_matrix(q) @ v, rel=1e-14)
    m_total = robot.model.base_mass + robot.model.mass.sum()
    assert robot.potential_energy(q) == pytest.approx(9.81 * m_total * robot.center_of_mass(q)[2],
                                                      rel=1e-12)


def test_integrate_is_pinocchios_exponential_map():
    robot, path = load("ur5e")
    ref = PinFloating(robot, path)
    for q, v, _, _ in states(robot, seed=8):
        for dt in (1e-3, 0.7):
            q1 = robot.integrate(q, v, dt)
            assert abs(np.linalg.norm(q1[3:7]) - 1.0) <= 1e-15
            np.testing.assert_allclose(q1, pin.integrate(ref.model, ref.q(q), v * dt), atol=1e-13)


def test_a_base_1e9_times_heavier_is_a_fixed_base():
    fixed = sd.load_urdf(sd.builtin_path("ur5e"), gravity=(0, 0, 0))
    robot, _ = load("ur5e", gravity=(0, 0, 0))
    k = 1e9
    heavy = sd.Robot(dataclasses.replace(
        robot.model, base_mass=k * robot.model.base_mass, base_h=k * robot.model.base_h,
        base_inertia=k * robot.model.base_inertia, base_I_O=k * robot.model.base_I_O),
        backend="numpy")                     # 4e9 kg: beyond the loader's magnitude checks
    for q, qd, _, tau in ((*fixed.random_state(s, speed=2.0), None,
                           np.random.default_rng(s).uniform(-5, 5, 6)) for s in range(3)):
        qf, vf = np.r_[np.zeros(6), 1.0, q], np.r_[np.zeros(6), qd]
        a = heavy.forward_dynamics(qf, vf, tau)
        qdd = fixed.forward_dynamics(q, qd, tau)
        assert rel_err(a[6:], qdd) <= 1e-6
        assert rel_err(robot.forward_dynamics(qf, vf, tau)[6:], qdd) > 1e-3   # 4 kg base: not


def test_zero_momentum_the_generalized_jacobian_and_the_base_reaction():
    robot, _ = load("panda")
    q, _ = robot.random_state(9)
    qdj = np.random.default_rng(10).uniform(-1, 1, robot.dof)
    v = np.r_[robot.base_reaction(q, qdj), qdj]
    np.testing.assert_allclose(robot.centroidal_momentum(q, v), 0.0, atol=1e-12)
    np.testing.assert_allclose(robot.generalized_jacobian(q) @ qdj, robot.jacobian(q) @ v,
                               atol=1e-12)


def test_bad_states_are_named():
    robot, _ = load("ur5e")
    q, v = robot.random_state(0)
    with pytest.raises(ValueError, match="quaternion .* zero length"):
        robot.mass_matrix(np.r_[q[:3], np.zeros(4), q[7:]])
    with pytest.raises(ValueError, match=r"q has shape \(12,\); expected \(13,\)"):
        robot.inverse_dynamics(q[:12], v, v)
    with pytest.raises(ValueError, match=r"v has shape \(13,\); expected \(12,\)"):
        robot.forward_dynamics(q, q, np.zeros(6))
    with pytest.raises(ValueError, match="v has a NaN"):
        robot.forward_dynamics(q, np.r_[np.nan, v[1:]], np.zeros(6))
    with pytest.raises(ValueError, match="wrench has shape"):
        robot.inverse_dynamics(q, v, v, wrench=np.zeros(5))
    with pytest.raises(ValueError, match="method 'qr' unknown for a floating base"):
        robot.forward_dynamics(q, v, np.zeros(6), method="qr")
    with pytest.raises(ValueError, match="base_motion"):
        robot.inverse_dynamics(q, v, v, base_motion=sd.BaseMotion())


FLOATING_URDF = """<robot name="sat">
<link name="world"/>
<joint name="free" type="floating"><parent link="world"/><child link="body"/></joint>
<link name="body"><inertial><mass value="400"/><inertia ixx="50" iyy="60" izz="70" ixy="0"
 ixz="0" iyz="0"/></inertial></link>
<joint name="j1" type="revolute"><parent link="body"/><child link="l1"/>
 <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="1"/></joint>
<link name="l1"><inertial><origin xyz="0.5 0 0"/><mass value="10"/><inertia ixx="0.1" iyy="1"
 izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
{extra}
</robot>"""


def test_a_root_floating_joint_floats_and_one_below_the_root_is_refused():
    robot = sd.load_urdf(FLOATING_URDF.format(extra=""))
    assert robot.is_floating and robot.base_link == "body" and robot.model.base_mass == 400
    same = sd.load_urdf(FLOATING_URDF.format(extra=""), base_link="body", floating_base=True)
    q = np.r_[0.1, 0.2, 0.3, 0, 0, np.sin(0.2), np.cos(0.2), 0.4]
    np.testing.assert_array_equal(robot.mass_matrix(q), same.mass_matrix(q))
    below = FLOATING_URDF.format(extra='<joint name="loose" type="floating"><parent link="l1"/>'
                                       '<child link="l2"/></joint><link name="l2"/>')
    with pytest.raises(sd.URDFError, match="'loose' on the chain is floating"):
        sd.load_urdf(below, tip_link="l2")


def test_the_compiled_backend_is_the_reference():
    robot, _ = load("panda")
    ref = sd.Robot(robot.model, backend="numpy")
    q, v = robot.random_state(11, batch=7, speed=2.0)
    rng = np.random.default_rng(12)
    a, tau, w = rng.normal(size=(7, robot.nv)), rng.normal(size=(7, robot.dof)), rng.normal(size=6)
    for got, want in ((robot.inverse_dynamics(q, v, a, w), ref.inverse_dynamics(q, v, a, w)),
                      (robot.mass_matrix(q), ref.mass_matrix(q)),
                      (robot.forward_dynamics(q, v, tau, w, method="aba"),
                       ref.forward_dynamics(q, v, tau, w, method="aba")),
                      (robot.forward_dynamics(q[0], v[0], tau[0], method="cholesky"),
                       ref.forward_dynamics(q[0], v[0], tau[0], method="cholesky")),
                      (robot.kinetic_energy(q, v), ref.kinetic_energy(q, v))):
        assert rel_err(got, want) <= 1e-12


@pytest.mark.parametrize("n", [6, 41, 51])
def test_the_free_flyer_root_is_the_references_root_alone_and_in_batches(n):
    """The compiled recursions take a floating chain's six base coordinates as one free-flyer
    joint (core/rnea.py, crba.py, forward.py, aba.py and their lanes); from 41 joints (47
    coordinates) the mass matrix is too big for the lanes' stack, from 51 (57) the
    articulated inertias too, and those batches run state by state: either way each row is
    bitwise its single call, and both agree with the reference's 6-DoF root."""
    from serial_dynamics.builtin.synthetic import chain_urdf
    base = ('<link name="base_link"><inertial><mass value="10"/><inertia ixx="0.2" iyy="0.3" '
            'izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    robot = sd.load_urdf(chain_urdf(n).replace('<link name="base_link"/>', base),
                         floating_base=True)
    ref = sd.Robot(robot.model, backend="numpy")
    q, v = robot.random_state(5, batch=35, speed=2.0)
    rng = np.random.default_rng(6)
    a, w = rng.normal(size=(35, robot.nv)), rng.normal(size=6)
    tau = robot.inverse_dynamics(q, v, a, w)
    M = robot.mass_matrix(q)
    qdd = {m: robot.forward_dynamics(q, v, tau, w, method=m) for m in ("cholesky", "aba")}
    assert rel_err(tau, ref.inverse_dynamics(q, v, a, w)) <= 1e-12
    assert rel_err(M, ref.mass_matrix(q)) <= 1e-12
    assert rel_err(qdd["cholesky"], a) <= 1e-9 and rel_err(qdd["aba"], a) <= 1e-9
    for k in (0, 31, 32, 34):                      # first, last of a block, next block, tail
        assert tau[k].tobytes() == robot.inverse_dynamics(q[k], v[k], a[k], w).tobytes()
        assert M[k].tobytes() == robot.mass_matrix(q[k]).tobytes()
        for m in ("cholesky", "aba"):
            assert qdd[m][k].tobytes() == robot.forward_dynamics(q[k], v[k], tau[k], w,
                                                                 method=m).tobytes()


def test_armature_payload_and_warmup_as_for_a_fixed_base():
    robot, _ = load("ur5e")
    rotors = sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True,
                          armature={"elbow_joint": 0.3}).warmup()
    q, v = robot.random_state(13)
    dM = rotors.mass_matrix(q) - robot.mass_matrix(q)
    assert dM[8, 8] == pytest.approx(0.3, rel=1e-12) and np.sum(np.abs(dM)) == pytest.approx(0.3)
    held = robot.with_payload(2.0, com=(0, 0, 0.05), inertia=(0.01, 0.01, 0.01, 0, 0, 0))
    ref = sd.Robot(held.model, backend="numpy")
    a = np.linspace(-1, 1, robot.nv)
    assert type(held) is type(robot) and held.payload.mass == 2.0
    assert rel_err(held.inverse_dynamics(q, v, a), ref.inverse_dynamics(q, v, a)) <= 1e-12
    m_total = robot.model.base_mass + robot.model.mass.sum()
    np.testing.assert_allclose(held.mass_matrix(q)[:3, :3], (m_total + 2.0) * np.eye(3), atol=1e-12)


def _root(path):
    import xml.etree.ElementTree as ET
    tree = ET.parse(path).getroot()
    children = {j.find("child").get("link") for j in tree.findall("joint")}
    return next(link.get("name") for link in tree.findall("link") if link.get("name") not in children)


def erd_chains():
    """test_pinocchio's chains of example-robot-data whose base is the URDF root (where
    Pinocchio puts its free-flyer), loaded on a floating base. Not anymal_c: a link fixed
    to its base ('hatch') has principal moments no rigid body has, which a fixed base never
    reads but a floating one must (the loader refuses it, naming the link)."""
    from test_pinocchio import CHAINS
    return sorted(name for name, (_, base, _, _) in CHAINS.items() if name != "anymal_c_leg"
                  and (base is None or base == _root(erd(CHAINS[name][0]))))


@pytest.mark.parametrize("name", erd_chains())
def test_every_chain_of_example_robot_data_floats_as_in_pinocchio(name):
    from test_pinocchio import CHAINS
    rel, base, tip, _ = CHAINS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(erd(rel), base, tip, floating_base=True)
    ref = PinFloating(robot, erd(rel))
    m, d = ref.model, ref.data
    for q, v, a, tau in states(robot, count=1, seed=14):
        qp, vp = ref.q(q), ref.v(v)
        assert rel_err(robot.inverse_dynamics(q, v, a), pin.rnea(m, d, qp, vp, ref.v(a))[ref.iv]) <= 1e-9
        a_pin = pin.aba(m, d, qp, vp, ref.v(np.r_[np.zeros(6), tau]))[ref.iv]
        assert rel_err(robot.forward_dynamics(q, v, tau), a_pin) <= 1e-9
        hg = pin.computeCentroidalMomentum(m, d, qp, vp)
        assert rel_err(robot.centroidal_momentum(q, v), np.r_[hg.linear, hg.angular]) <= 1e-9
