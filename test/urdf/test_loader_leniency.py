"""What urdfdom (ROS's and Pinocchio's URDF parser) reads, the loader reads (issue 22, items
3-6, 11, 12): an odd XML declaration or blank lines before it; a mimic joint on the chain
whose leader is off it (held at its offset); an off-chain joint that mimics an on-chain one
(named); xacro:/drake: prefixes without noise on stderr; dissipation and limits bounded;
names cut to a readable length in messages."""
import logging
import warnings

import numpy as np
import pytest

import serial_dynamics as sd


def link(name, mass="1.0", com="0.05 0 0.1"):
    return (f'<link name="{name}"><inertial><origin xyz="{com}" rpy="0.1 0 0.2"/>'
            f'<mass value="{mass}"/><inertia ixx="0.02" iyy="0.03" izz="0.025" ixy="0.001" '
            'ixz="0" iyz="0.002"/></inertial></link>')


def joint(name, parent, child, kind="revolute", axis="0 1 0", xyz="0.1 0 0.2", rpy="0 0.3 0",
          extra="", limit='<limit lower="-3" upper="3" effort="10" velocity="2"/>'):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            f'{limit}{extra}</joint>')


def arm(*extra, j2=None, j3=None):
    """base -j1(z)- l1 -j2(y)- l2 -j3(x)- l3, plus ``extra`` elements."""
    return ('<robot name="arm"><link name="base"/>' + link("l1") + link("l2") + link("l3")
            + joint("j1", "base", "l1", axis="0 0 1")
            + (j2 or joint("j2", "l1", "l2"))
            + (j3 or joint("j3", "l2", "l3", axis="1 0 0"))
            + "".join(extra) + "</robot>")


STATES = np.random.default_rng(3).uniform(-1, 1, (4, 3))


def same_dynamics(a, b):
    """Bit-for-bit the same rigid-body model (mass matrix, inverse dynamics, tip pose)."""
    n = a.dof
    for x in STATES:
        q, qd, qdd = x[:n], x[::-1][:n], x[:n] ** 2
        assert np.array_equal(a.mass_matrix(q), b.mass_matrix(q))
        assert np.array_equal(a.inverse_dynamics(q, qd, qdd), b.inverse_dynamics(q, qd, qdd))
        assert np.array_equal(a.forward_kinematics(q), b.forward_kinematics(q))


# ---------------------------------------------------------------- item 3: markup before <robot>
HEADERS = ['<?xml version="0.0" ?>\n',                      # pybullet's minitaur, quadruped
           '\n<?xml version="1.0" ?>\n',                    # pybullet's diff_ring
           ' \n\n<?xml version="0.0" encoding="utf-8"?>\n',
           '\n<?xml version="1.0"?><!-- a comment -->\n']


@pytest.mark.parametrize("header", HEADERS)
def test_an_odd_declaration_or_blank_lines_before_it_load(header, tmp_path):
    plain = sd.load_urdf(arm())
    same_dynamics(sd.load_urdf(header + arm()), plain)
    path = tmp_path / "pybullet.urdf"
    path.write_text(header + arm())
    same_dynamics(sd.load_urdf(str(path)), plain)


def test_a_real_error_behind_a_harmless_header_is_the_one_named(tmp_path):
    broken = arm().replace("</joint>", "", 1)             # an unclosed <joint> on line 3
    text = '\n<?xml version="0.0" ?>\n' + broken
    path = tmp_path / "broken.urdf"
    path.write_text(text)
    for source in (text, str(path)):
        with pytest.raises(sd.URDFError) as info:
            sd.load_urdf(source)
        message = str(info.value)
        assert "not well-formed" in message and "line 3" in message, message
        assert "declaration" not in message and "version" not in message, message
    # a document that is nothing but a declaration is still refused
    with pytest.raises(sd.URDFError, match="not well-formed"):
        sd.load_urdf('\n<?xml version="0.0" ?>\n')


