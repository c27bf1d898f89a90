"""Property-based tests of the URDF loader (hypothesis; issue 13).

- Random valid chains (random joint kinds and axes, origins, inertias, fixed links in the
  chain, off-chain branches held or lumped) load, agree with Pinocchio's full model (the
  joints we hold at neutral), and obey identities that need no reference: M symmetric
  positive definite, forward dynamics inverts inverse dynamics, and the O(n) singularity
  check's numbers are those of the dense mass matrix.
- Random corruptions of those files (NaN, huge, negative, missing, garbage values, missing
  or duplicated elements, cycles, unknown references and types) either load a valid model
  or raise ``sd.RobotDescriptionError`` (``URDFError`` / ``ModelError``) whose message
  names an element of the file: never another exception, never a hang. The issue's cases
  are explicit examples.
"""
import copy
import signal
import warnings
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from lxml import etree

import serial_dynamics as sd
from serial_dynamics.urdf.mass_matrix import _diagonal_and_pivots

SETTINGS = dict(deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
TIMEOUT = 10      # s per example: a hang fails the test instead of stalling the suite


@contextmanager
def time_limit(seconds=TIMEOUT):
    def hang(signum, frame):
        raise TimeoutError(f"loading took more than {seconds} s")
    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


# ---------------------------------------------------------------- random valid chains
def f(x):
    return repr(float(x))


def vec(v):
    return " ".join(f(x) for x in v)


unit = st.floats(-1.0, 1.0, allow_nan=False)
length = st.floats(-0.5, 0.5, allow_nan=False)
angle = st.floats(-np.pi, np.pi, allow_nan=False)
axes = st.tuples(unit, unit, unit).filter(lambda a: np.linalg.norm(a) > 0.1)


@st.composite
def inertials(draw, massless_ok=False):
    """<inertial> of a body of positive mass and full-rank inertia (second moments s_k > 0
    along principal axes turned by rpy: I_x = s_y + s_z, ...), or nothing."""
    if massless_ok and draw(st.booleans()):
        return ""
    m = draw(st.floats(0.1, 5.0))
    s = draw(st.tuples(*[st.floats(1e-4, 0.05)] * 3))
    I = np.diag([s[1] + s[2], s[0] + s[2], s[0] + s[1]]) * m
    r, p, y = draw(st.tuples(angle, angle, angle))
    R = rpy_matrix(r, p, y)
    I = R @ I @ R.T
    com = draw(st.tuples(length, length, length))
    return (f'<inertial><origin xyz="{vec(com)}" rpy="0 0 0"/><mass value="{f(m)}"/>'
            f'<inertia ixx="{f(I[0, 0])}" ixy="{f(I[0, 1])}" ixz="{f(I[0, 2])}" '
            f'iyy="{f(I[1, 1])}" iyz="{f(I[1, 2])}" izz="{f(I[2, 2])}"/></inertial>')


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
            @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


@st.composite
def joints(draw, name, parent, child, kind):
    xyz = draw(st.tuples(length, length, length))
    rpy = draw(st.tuples(angle, angle, angle))
    axis = draw(axes)
    lo = draw(st.floats(-3.0, 0.0))
    hi = lo + draw(st.floats(0.1, 3.0))
    limit = ("" if kind == "fixed" else
             f'<limit lower="{f(lo)}" upper="{f(hi)}" effort="100" velocity="10"/>')
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{vec(xyz)}" rpy="{vec(rpy)}"/>'
            f'<axis xyz="{vec(axis)}"/>{limit}</joint>')


@st.composite
def chains(draw, max_joints=6):
    """(URDF XML, the chain's movable joints, its tip link, whether joints are held)."""
    n = draw(st.integers(1, max_joints))
    parts, chain, held = ['<link name="base_link"/>'], [], False
    parent, k = "base_link", 0

    def new_link(massless_ok):
        nonlocal k
        k += 1
        return f"l{k}", draw(inertials(massless_ok=massless_ok))

    for i in range(n):
        if draw(st.integers(0, 3)) == 0:                       # a fixed link on the chain
            name, inertial = new_link(True)
            parts += [f'<link name="{name}">{inertial}</link>',
                      draw(joints(f"fixed{k}", parent, name, "fixed"))]
            parent = name
        kind = draw(st.sampled_from(["revolute", "continuous", "prismatic"]))
        name, inertial = new_link(False)
        parts += [f'<link name="{name}">{inertial}</link>',
                  draw(joints(f"j{i}", parent, name, kind))]
        chain.append(f"j{i}")
        parent = name
        branch = draw(st.sampled_from([None, None, "fixed", "revolute", "prismatic"]))
        if branch is not None:                                 # off the chain: lumped
            bname, binertial = new_link(True)
            parts += [f'<link name="{bname}">{binertial}</link>',
                      draw(joints(f"off{k}", parent, bname, branch))]
            held = held or branch != "fixed"
    tip = parent
    if draw(st.booleans()):                                    # a fixed tail: the tool
        parts += ['<link name="tool"/>', draw(joints("tool_joint", parent, "tool", "fixed"))]
        tip = "tool"
    order = draw(st.permutations(range(len(parts))))           # any element order
    return ('<robot name="random">' + "".join(parts[j] for j in order) + "</robot>",
            chain, tip, held)


