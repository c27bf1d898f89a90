"""The cases the modelling tests share (test_armature, test_transmissions, test_payload,
test_base_motion): real robots (example-robot-data) and synthetic chains, each loaded with
armature, with its Pinocchio oracles (fixed base, and a free-flyer root for a base with known
motion). Built once per session.

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
from serial_dynamics.builtin.synthetic import chain_urdf

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


@pytest.fixture(scope="session")
def tmpdir_chains(tmp_path_factory):
    return str(tmp_path_factory.mktemp("modelling_urdfs"))


@pytest.fixture(scope="session", params=sorted(CHAINS))
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
