"""Modelling terms against Pinocchio: armature (reflected rotor inertia), payload, and a
base with known motion, relative error <= 1e-9, on real robots (example-robot-data) and
synthetic chains (prismatic joints, tilted axes, fixed links carrying mass).

Oracles:
- armature: Pinocchio's ``model.armature`` (``rnea``, ``crba``, ``aba`` include it);
- payload: the payload's spatial inertia added to the Pinocchio body its link is fixed to
  (the link's frame placement in that joint);
- base motion: Pinocchio with a free-flyer root joint at the identity pose, base velocity
  [0, omega_0] and acceleration [a_0, alpha_0] (valid because every chain here has the URDF
  root as its base link, so the free-flyer frame is our base frame).

Gravity is tilted. Both backends (compiled, NumPy reference) are checked against the
oracle, against each other at 1e-12, and batch rows against single calls.
"""
import os
import re
import warnings
import xml.etree.ElementTree as ET
import zlib
from functools import lru_cache
from types import SimpleNamespace

import numpy as np
import pytest

from pin_reference import PinReference, configuration, erd, pin

import serial_dynamics as sd
from serial_dynamics.robots.synthetic import chain_urdf

G_WORLD = np.array([0.8, -1.3, -9.7])
RTOL = 1e-9
XTOL = 1e-12            # compiled vs NumPy reference
BACKENDS = ("numba", "numpy")
FD_METHODS = ("cholesky", "aba", "qr", "auto")
PAYLOAD = dict(mass=2.5, com=(0.03, -0.05, 0.08),
               inertia=(0.02, 0.025, 0.03, 0.001, -0.002, 0.0015))
BM = sd.BaseMotion(angular_velocity=(0.4, -0.7, 1.1), angular_acceleration=(-2.0, 1.5, 0.6),
                   linear_acceleration=(1.2, -0.8, 2.5))


def tilted_chain_urdf(kinds, seed=0):
    """A chain with tilted joint axes and origins (random unit axes, rpy), full inertia
    tensors rotated by the inertial rpy, a fixed 'bracket' link with mass between joints 2
    and 3, a fixed 'flange' with mass below the last joint and a massless 'tool' tip."""
    rng = np.random.default_rng(seed)
    f = lambda v: " ".join(repr(float(x)) for x in np.atleast_1d(v))   # noqa: E731

    def inertial():
        a, b = rng.uniform(0.01, 0.06, 2)
        c = rng.uniform(abs(a - b) + 0.002, a + b - 0.002)      # principal moments: a triangle
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        I = Q @ np.diag([a, b, c]) @ Q.T
        return (f'<inertial><origin xyz="{f(rng.uniform(-0.1, 0.1, 3))}" '
                f'rpy="{f(rng.uniform(-1, 1, 3))}"/><mass value="{f(rng.uniform(0.5, 3))}"/>'
                f'<inertia ixx="{f(I[0, 0])}" ixy="{f(I[0, 1])}" ixz="{f(I[0, 2])}" '
                f'iyy="{f(I[1, 1])}" iyz="{f(I[1, 2])}" izz="{f(I[2, 2])}"/></inertial>')

    def joint(name, kind, parent, child, axis=True):
        origin = f'<origin xyz="{f(rng.uniform(-0.2, 0.2, 3))}" rpy="{f(rng.uniform(-1.5, 1.5, 3))}"/>'
        ends = f'<parent link="{parent}"/><child link="{child}"/>{origin}'
        if not axis:
            return f'<joint name="{name}" type="fixed">{ends}</joint>'
        u = rng.normal(size=3)
        lo = 0.3 if kind == "prismatic" else 2.5
        return (f'<joint name="{name}" type="{kind}">{ends}<axis xyz="{f(u / np.linalg.norm(u))}"/>'
                f'<limit lower="{-lo}" upper="{lo}" effort="100" velocity="10"/></joint>')

    out = ['<?xml version="1.0"?>', '<robot name="tilted">', '<link name="base_link"/>']
    parent = "base_link"
    for i, kind in enumerate(kinds):
        out.append(f'<link name="link{i + 1}">{inertial()}</link>')
        out.append(joint(f"joint{i + 1}", kind, parent, f"link{i + 1}"))
        parent = f"link{i + 1}"
        if i == 1:
            out.append(f'<link name="bracket">{inertial()}</link>')
            out.append(joint("bracket_joint", "fixed", parent, "bracket", axis=False))
            parent = "bracket"
    out.append(f'<link name="flange">{inertial()}</link>')
    out.append(joint("flange_joint", "fixed", parent, "flange", axis=False))
    out.append('<link name="tool"/>')
    out.append(joint("tool_joint", "fixed", "flange", "tool", axis=False))
    out.append("</robot>")
    return "\n".join(out) + "\n"


# id: (URDF (example-robot-data path, or a callable giving XML), base, tip, payload links
# beyond the tip and a middle link: links fixed below a body or on a held branch)
CHAINS = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8",
              ("panda_leftfinger",)),                 # on the held finger branch
    "panda_finger": ("panda_description/urdf/panda_collision.urdf", None, "panda_leftfinger",
                     ()),                             # prismatic last joint
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None, "tool0", ("ee_link",)),
    "kinova": ("kinova_description/robots/kinova.urdf", None, None, ()),   # continuous
    "tiago": ("tiago_description/robots/tiago_no_hand.urdf", None, "wrist_ft_tool_link",
              ("wrist_ft_link",)),                    # prismatic torso lift
    "z1": ("z1_description/urdf/z1.urdf", None, None, ()),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", None, None, ()),
    "synthetic_prismatic": (lambda: chain_urdf(5, kinds=["revolute", "prismatic", "revolute",
                                                         "prismatic", "revolute"],
                                               masses=[3.0, 2.0, 1.5, 1.0, 0.5],
                                               lengths=[0.4, 0.3, 0.3, 0.2, 0.1]),
                            None, None, ("link3",)),
    "tilted": (lambda: tilted_chain_urdf(["revolute", "prismatic", "revolute", "revolute",
                                          "prismatic", "revolute"]), None, "tool",
               ("bracket", "flange")),
}