def load(xml, tip=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(xml, tip_link=tip)


def rel_err(actual, expected):
    return np.max(np.abs(actual - expected)) / max(np.max(np.abs(expected)), 1e-300)


@settings(max_examples=250, **SETTINGS)
@given(chains(), st.data())
def test_a_random_chain_loads_and_agrees_with_pinocchio(case, data):
    pin = pytest.importorskip("pinocchio")
    from pin_reference import configuration
    xml, chain, tip, held = case
    with time_limit():
        robot = load(xml, tip)
    assert robot.joint_names == chain and robot.tip_link == tip
    full = pin.buildModelFromXML(xml)               # held joints at neutral, at rest
    pdata = full.createData()
    jid = [full.getJointId(name) for name in chain]
    iv = np.array([full.idx_vs[j] for j in jid])
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    q, qd = robot.random_state(rng, speed=2.0)
    qdd = rng.uniform(-3, 3, robot.dof)

    def v(x):
        out = np.zeros(full.nv)
        out[iv] = x
        return out

    qp = configuration(full, jid, q)
    tau = pin.rnea(full, pdata, qp, v(qd), v(qdd))[iv]
    M = pin.crba(full, pdata, qp)
    M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(iv, iv)]
    assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) <= 1e-9
    assert rel_err(robot.mass_matrix(q), M) <= 1e-9


@settings(max_examples=250, **SETTINGS)
@given(chains(max_joints=8), st.data())
def test_a_random_chain_obeys_the_identities(case, data):
    xml, chain, tip, _ = case
    with time_limit():
        robot = load(xml, tip)
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    q, qd = robot.random_state(rng, speed=2.0)
    qdd = rng.uniform(-3, 3, robot.dof)
    M = robot.mass_matrix(q)
    np.testing.assert_array_equal(M, M.T)
    eig = np.linalg.eigvalsh(M)
    assert eig[0] > 0
    cond = eig[-1] / eig[0]
    for method in ("cholesky", "aba"):
        back = robot.forward_dynamics(q, qd, robot.inverse_dynamics(q, qd, qdd), method=method)
        assert rel_err(back, qdd) <= max(1e-10, 100 * cond * np.finfo(float).eps)
    # the O(n) singularity check reads the dense M: its diagonal, and its pivots, the Schur
    # complements D_i = 1 / ((M_{i:, i:})^-1)_00 (Featherstone 2008, Sec. 6.5 and 7.3)
    diag, pivots = _diagonal_and_pivots(robot.model, q[None])
    np.testing.assert_allclose(diag[0], np.diag(M), rtol=1e-12)
    schur = [1.0 / np.linalg.inv(M[i:, i:])[0, 0] for i in range(robot.dof)]
    np.testing.assert_allclose(pivots[0], schur, rtol=1e-9 * cond)


# ---------------------------------------------------------------- random corruptions
BAD_VALUES = ["nan", "NaN NaN NaN", "inf", "-inf", "1e308", "-1e308", "1e400", "1e-320", "-1",
              "0", "-0", "", " ", "garbage", "1 2", "1 2 3 4", "0 0 0", "1e200 1e200 0",
              "1,0,0", "0x10", "-1e9", "1e9", "1e-200 0 0", "\u00e9", "nope", "base_link"]
JOINT_KINDS = ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "hinge", ""]