def test_the_identification_writer_reads_such_files_too(tmp_path):
    from serial_dynamics.identification import urdf_out
    path = tmp_path / "odd.urdf"
    path.write_text(HEADERS[2] + arm())
    robot = sd.load_urdf(str(path))
    m = robot.model
    phi = robot.inertial_parameters()[:10 * m.dof].reshape(m.dof, 10)
    out = tmp_path / "out.urdf"
    urdf_out.write_urdf(str(path), m, phi, [0.1] * 3, [0.2] * 3, out)
    np.testing.assert_allclose(sd.load_urdf(str(out)).mass_matrix(STATES[0]),
                               robot.mass_matrix(STATES[0]), rtol=1e-12)


# ---------------------------------------------------------------- item 4: on-chain follower
@pytest.mark.parametrize("kind, axis", [("revolute", "0 1 0"), ("prismatic", "0.6 0.8 0")])
def test_a_mimic_on_the_chain_whose_leader_is_off_it_is_held_at_its_offset(kind, axis):
    """j2 mimics 'lead', a joint off the chain (held at zero): j2 is held at
    multiplier * 0 + offset, exactly as if it were fixed there."""
    lead = link("side") + joint("lead", "l1", "side", axis="0 0 1")
    follower = joint("j2", "l1", "l2", kind=kind, axis=axis,
                     extra='<mimic joint="lead" multiplier="2" offset="0.3"/>')
    with pytest.warns(sd.HeldJointsWarning) as record:
        robot = sd.load_urdf(arm(lead, j2=follower), tip_link="l3")
    message = " ".join(str(r.message) for r in record)
    assert "'j2'" in message and "'lead'" in message and "0.3" in message, message
    assert robot.joint_names == ["j1", "j3"]
    # the same arm with j2 fixed at 0.3 (its motion folded into the origin) and 'lead' held
    if kind == "revolute":
        fixed = joint("j2", "l1", "l2", kind="fixed", rpy="0 0.6 0")    # 0.3 + 0.3 about y
    else:
        c, s = np.cos(0.3), np.sin(0.3)         # + Ry(0.3) (0.3 * axis): axis in joint frame
        xyz = np.array([0.1, 0, 0.2]) + np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ [
            0.18, 0.24, 0]
        fixed = joint("j2", "l1", "l2", kind="fixed", xyz=" ".join(repr(float(v)) for v in xyz))
    with pytest.warns(sd.HeldJointsWarning):
        reference = sd.load_urdf(arm(lead, j2=fixed), tip_link="l3")
    for x in STATES:
        q, qd = x[:2], x[1:]
        np.testing.assert_allclose(robot.mass_matrix(q), reference.mass_matrix(q), rtol=1e-13)
        np.testing.assert_allclose(robot.bias_torques(q, qd), reference.bias_torques(q, qd),
                                   rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(robot.forward_kinematics(q), reference.forward_kinematics(q),
                                   rtol=1e-13, atol=1e-15)


def test_the_pandas_right_finger_as_tip_agrees_with_pinocchio():
    """The Panda's right finger mimics the left one, off this chain: both held (offset 0),
    as Pinocchio's model with the finger joints locked at zero."""
    from pin_reference import PinReference, erd, load
    path = erd("panda_description/urdf/panda.urdf")
    robot = load(path, tip="panda_rightfinger")
    assert robot.dof == 7
    ref = PinReference(robot, path)
    rng = np.random.default_rng(0)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1, 1, (3, 7))
        np.testing.assert_allclose(robot.mass_matrix(q), ref.mass_matrix(q), rtol=1e-12,
                                   atol=1e-12)
        np.testing.assert_allclose(robot.inverse_dynamics(q, qd, qdd), ref.rnea(q, qd, qdd),
                                   rtol=1e-12, atol=1e-11)


def test_a_mimic_whose_leader_is_above_the_base_is_held_too():
    follower = joint("j3", "l2", "l3", axis="1 0 0", extra='<mimic joint="j1" offset="-0.2"/>')
    with pytest.warns(sd.HeldJointsWarning, match="'j3'.*'j1'"):
        robot = sd.load_urdf(arm(j3=follower), base_link="l1")
    assert robot.joint_names == ["j2"]
    # a leader that is no joint at all is still an error
    follower = joint("j3", "l2", "l3", axis="1 0 0", extra='<mimic joint="nowhere"/>')
    with pytest.raises(sd.URDFError, match="'j3'.*'nowhere'"):
        sd.load_urdf(arm(j3=follower))