def rel_err(actual, expected):
    return np.max(np.abs(np.asarray(actual) - expected)) / max(np.max(np.abs(expected)), 1e-300)


def quiet_load(source, base=None, tip=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(source, base, tip, gravity=G_WORLD, **kw)


def fixed_reference(robot, path, armature=None, payload=None):
    """Pinocchio, fixed base, with the armature and a payload (its own model copy)."""
    ref = PinReference(robot, path)
    ref.model.gravity.linear[:] = G_WORLD      # base = root: world and base frames agree
    if armature is not None:
        ref.model.armature[ref.iv] = armature
    if payload is not None:
        add_payload(ref, *payload)
    ref.data = ref.model.createData()
    return ref


def add_payload(ref, link, mass, com, inertia6):
    ixx, iyy, izz, ixy, ixz, iyz = inertia6
    I3 = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    fr = ref.model.frames[ref.model.getFrameId(link, pin.BODY)]
    assert fr.parentJoint in ref.jid, f"{link} is not on a body of the chain"
    ref.model.inertias[fr.parentJoint] = (ref.model.inertias[fr.parentJoint]
                                          + fr.placement.act(pin.Inertia(mass, np.array(com), I3)))


class FreeFlyerReference:
    """Pinocchio with a free-flyer root joint: our chain on a base with known motion."""

    def __init__(self, robot, path):
        full = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
        keep = set(robot.joint_names) | {"root_joint"}
        lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.model.gravity.linear[:] = robot.gravity
        self.jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iv = np.array([self.model.idx_vs[j] for j in self.jid])
        self.model.armature[self.iv] = robot.armature
        self.data = self.model.createData()
        base = self.model.frames[self.model.getFrameId(robot.base_link, pin.BODY)]
        # the free-flyer frame is our base frame: the base link is the URDF root
        assert base.parentJoint == 1 and base.placement.isIdentity()
        self.robot = robot

    def q(self, q):
        return configuration(self.model, self.jid, q)     # identity base pose

    def v(self, head, x):
        out = np.zeros(self.model.nv)
        out[:6] = head
        out[self.iv] = x
        return out

    def fext(self, q, w):
        """Our tip wrench (tip origin, base axes) as a force on the last joint (its axes)."""
        return pin_fext_fixed(self, self.robot, q, w)

    def rnea(self, q, qd, qdd, bm, w=None):
        v = self.v(np.r_[0, 0, 0, bm.angular_velocity], qd)
        a = self.v(np.r_[bm.linear_acceleration, bm.angular_acceleration], qdd)
        args = (self.model, self.data, self.q(q), v, a)
        return (pin.rnea(*args) if w is None else pin.rnea(*args, self.fext(q, w)))[self.iv]

    def forward(self, q, qd, tau, bm, w=None):
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        b = self.rnea(q, qd, np.zeros_like(q), bm, w)
        return np.linalg.solve(M[np.ix_(self.iv, self.iv)], tau - b)


@lru_cache(maxsize=None)
def _chain_source(name, tmpdir):
    src = CHAINS[name][0]
    if callable(src):
        path = os.path.join(tmpdir, f"{name}.urdf")
        with open(path, "w") as fh:
            fh.write(src())
        return path
    return erd(src)


@pytest.fixture(scope="module")
def tmpdir_chains(tmp_path_factory):
    return str(tmp_path_factory.mktemp("modelling_urdfs"))


@pytest.fixture(scope="module", params=sorted(CHAINS))
def case(request, tmpdir_chains):
    name = request.param
    _, base, tip, extra_links = CHAINS[name]
    path = _chain_source(name, tmpdir_chains)
    plain = quiet_load(path, base, tip)
    rng = np.random.default_rng(zlib.crc32(name.encode()))   # not hash(): salted
    # revolute: kg m^2 of geared motors (N^2 J ~ 0.02 .. 0.5); prismatic: kg
    arm = {j: float(rng.uniform(0.02, 0.5) if t != "prismatic" else rng.uniform(0.5, 4.0))
           for j, t in zip(plain.joint_names, plain.joint_types)}
    robot = quiet_load(path, base, tip, armature=arm)
    expected_arm = np.array([arm[j] for j in robot.joint_names])
    np.testing.assert_array_equal(robot.armature, expected_arm)
    assert robot.base_link == pin.buildModelFromUrdf(path).frames[1].name, "base must be the root"
    return SimpleNamespace(
        name=name, path=path, base=base, tip=tip, extra_links=extra_links,
        plain=plain, arm=arm,
        robots={"numba": robot, "numpy": sd.Robot(robot.model, backend="numpy")},
        ref0=fixed_reference(plain, path),
        ref=fixed_reference(robot, path, armature=expected_arm),
        ff=FreeFlyerReference(robot, path))


def states(robot, count=3, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, qd = robot.random_state(rng, speed=2.0)
        yield q, qd, rng.uniform(-3, 3, robot.dof), rng.normal(size=6) * [30, 30, 30, 3, 3, 3]


def batch(robot, N, seed=0):
    rng = np.random.default_rng(seed)
    Q, QD = robot.random_state(rng, batch=N, speed=2.0)
    return Q, QD, rng.uniform(-3, 3, (N, robot.dof)), rng.normal(size=(N, 6)) * [30, 30, 30, 3, 3, 3]


# ============================================================================ armature
@pytest.mark.parametrize("backend", BACKENDS)
def test_armature_inverse_dynamics_and_mass_matrix(case, backend):
    robot, ref, ref0 = case.robots[backend], case.ref, case.ref0
    for q, qd, qdd, _ in states(robot):
        tau = ref.rnea(q, qd, qdd)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) <= RTOL
        assert rel_err(ref0.rnea(q, qd, qdd), tau) > 1e-4                # the armature matters
        np.testing.assert_allclose(tau - ref0.rnea(q, qd, qdd), robot.armature * qdd,
                                   rtol=1e-9, atol=1e-9 * np.max(np.abs(tau)))
        M = ref.mass_matrix(q)
        assert rel_err(robot.mass_matrix(q), M) <= RTOL
        # the bias and gravity torques do not see the armature
        assert rel_err(robot.bias_torques(q, qd), ref.rnea(q, qd, 0 * qdd)) <= RTOL
        assert rel_err(robot.gravity_torques(q), ref.gravity(q)) <= RTOL
    Q, QD, QDD, _ = batch(robot, 7, seed=1)
    expect = np.array([ref.rnea(*s) for s in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD), expect) <= RTOL
    assert rel_err(robot.mass_matrix(Q), np.array([ref.mass_matrix(q) for q in Q])) <= RTOL


@pytest.mark.parametrize("backend", BACKENDS)
def test_armature_forward_dynamics(case, backend):
    robot, ref = case.robots[backend], case.ref
    Q, QD, QDD, W = batch(robot, 5, seed=2)
    TAU = np.array([ref.rnea(*s) for s in zip(Q, QD, QDD)])
    expect = np.array([ref.aba(q, qd, tau) for q, qd, tau in zip(Q, QD, TAU)])
    assert rel_err(expect, QDD) <= 1e-9                    # Pinocchio is consistent
    for method in FD_METHODS:
        for k in range(2):
            got = robot.forward_dynamics(Q[k], QD[k], TAU[k], method=method)
            assert rel_err(got, expect[k]) <= RTOL, method
        assert rel_err(robot.forward_dynamics(Q, QD, TAU, method=method), expect) <= RTOL, method
    # with a tip wrench: Pinocchio's torques against it give the same qdd back
    for k in range(2):
        fext = pin_fext_fixed(ref, robot, Q[k], W[k])
        tau_w = ref.rnea(Q[k], QD[k], QDD[k], fext)
        for method in FD_METHODS:
            assert rel_err(robot.forward_dynamics(Q[k], QD[k], tau_w, wrench=W[k], method=method),
                           QDD[k]) <= 1e-8, method


def pin_fext_fixed(ref, robot, q, w):
    m, d = ref.model, ref.data
    pin.forwardKinematics(m, d, ref.q(q))
    pin.updateFramePlacements(m, d)
    oMb = d.oMf[m.getFrameId(robot.base_link, pin.BODY)]
    oMt = d.oMf[m.getFrameId(robot.tip_link, pin.BODY)]
    oMj = d.oMi[ref.jid[-1]]
    f, mo = oMb.rotation @ w[:3], oMb.rotation @ w[3:]
    r = oMt.translation - oMj.translation
    out = [pin.Force.Zero() for _ in range(m.njoints)]
    out[ref.jid[-1]] = pin.Force(oMj.rotation.T @ f, oMj.rotation.T @ (mo + np.cross(r, f)))
    return out


@pytest.mark.parametrize("backend", BACKENDS)
def test_kinetic_energy_includes_the_armature(case, backend):
    robot, ref = case.robots[backend], case.ref
    Q, QD, _, _ = batch(robot, 6, seed=3)
    T = np.array([0.5 * qd @ ref.mass_matrix(q) @ qd for q, qd in zip(Q, QD)])
    T0 = np.array([0.5 * qd @ case.ref0.mass_matrix(q) @ qd for q, qd in zip(Q, QD)])
    assert np.all(T - T0 > 1e-6 * T)                     # the rotors carry energy
    np.testing.assert_allclose(T - T0, 0.5 * np.sum(robot.armature * QD**2, axis=1), rtol=1e-9)
    assert abs(robot.kinetic_energy(Q[0], QD[0]) - T[0]) <= RTOL * T[0]
    np.testing.assert_allclose(robot.kinetic_energy(Q, QD), T, rtol=RTOL)
    M = robot.mass_matrix(Q)
    np.testing.assert_allclose(robot.kinetic_energy(Q, QD),
                               0.5 * np.einsum("ni,nij,nj->n", QD, M, QD), rtol=1e-13)


def test_armature_compiled_matches_reference(case):
    fast, slow = case.robots["numba"], case.robots["numpy"]
    Q, QD, QDD, W = batch(fast, 9, seed=4)
    for args in ((Q, QD, QDD), (Q[0], QD[0], QDD[0])):
        assert rel_err(fast.inverse_dynamics(*args), slow.inverse_dynamics(*args)) <= XTOL
    assert rel_err(fast.inverse_dynamics(Q, QD, QDD, wrench=W),
                   slow.inverse_dynamics(Q, QD, QDD, wrench=W)) <= XTOL
    assert rel_err(fast.mass_matrix(Q), slow.mass_matrix(Q)) <= XTOL
    TAU = slow.inverse_dynamics(Q, QD, QDD)
    for method in FD_METHODS:
        assert rel_err(fast.forward_dynamics(Q, QD, TAU, method=method),
                       slow.forward_dynamics(Q, QD, TAU, method=method)) <= 1e-11, method
    assert rel_err(fast.kinetic_energy(Q, QD), slow.kinetic_energy(Q, QD)) <= XTOL


def test_armature_batch_rows_are_single_calls_bitwise(case):
    robot = case.robots["numba"]
    Q, QD, QDD, W = batch(robot, 37, seed=5)          # one 32-lane block and a remainder
    out = robot.inverse_dynamics(Q, QD, QDD)
    out_w = robot.inverse_dynamics(Q, QD, QDD, wrench=W)
    for k in range(len(Q)):
        np.testing.assert_array_equal(out[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k]))
        np.testing.assert_array_equal(out_w[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k],
                                                                       wrench=W[k]))