@st.composite
def corrupted(draw):
    """A valid random chain with one to three corruptions; (XML, tip_link or None)."""
    xml, chain, tip, _ = draw(chains(max_joints=4))
    root = etree.fromstring(xml)
    for _ in range(draw(st.integers(1, 3))):
        elements = [e for e in root.iter() if e is not root]
        what = draw(st.sampled_from(["value", "value", "value", "drop attribute", "drop element",
                                     "duplicate", "relink", "kind", "mimic", "cycle",
                                     "transmission"]))
        if what in ("value", "drop attribute"):
            with_attrs = [e for e in elements if e.attrib]
            element = draw(st.sampled_from(with_attrs))
            attr = draw(st.sampled_from(sorted(element.attrib)))
            if what == "value":
                element.set(attr, draw(st.sampled_from(BAD_VALUES) | st.text(max_size=8).filter(
                    lambda t: all(c.isprintable() for c in t))))
            else:
                del element.attrib[attr]
        elif what == "drop element":
            element = draw(st.sampled_from(elements))
            element.getparent().remove(element)
        elif what == "duplicate":                  # a second <link> or <joint> of that name
            element = draw(st.sampled_from([e for e in root if e.tag in ("link", "joint")]))
            root.append(copy.deepcopy(element))
        elif what in ("relink", "cycle"):          # a joint pointing elsewhere, or upward
            joint_elements = [e for e in root if e.tag == "joint"]
            if joint_elements:
                joint = draw(st.sampled_from(joint_elements))
                end = joint.find(draw(st.sampled_from(["parent", "child"])))
                names = [e.get("name") for e in root if e.tag == "link" and e.get("name")]
                names.append("nowhere")
                if end is not None:
                    end.set("link", draw(st.sampled_from(names)))
        elif what == "kind":
            joint_elements = [e for e in root if e.tag == "joint"]
            if joint_elements:
                draw(st.sampled_from(joint_elements)).set("type", draw(st.sampled_from(JOINT_KINDS)))
        elif what == "mimic":                      # a mimic of anything, even itself
            joint_elements = [e for e in root if e.tag == "joint"]
            if joint_elements:
                joint = draw(st.sampled_from(joint_elements))
                leader = draw(st.sampled_from([e.get("name") or "" for e in joint_elements]
                                              + ["ghost"]))
                etree.SubElement(joint, "mimic", joint=leader or "",
                                 multiplier=draw(st.sampled_from(["2", "0", "nan", "-1"])))
        elif what == "transmission":               # a rotor inertia, good or bad
            names = [e.get("name") or "" for e in root if e.tag == "joint"] + ["ghost"]
            tr = etree.SubElement(root, "transmission", name="t")
            etree.SubElement(tr, "joint", name=draw(st.sampled_from(names)))
            actuator = etree.SubElement(tr, "actuator", name="motor")
            for tag in draw(st.lists(st.sampled_from(["rotor_inertia", "gear_ratio"]),
                                     max_size=3)):
                etree.SubElement(actuator, "{http://drake.mit.edu}" + tag,
                                 value=draw(st.sampled_from(BAD_VALUES + ["1e-4", "50"])))
    return etree.tostring(root).decode(), draw(st.sampled_from([None, tip]))


def _named_in(message, xml):
    """Does ``message`` name something of ``xml``: a link or joint (quoted; or a coordinate
    of a planar joint, 'name/x'), an element (<tag), or the file itself?"""
    root = etree.fromstring(xml)
    names = {e.get(a) for e in root.iter() for a in ("name", "link", "joint") if e.get(a)}
    tags = {e.tag for e in root.iter() if isinstance(e.tag, str)} | {"robot", "link", "joint"}
    return (any(f"'{n}'" in message or f"'{n}/" in message for n in names)
            or any(f"<{t}" in message for t in tags))


def _issue_case(old, new):
    """The issue's cases, on a small valid arm (what replaces what)."""
    base = ('<robot name="t"><link name="base_link"/>'
            '<link name="link1"><inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="1"/>'
            '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
            '<link name="link2"><inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="1"/>'
            '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
            '<joint name="j1" type="revolute"><parent link="base_link"/><child link="link1"/>'
            '<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="2"/></joint>'
            '<joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>'
            '<origin xyz="0 0 0.2" rpy="0 0 0"/><axis xyz="0 1 0"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="2"/>'
            '<dynamics damping="0.1"/></joint></robot>')
    assert old in base
    return base.replace(old, new, 1)


@settings(max_examples=1500, **SETTINGS)
@given(corrupted())
@example(case=(_issue_case('<axis xyz="0 1 0"/>', '<axis xyz="1 2"/>'), None))
@example(case=(_issue_case('damping="0.1"', 'damping="garbage"'), None))
@example(case=(_issue_case('<axis xyz="0 1 0"/>', '<axis xyz="1e200 1e200 0"/>'), None))
@example(case=(_issue_case('<parent link="link1"/>', ""), None))
@example(case=(_issue_case('<link name="link2">', "<link>"), None))
@example(case=(_issue_case('<origin xyz="0 0 0.2"', '<origin xyz="a b c"'), None))
@example(case=(_issue_case('<mass value="1"/>', "<mass/>"), None))
@example(case=(_issue_case('lower="-3"', 'lower="x"'), None))
@example(case=(_issue_case(' ixy="0" ixz="0"', ""), None))
@example(case=(_issue_case('<child link="link2"/>', '<child link="base_link"/>'), None))
@example(case=(_issue_case('<link name="link2">', '<link name="link1">'), None))
@example(case=(_issue_case('<mass value="1"/>', '<mass value="-1"/>'), None))
@example(case=(_issue_case('<mass value="1"/>', '<mass value="nan"/>'), None))
def test_a_corrupted_urdf_loads_or_names_the_culprit(case):
    xml, tip = case
    try:
        with time_limit(), warnings.catch_warnings():
            warnings.simplefilter("error")         # nor an overflow on the way
            warnings.simplefilter("ignore", sd.HeldJointsWarning)
            robot = sd.load_urdf(xml, tip_link=tip)
    except sd.RobotDescriptionError as exc:
        assert _named_in(str(exc), xml), str(exc)
        return
    # it loaded: a valid model, with finite dynamics (a floating root: the base at the origin)
    q, v = np.zeros(robot.nq), np.zeros(robot.nv)
    if robot.is_floating:
        q[6] = 1.0                                 # qw: the identity rotation
    assert np.all(np.isfinite(robot.inverse_dynamics(q, v, v)))
    assert np.linalg.eigvalsh(robot.mass_matrix(q))[0] > 0