# ---------------------------------------------------------------- item 5: off-chain follower
def test_an_off_chain_joint_mimicking_an_on_chain_joint_is_named():
    finger = link("finger", mass="0.1") + joint("finger2", "l3", "finger", kind="prismatic",
                                                axis="0 1 0", extra='<mimic joint="j3"/>')
    with pytest.warns(sd.HeldJointsWarning) as record:
        sd.load_urdf(arm(finger), tip_link="l3")
    message = " ".join(str(r.message) for r in record)
    assert "'finger2' mimics 'j3'" in message and "does not follow" in message, message


# ---------------------------------------------------------------- item 6: namespace prefixes
def test_xacro_and_drake_prefixes_load_without_noise_on_stderr(capfd, caplog):
    """yourdfpy logs (to stderr, outside pytest) an error for each undeclared prefix."""
    prefixed = arm('<xacro:property name="a" value="1"/>',
                   '<drake:collision_filter_group name="g"><drake:member link="l1"/>'
                   '</drake:collision_filter_group>',
                   j2=joint("j2", "l1", "l2").replace('type="revolute"',
                                                       'type="revolute" drake:x="1"'))
    capfd.readouterr()
    robot = sd.load_urdf(prefixed)
    out, err = capfd.readouterr()
    assert err == "" and out == "", err
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    same_dynamics(robot, sd.load_urdf(arm()))


# ---------------------------------------------------------------- item 11: dissipation, limits
@pytest.mark.parametrize("dynamics", ['damping="1e308"', 'friction="1e300"', 'damping="1e13"'])
def test_absurd_dissipation_coefficients_are_refused(dynamics):
    xml = arm(j2=joint("j2", "l1", "l2", extra=f"<dynamics {dynamics}/>"))
    with pytest.raises(sd.RobotDescriptionError, match="'j2'.*beyond any robot"):
        sd.load_urdf(xml)


def test_large_but_real_dissipation_loads():
    xml = arm(j2=joint("j2", "l1", "l2", extra='<dynamics damping="1e5" friction="1e4"/>'))
    assert sd.load_urdf(xml).dissipation.viscous[1] == 1e5


@pytest.mark.parametrize("limit", ['lower="-1" upper="inf" effort="1" velocity="1"',
                                   'lower="-inf" upper="1" effort="1" velocity="1"',
                                   'lower="-1" upper="1" effort="inf" velocity="1"',
                                   'lower="-1" upper="1" effort="1" velocity="1e999"'])
def test_an_infinite_limit_in_the_file_is_refused(limit):
    xml = arm(j2=joint("j2", "l1", "l2", limit=f"<limit {limit}/>"))
    with pytest.raises(sd.URDFError, match="'j2'.*Inf"):
        sd.load_urdf(xml)


# ---------------------------------------------------------------- item 12: long names
def test_a_huge_name_is_cut_in_messages():
    huge = "L" * 1_000_000
    xml = arm().replace(link("l3"), link(huge, mass="-1")).replace('"l3"', f'"{huge}"')
    with pytest.raises(sd.ModelError) as info:
        sd.load_urdf(xml)
    message = str(info.value)
    assert len(message) < 400 and "LLLL" in message and "1000000 characters" in message, \
        message[:400]
    with pytest.raises(sd.URDFError) as info:
        sd.load_urdf(arm(), tip_link=huge)
    assert len(str(info.value)) < 400 and "1000000 characters" in str(info.value)


def test_short_names_are_untouched():
    name = "n" * 60
    with pytest.raises(sd.URDFError) as info:
        sd.load_urdf(arm(), tip_link=name)
    assert repr(name) in str(info.value)
    prose = "'a' and " + "then more words " * 10 + "'b'"        # no name is cut from prose
    assert str(sd.RobotDescriptionError(prose)) == prose


def test_no_warning_on_a_plain_arm():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd.load_urdf(arm())


def test_a_dissipation_override_is_bounded_too():
    robot = sd.load_urdf(arm())
    with pytest.raises(ValueError, match="viscous of joint 'j2' is 1e.308.*at most 1e.12"):
        robot.dissipation.override(viscous={"j2": 1e308})
    assert robot.dissipation.override(coulomb={"j2": 50.0}).coulomb[1] == 50.0