# ---------------------------------------------------------------- armature from <transmission>
DRAKE_NS = 'xmlns:drake="http://drake.mit.edu"'


def _simple(block):
    return block.count("<actuator") == 1 and len(re.findall(r"<joint\b", block)) == 1


def _inject_rotors(text, J, declare=True, only=_simple):
    """The <actuator> of every simple transmission (one joint, one actuator) of ``text``
    gets a drake:rotor_inertia, J[k] for the k-th; ``only`` picks other transmissions."""
    k = iter(range(10**6))

    def inject(match):
        block = match.group(0)
        if not only(block):
            return block
        return block.replace("</actuator>", f'<drake:rotor_inertia value="{J[next(k)]!r}"/></actuator>')

    text = re.sub(r"<transmission\b.*?</transmission>", inject, text, flags=re.S)
    if declare:
        text = re.sub(r"<robot\b", f"<robot {DRAKE_NS}", text, count=1)
    return text


def _transmission_ratios(path):
    """[(joint, gear ratio)] of each simple transmission, read independently (ElementTree)."""
    out = []
    for tr in ET.parse(path).getroot().iter("transmission"):
        if len(tr.findall("actuator")) != 1 or len(tr.findall("joint")) != 1:
            continue
        red = tr.find("actuator/mechanicalReduction")
        out.append((tr.find("joint").get("name"), 1.0 if red is None else float(red.text)))
    return out


