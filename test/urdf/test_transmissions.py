"""Armature from URDF ``<transmission>`` elements (Drake's rotor inertia and gear ratio, ROS's
mechanicalReduction) and from ``load_urdf(armature=...)``: values, warnings, errors.

The cases and their oracles: test/modelling_cases.py."""
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import chain_urdf
from pin_reference import erd
from modelling_cases import G_WORLD, RTOL, fixed_reference, quiet_load, rel_err, states


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