@pytest.mark.parametrize("declare", [True, False], ids=["declared_ns", "undeclared_prefix"])
def test_rotor_inertia_from_xarm7_transmissions(tmp_path, declare):
    src = erd("xarm_description/urdf/xarm7.urdf")
    ratios = _transmission_ratios(src)
    assert len(ratios) == 7 and all(r == 100.0 for _, r in ratios)
    J = [1e-5 * (k + 1) for k in range(len(ratios))]
    path = tmp_path / "xarm7_rotors.urdf"
    path.write_text(_inject_rotors(open(src).read(), J, declare))
    robot = quiet_load(str(path))
    expected = {j: r * r * Jk for (j, r), Jk in zip(ratios, J)}
    np.testing.assert_allclose(robot.armature, [expected[j] for j in robot.joint_names],
                               rtol=1e-15)
    assert robot.armature[0] == pytest.approx(0.1)        # 100^2 * 1e-5
    # against Pinocchio (the unmodified file) with the armature we expect
    plain = quiet_load(src)
    ref = fixed_reference(plain, src, armature=[expected[j] for j in plain.joint_names])
    for r in (robot, sd.Robot(robot.model, backend="numpy")):
        for q, qd, qdd, _ in states(r, count=2, seed=6):
            assert rel_err(r.inverse_dynamics(q, qd, qdd), ref.rnea(q, qd, qdd)) <= RTOL
            assert rel_err(r.mass_matrix(q), ref.mass_matrix(q)) <= RTOL
    # armature= overrides one joint's transmission, the others keep theirs
    over = quiet_load(str(path), armature={"joint3": 0.7})
    exp = [0.7 if j == "joint3" else expected[j] for j in over.joint_names]
    np.testing.assert_allclose(over.armature, exp, rtol=1e-15)


def test_rotor_inertia_from_tiago_transmissions_off_chain_warns(tmp_path):
    src = erd("tiago_description/robots/tiago_no_hand.urdf")
    ratios = _transmission_ratios(src)
    J = [2e-4 * (k + 1) for k in range(len(ratios))]
    path = tmp_path / "tiago_rotors.urdf"
    path.write_text(_inject_rotors(open(src).read(), J))
    with pytest.warns(sd.HeldJointsWarning) as record:
        robot = sd.load_urdf(str(path), None, "wrist_ft_tool_link", gravity=G_WORLD)
    text = " ".join(str(w.message) for w in record if "transmission" in str(w.message))
    off = sorted(j for j, _ in ratios if j not in robot.joint_names)
    assert off and all(j in text for j in off), (off, text)   # wheels, head: named, ignored
    assert not any(j in text for j in robot.joint_names)
    expected = {j: r * r * Jk for (j, r), Jk in zip(ratios, J)}
    assert robot.joint_types[0] == "prismatic"
    np.testing.assert_allclose(robot.armature, [expected.get(j, 0.0) for j in robot.joint_names],
                               rtol=1e-15)
    assert np.count_nonzero(robot.armature) == robot.dof - 2    # the differential wrist: none
    plain = quiet_load(src, None, "wrist_ft_tool_link")
    ref = fixed_reference(plain, src, armature=[expected.get(j, 0.0) for j in plain.joint_names])
    for q, qd, qdd, _ in states(robot, count=2, seed=7):
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), ref.rnea(q, qd, qdd)) <= RTOL
        assert rel_err(robot.forward_dynamics(q, qd, ref.rnea(q, qd, qdd)), qdd) <= 1e-8
    # a rotor inertia in its differential wrist transmission (two joints, two actuators)
    # is refused, naming the transmission
    path.write_text(_inject_rotors(open(src).read(), [1e-4] * 2, only=lambda b: not _simple(b)))
    with pytest.raises(sd.URDFError, match="wrist_trans"):
        quiet_load(str(path), None, "wrist_ft_tool_link")


def _with_transmissions(*transmissions, n=3, ns=True):
    xml = chain_urdf(n)
    if ns:
        xml = xml.replace('<robot name="chain">', f'<robot name="chain" {DRAKE_NS}>')
    return xml.replace("</robot>", "\n".join(transmissions) + "\n</robot>")


def _tr(name, joint, body, joints=None):
    js = joints if joints is not None else f'<joint name="{joint}"/>'
    return (f'<transmission name="{name}">{js}<actuator name="{name}_motor">{body}</actuator>'
            "</transmission>")


def test_gear_ratio_sources_and_default():
    xml = _with_transmissions(
        _tr("t1", "joint1", '<drake:rotor_inertia value="0.002"/><drake:gear_ratio value="3"/>'
                            "<mechanicalReduction>50</mechanicalReduction>"),     # drake wins
        _tr("t2", "joint2", '<mechanicalReduction>20</mechanicalReduction>'
                            '<drake:rotor_inertia value="0.0005"/>'),            # ROS ratio
        _tr("t3", "joint3", '<drake:rotor_inertia value="0.125"/>'))             # ratio 1
    robot = sd.load_urdf(xml)
    np.testing.assert_allclose(robot.armature, [9 * 0.002, 400 * 0.0005, 0.125], rtol=1e-15)
    # a transmission without a rotor inertia adds nothing
    robot = sd.load_urdf(_with_transmissions(
        _tr("t1", "joint1", "<mechanicalReduction>50</mechanicalReduction>")))
    np.testing.assert_array_equal(robot.armature, np.zeros(3))
    # undeclared prefix reads the same
    und = sd.load_urdf(_with_transmissions(
        _tr("t3", "joint3", '<drake:rotor_inertia value="0.125"/>'), ns=False))
    np.testing.assert_array_equal(und.armature, [0, 0, 0.125])
    # its effect, exactly as a diagonal term: tau = tau_0 + I_a qdd
    plain = sd.load_urdf(chain_urdf(3))
    q, qd, qdd = np.array([0.3, -0.5, 1.1]), np.array([1.0, -2.0, 0.5]), np.array([2.0, 1.0, -3.0])
    np.testing.assert_allclose(und.inverse_dynamics(q, qd, qdd) - plain.inverse_dynamics(q, qd, qdd),
                               [0, 0, 0.125 * -3.0], atol=1e-12)
    np.testing.assert_allclose(und.mass_matrix(q) - plain.mass_matrix(q),
                               np.diag([0, 0, 0.125]), atol=1e-14)


def test_transmission_off_the_chain_is_ignored_with_a_warning():
    xml = _with_transmissions(_tr("t3", "joint3", '<drake:rotor_inertia value="0.5"/>'),
                              _tr("t1", "joint1", '<drake:rotor_inertia value="0.25"/>'))
    with pytest.warns(sd.HeldJointsWarning, match="joint3") as record:
        robot = sd.load_urdf(xml, "base_link", "link2")
    assert any("transmission" in str(w.message) for w in record)
    assert robot.joint_names == ["joint1", "joint2"]
    np.testing.assert_array_equal(robot.armature, [0.25, 0.0])


@pytest.mark.parametrize("transmission, culprit", [
    (_tr("bad_value", "joint1", '<drake:rotor_inertia value="heavy"/>'), "bad_value"),
    (_tr("negative", "joint2", '<drake:rotor_inertia value="-0.1"/>'), "negative"),
    (_tr("nan_value", "joint2", '<drake:rotor_inertia value="nan"/>'), "nan_value"),
    (_tr("bad_ratio", "joint1", '<drake:rotor_inertia value="0.1"/><drake:gear_ratio value="x"/>'),
     "bad_ratio"),
    (_tr("bad_reduction", "joint1",
         '<drake:rotor_inertia value="0.1"/><mechanicalReduction>ten</mechanicalReduction>'),
     "bad_reduction"),
    (_tr("two_joints", None, '<drake:rotor_inertia value="0.1"/>',
         joints='<joint name="joint1"/><joint name="joint2"/>'), "two_joints"),
    (_tr("twice_a", "joint2", '<drake:rotor_inertia value="0.1"/>') + "\n"
     + _tr("twice_b", "joint2", '<drake:rotor_inertia value="0.2"/>'), "twice_b"),
], ids=["non_numeric", "negative", "nan", "bad_gear_ratio", "bad_reduction", "two_joints",
        "two_transmissions_one_joint"])
def test_malformed_transmission_names_it(transmission, culprit):
    with pytest.raises(sd.URDFError) as info:
        sd.load_urdf(_with_transmissions(transmission))
    assert culprit in str(info.value)


def test_armature_argument_errors_name_the_joint():
    xml = chain_urdf(3)
    with pytest.raises(sd.URDFError, match="'no_such_joint'"):
        sd.load_urdf(xml, armature={"no_such_joint": 0.1})
    with pytest.raises(sd.URDFError, match="'joint3'"):       # a joint off the chain
        quiet_load(xml, "base_link", "link2", armature={"joint3": 0.1})
    with pytest.raises((sd.ModelError, sd.URDFError), match="joint2.*< 0"):
        sd.load_urdf(xml, armature={"joint2": -0.1})
    with pytest.raises((sd.ModelError, sd.URDFError), match="joint1.*NaN"):
        sd.load_urdf(xml, armature={"joint1": float("nan")})
    # a negative override of a transmission's (valid) value is refused as well
    with pytest.raises((sd.ModelError, sd.URDFError), match="joint3"):
        sd.load_urdf(_with_transmissions(_tr("t3", "joint3", '<drake:rotor_inertia value="0.1"/>')),
                     armature={"joint3": -1.0})


def test_non_numeric_armature_argument_names_the_joint():
    with pytest.raises(ValueError, match="joint2"):
        sd.load_urdf(chain_urdf(3), armature={"joint2": "heavy"})


# ============================================================================ payload
def _payload_links(case):
    robot = case.robots["numba"]
    return [None, robot.link_names[robot.dof // 2], *case.extra_links]


@pytest.mark.parametrize("backend", BACKENDS)
def test_payload_against_pinocchio(case, backend):
    robot = case.robots[backend]
    for link in _payload_links(case):
        loaded = robot.with_payload(**PAYLOAD, link=link)
        name = robot.tip_link if link is None else link
        assert loaded.payload.link == name
        ref = fixed_reference(robot, case.path, armature=robot.armature,
                              payload=(name, PAYLOAD["mass"], PAYLOAD["com"], PAYLOAD["inertia"]))
        for q, qd, qdd, w in states(robot, count=2, seed=8):
            tau = ref.rnea(q, qd, qdd)
            assert rel_err(loaded.inverse_dynamics(q, qd, qdd), tau) <= RTOL, name
            assert rel_err(case.ref.rnea(q, qd, qdd), tau) > 1e-6, name    # it matters
            assert rel_err(loaded.mass_matrix(q), ref.mass_matrix(q)) <= RTOL, name
            assert rel_err(loaded.gravity_torques(q), ref.gravity(q)) <= RTOL, name
            tau_w = ref.rnea(q, qd, qdd, pin_fext_fixed(ref, robot, q, w))
            assert rel_err(loaded.inverse_dynamics(q, qd, qdd, wrench=w), tau_w) <= RTOL, name
            for method in ("cholesky", "aba"):
                assert rel_err(loaded.forward_dynamics(q, qd, tau, method=method),
                               ref.aba(q, qd, tau)) <= RTOL, (name, method)
        Q, QD, QDD, _ = batch(robot, 6, seed=9)
        expect = np.array([ref.rnea(*s) for s in zip(Q, QD, QDD)])
        assert rel_err(loaded.inverse_dynamics(Q, QD, QDD), expect) <= RTOL, name
        assert rel_err(loaded.forward_dynamics(Q, QD, expect), QDD) <= 1e-8, name
        assert rel_err(loaded.mass_matrix(Q), np.array([ref.mass_matrix(q) for q in Q])) <= RTOL
        T = np.array([0.5 * qd @ ref.mass_matrix(q) @ qd for q, qd in zip(Q, QD)])
        np.testing.assert_allclose(loaded.kinetic_energy(Q, QD), T, rtol=RTOL)


def test_payload_properties():
    robot = quiet_load(erd("panda_description/urdf/panda.urdf"), "panda_link0", "panda_link8")
    assert robot.payload is None
    loaded = robot.with_payload(**PAYLOAD)
    p = loaded.payload
    assert p.mass == 2.5 and p.link == "panda_link8"
    np.testing.assert_array_equal(p.com, PAYLOAD["com"])
    np.testing.assert_array_equal(p.inertia, PAYLOAD["inertia"])
    np.testing.assert_array_equal(p.inertia_matrix, [[0.02, 0.001, -0.002], [0.001, 0.025, 0.0015],
                                                     [-0.002, 0.0015, 0.03]])
    assert robot.payload is None
    assert loaded.without_payload().payload is None
    assert robot.with_payload(1.0, link="panda_link3").payload.link == "panda_link3"
    # a point mass by default: com (0, 0, 0) and zero inertia
    point = robot.with_payload(3.0)
    np.testing.assert_array_equal(point.payload.com, [0, 0, 0])
    np.testing.assert_array_equal(point.payload.inertia, [0] * 6)


@pytest.mark.parametrize("backend", BACKENDS)
def test_without_payload_is_bitwise_the_loaded_robot(case, backend):
    robot = case.robots[backend]
    Q, QD, QDD, W = batch(robot, 5, seed=10)
    q, qd, qdd = Q[0], QD[0], QDD[0]

    def results(r):
        return [r.inverse_dynamics(q, qd, qdd), r.inverse_dynamics(Q, QD, QDD, wrench=W),
                r.inverse_dynamics(q, qd, qdd, base_motion=BM), r.mass_matrix(Q),
                r.bias_torques(q, qd), r.gravity_torques(Q), r.forward_dynamics(q, qd, qdd),
                r.forward_dynamics(Q, QD, QDD, method="aba"), r.kinetic_energy(Q, QD)]

    before = results(robot)
    first = robot.with_payload(**PAYLOAD)
    second = first.with_payload(1.0, com=(0.0, 0.1, 0.0), inertia=(1e-3, 1e-3, 1e-3, 0, 0, 0),
                                link=robot.link_names[1])
    alone = robot.with_payload(1.0, com=(0.0, 0.1, 0.0), inertia=(1e-3, 1e-3, 1e-3, 0, 0, 0),
                               link=robot.link_names[1])
    # the original is unchanged, and a payload removed leaves it bitwise as loaded
    for r in (robot, first.without_payload(), second.without_payload()):
        for a, b in zip(results(r), before):
            np.testing.assert_array_equal(a, b)
    # a second payload replaces the first (not cumulative)
    assert second.payload.mass == 1.0 and second.payload.link == robot.link_names[1]
    for a, b in zip(results(second), results(alone)):
        np.testing.assert_array_equal(a, b)
    assert rel_err(results(first)[0], before[0]) > 1e-6
    assert rel_err(results(second)[0], results(first)[0]) > 1e-6
    assert second.backend == robot.backend == first.without_payload().backend


def test_payload_compiled_matches_reference(case):
    fast, slow = case.robots["numba"], case.robots["numpy"]
    Q, QD, QDD, W = batch(fast, 8, seed=11)
    for link in _payload_links(case):
        f, s = fast.with_payload(**PAYLOAD, link=link), slow.with_payload(**PAYLOAD, link=link)
        assert s.backend == "numpy"
        assert rel_err(f.inverse_dynamics(Q, QD, QDD, wrench=W),
                       s.inverse_dynamics(Q, QD, QDD, wrench=W)) <= XTOL
        assert rel_err(f.inverse_dynamics(Q[0], QD[0], QDD[0]),
                       s.inverse_dynamics(Q[0], QD[0], QDD[0])) <= XTOL
        assert rel_err(f.mass_matrix(Q), s.mass_matrix(Q)) <= XTOL
        assert rel_err(f.forward_dynamics(Q, QD, QDD), s.forward_dynamics(Q, QD, QDD)) <= 1e-11


def test_payload_is_a_lumped_rigid_body_exactly_as_a_urdf_link(tmp_path):
    """The same payload written into the URDF as a link fixed to the tip: the same dynamics."""
    xml = tilted_chain_urdf(["revolute", "prismatic", "revolute", "revolute"], seed=3)
    m, c, (ixx, iyy, izz, ixy, ixz, iyz) = PAYLOAD["mass"], PAYLOAD["com"], PAYLOAD["inertia"]
    extra = (f'<link name="load"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" rpy="0 0 0"/>'
             f'<mass value="{m}"/><inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" '
             f'iyz="{iyz}" izz="{izz}"/></inertial></link><joint name="load_joint" type="fixed">'
             '<parent link="tool"/><child link="load"/><origin xyz="0 0 0" rpy="0 0 0"/></joint>')
    robot = quiet_load(xml, None, "tool")
    urdf_load = quiet_load(xml.replace("</robot>", extra + "</robot>"), None, "tool")
    loaded = robot.with_payload(**PAYLOAD)
    Q, QD, QDD, _ = batch(robot, 5, seed=12)
    assert rel_err(loaded.inverse_dynamics(Q, QD, QDD), urdf_load.inverse_dynamics(Q, QD, QDD)) <= 1e-12
    assert rel_err(loaded.mass_matrix(Q), urdf_load.mass_matrix(Q)) <= 1e-12


@pytest.mark.parametrize("kwargs, match", [
    (dict(mass=-1.0), "mass"),
    (dict(mass=float("nan")), "mass"),
    (dict(mass=1.0, com=(0.0, float("nan"), 0.0)), "com"),
    (dict(mass=1.0, inertia=(0.01, float("inf"), 0.01, 0, 0, 0)), "inertia"),
    (dict(mass=1.0, inertia=(-0.01, 0.01, 0.01, 0, 0, 0)), "positive semi-definite"),
    (dict(mass=1.0, inertia=(0.01, 0.01, 0.01, 0.02, 0, 0)), "positive semi-definite"),
    (dict(mass=1.0, inertia=(0.01, 0.01, 0.05, 0, 0, 0)), "triangle"),
    (dict(mass=1.0, com=(0.0, 0.1)), "com"),
    (dict(mass=1.0, inertia=(0.01, 0.01, 0.01)), "inertia"),
    (dict(mass=1.0, link="no_such_link"), "'no_such_link'"),
    (dict(mass=1.0, link="panda_link0"), "'panda_link0'.*base"),     # the base link itself
], ids=["negative_mass", "nan_mass", "nan_com", "inf_inertia", "negative_moment",
        "indefinite_products", "triangle", "com_shape", "inertia_shape", "unknown_link",
        "base_link"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_payload_bad_input_names_it(kwargs, match, backend):
    robot = sd.Robot(quiet_load(erd("panda_description/urdf/panda.urdf"), "panda_link0",
                                "panda_link8").model, backend=backend)
    with pytest.raises(ValueError, match=match) as info:
        robot.with_payload(**kwargs)
    assert "payload" in str(info.value)
    assert robot.payload is None


def test_payload_links_off_the_chain_or_fixed_to_the_base():
    # tiago from the root: the wheels hang from the base (fixed to it: nothing moves them)
    robot = quiet_load(erd("tiago_description/robots/tiago_no_hand.urdf"), None, "wrist_ft_tool_link")
    for link in ("base_footprint", "wheel_left_link"):
        with pytest.raises(ValueError, match=f"'{link}'.*fixed to the base"):
            robot.with_payload(1.0, link=link)
    # from the torso: the root is above the base, not a link of the chain
    torso = quiet_load(erd("tiago_description/robots/tiago_no_hand.urdf"), "torso_fixed_link",
                       "wrist_ft_tool_link")
    with pytest.raises(ValueError, match="'base_footprint'.*not a link of the chain"):
        torso.with_payload(1.0, link="base_footprint")


# ============================================================================ base motion
@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_inverse_dynamics(case, backend):
    robot, ff = case.robots[backend], case.ff
    for q, qd, qdd, w in states(robot, seed=13):
        tau = ff.rnea(q, qd, qdd, BM)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=BM), tau) <= RTOL
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) > 1e-4       # it matters
        tau_w = ff.rnea(q, qd, qdd, BM, w)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, wrench=w, base_motion=BM), tau_w) <= RTOL
        assert rel_err(robot.bias_torques(q, qd, base_motion=BM),
                       ff.rnea(q, qd, 0 * qdd, BM)) <= RTOL
        assert rel_err(robot.bias_torques(q, qd, wrench=w, base_motion=BM),
                       ff.rnea(q, qd, 0 * qdd, BM, w)) <= RTOL
    # the free-flyer oracle without base motion is the fixed-base one
    rest = sd.BaseMotion()
    assert rel_err(ff.rnea(q, qd, qdd, rest), case.ref.rnea(q, qd, qdd)) <= 1e-12
    assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=rest),
                   robot.inverse_dynamics(q, qd, qdd)) <= 1e-14
    # each component of the motion alone
    for bm in (sd.BaseMotion(angular_velocity=(0.0, 0.0, 2.0)),
               sd.BaseMotion(angular_acceleration=(1.0, -3.0, 0.5)),
               sd.BaseMotion(linear_acceleration=(0.0, 4.0, -1.0))):
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=bm),
                       ff.rnea(q, qd, qdd, bm)) <= RTOL, bm


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_batch(case, backend):
    robot, ff = case.robots[backend], case.ff
    Q, QD, QDD, W = batch(robot, 11, seed=14)
    expect = np.array([ff.rnea(*s, BM) for s in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, base_motion=BM), expect) <= RTOL
    expect_w = np.array([ff.rnea(q, qd, qdd, BM, w) for q, qd, qdd, w in zip(Q, QD, QDD, W)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, wrench=W, base_motion=BM), expect_w) <= RTOL
    # one wrench broadcast over the batch
    expect_w0 = np.array([ff.rnea(q, qd, qdd, BM, W[0]) for q, qd, qdd in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, wrench=W[0], base_motion=BM), expect_w0) <= RTOL
    assert rel_err(robot.bias_torques(Q, QD, base_motion=BM),
                   np.array([ff.rnea(q, qd, 0 * q, BM) for q, qd in zip(Q, QD)])) <= RTOL
    tau = np.random.default_rng(15).uniform(-20, 20, Q.shape)
    qdd = np.array([ff.forward(q, qd, t, BM) for q, qd, t in zip(Q, QD, tau)])
    qdd_w = np.array([ff.forward(q, qd, t, BM, w) for q, qd, t, w in zip(Q, QD, tau, W)])
    for method in FD_METHODS:
        assert rel_err(robot.forward_dynamics(Q, QD, tau, base_motion=BM, method=method), qdd) <= 1e-8
        assert rel_err(robot.forward_dynamics(Q, QD, tau, wrench=W, base_motion=BM, method=method),
                       qdd_w) <= 1e-8


@pytest.mark.parametrize("method", FD_METHODS)
@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_forward_dynamics(case, backend, method):
    robot, ff = case.robots[backend], case.ff
    rng = np.random.default_rng(16)
    for q, qd, _, w in states(robot, count=2, seed=17):
        tau = rng.uniform(-20, 20, robot.dof)
        qdd = robot.forward_dynamics(q, qd, tau, base_motion=BM, method=method)
        assert rel_err(qdd, ff.forward(q, qd, tau, BM)) <= 1e-8
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=BM), tau) <= 1e-9
        assert rel_err(robot.forward_dynamics(q, qd, tau, method=method), qdd) > 1e-4
        qdd_w = robot.forward_dynamics(q, qd, tau, wrench=w, base_motion=BM, method=method)
        assert rel_err(qdd_w, ff.forward(q, qd, tau, BM, w)) <= 1e-8
        assert rel_err(robot.inverse_dynamics(q, qd, qdd_w, wrench=w, base_motion=BM), tau) <= 1e-9


def test_base_motion_compiled_matches_reference(case):
    fast, slow = case.robots["numba"], case.robots["numpy"]
    Q, QD, QDD, W = batch(fast, 9, seed=18)
    for kw in (dict(base_motion=BM), dict(base_motion=BM, wrench=W)):
        assert rel_err(fast.inverse_dynamics(Q, QD, QDD, **kw),
                       slow.inverse_dynamics(Q, QD, QDD, **kw)) <= XTOL
        assert rel_err(fast.bias_torques(Q, QD, **kw), slow.bias_torques(Q, QD, **kw)) <= XTOL
        for method in FD_METHODS:
            assert rel_err(fast.forward_dynamics(Q, QD, QDD, method=method, **kw),
                           slow.forward_dynamics(Q, QD, QDD, method=method, **kw)) <= 1e-11
    for k in range(2):
        for kw in (dict(base_motion=BM), dict(base_motion=BM, wrench=W[k])):
            assert rel_err(fast.inverse_dynamics(Q[k], QD[k], QDD[k], **kw),
                           slow.inverse_dynamics(Q[k], QD[k], QDD[k], **kw)) <= XTOL
            assert rel_err(fast.bias_torques(Q[k], QD[k], **kw),
                           slow.bias_torques(Q[k], QD[k], **kw)) <= XTOL
            for method in FD_METHODS:
                assert rel_err(fast.forward_dynamics(Q[k], QD[k], QDD[k], method=method, **kw),
                               slow.forward_dynamics(Q[k], QD[k], QDD[k], method=method, **kw)) <= 1e-11


def test_base_motion_batch_rows_are_single_calls_bitwise(case):
    robot = case.robots["numba"]
    Q, QD, QDD, W = batch(robot, 37, seed=19)
    out = robot.inverse_dynamics(Q, QD, QDD, base_motion=BM)
    out_w = robot.inverse_dynamics(Q, QD, QDD, wrench=W, base_motion=BM)
    out_b = robot.bias_torques(Q, QD, base_motion=BM)
    for k in range(len(Q)):
        np.testing.assert_array_equal(out[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k],
                                                                     base_motion=BM))
        np.testing.assert_array_equal(out_w[k], robot.inverse_dynamics(
            Q[k], QD[k], QDD[k], wrench=W[k], base_motion=BM))
        np.testing.assert_array_equal(out_b[k], robot.bias_torques(Q[k], QD[k], base_motion=BM))


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_translation_is_a_change_of_gravity(case, backend):
    """A base accelerating at a_0 (no rotation) is the base at rest under gravity g - a_0."""
    robot = case.robots[backend]
    a0 = np.array([1.5, -2.0, 3.25])
    shifted = _with_gravity(case, G_WORLD - a0, backend)
    np.testing.assert_array_equal(shifted.gravity, G_WORLD - a0)
    bm = sd.BaseMotion(linear_acceleration=a0)
    Q, QD, QDD, _ = batch(robot, 6, seed=20)
    # the oracles agree on it too (a_0 is the classical acceleration of the base origin)
    ref = PinReference(robot, case.path)
    ref.model.gravity.linear[:] = G_WORLD - a0
    ref.model.armature[ref.iv] = robot.armature
    ref.data = ref.model.createData()
    assert rel_err(case.ff.rnea(Q[0], QD[0], QDD[0], bm), ref.rnea(Q[0], QD[0], QDD[0])) <= 1e-12
    assert rel_err(robot.inverse_dynamics(Q[0], QD[0], QDD[0], base_motion=bm),
                   ref.rnea(Q[0], QD[0], QDD[0])) <= RTOL
    np.testing.assert_array_equal(robot.inverse_dynamics(Q, QD, QDD, base_motion=bm),
                                  shifted.inverse_dynamics(Q, QD, QDD))
    np.testing.assert_array_equal(robot.inverse_dynamics(Q[0], QD[0], QDD[0], base_motion=bm),
                                  shifted.inverse_dynamics(Q[0], QD[0], QDD[0]))
    np.testing.assert_array_equal(robot.bias_torques(Q, QD, base_motion=bm),
                                  shifted.bias_torques(Q, QD))
    assert rel_err(robot.forward_dynamics(Q, QD, QDD, base_motion=bm),
                   shifted.forward_dynamics(Q, QD, QDD)) <= 1e-12


def _with_gravity(case, g, backend):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        r = sd.load_urdf(case.path, case.base, case.tip, gravity=g, armature=case.arm)
    return sd.Robot(r.model, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_bad_input(backend):
    robot = sd.Robot(sd.load_urdf(chain_urdf(4, kinds=["revolute", "prismatic"] * 2)).model,
                     backend=backend)
    n = robot.dof
    q, Q = np.zeros(n), np.zeros((3, n))
    for field in ("angular_velocity", "angular_acceleration", "linear_acceleration"):
        with pytest.raises(ValueError, match=f"{field}.*NaN"):
            sd.BaseMotion(**{field: (0.0, float("nan"), 0.0)})
        with pytest.raises(ValueError, match=f"{field}.*Inf"):
            sd.BaseMotion(**{field: (float("inf"), 0.0, 0.0)})
        for bad in ((1.0, 2.0), np.zeros((3, 1)), (1, 2, 3, 4)):
            with pytest.raises(ValueError, match=f"{field} has shape"):
                sd.BaseMotion(**{field: bad})
    for bad in ((0.0, 0.0, 1.0), np.zeros(9), {"angular_velocity": (0, 0, 1)}, "BM"):
        for x in (q, Q):
            for call in (lambda: robot.inverse_dynamics(x, x, x, base_motion=bad),
                         lambda: robot.inverse_dynamics(x, x, x, wrench=np.zeros(6), base_motion=bad),
                         lambda: robot.bias_torques(x, x, base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, method="aba", base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, method="qr", base_motion=bad)):
                with pytest.raises(TypeError, match="BaseMotion"):
                    call()
    # a BaseMotion is immutable: its arrays cannot be changed behind the robot's back
    bm = sd.BaseMotion(angular_velocity=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError):
        bm.angular_velocity[0] = 5.0
    # the state is still validated, naming the argument
    with pytest.raises(ValueError, match="qd"):
        robot.inverse_dynamics(q, np.zeros(n + 1), q, base_motion=bm)
    with pytest.raises(ValueError, match="wrench"):
        robot.inverse_dynamics(q, q, q, wrench=np.zeros(5), base_motion=bm)
