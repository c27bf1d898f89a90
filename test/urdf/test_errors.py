"""Bad input gets a clear exception naming the culprit (DESIGN.md, "Errors"); legal but
unusual URDFs (massless links, fixed links carrying mass, tilted bases) load and are right."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd

G = 9.81


# ---------------------------------------------------------------- a small URDF builder
def link(name, mass="1.0", com="0 0 0.1", I=("0.01", "0.01", "0.01"), off=("0", "0", "0"),
         rpy="0 0 0"):
    if mass is None:
        return f'<link name="{name}"/>'
    return (f'<link name="{name}"><inertial><origin xyz="{com}" rpy="{rpy}"/>'
            f'<mass value="{mass}"/><inertia ixx="{I[0]}" iyy="{I[1]}" izz="{I[2]}" '
            f'ixy="{off[0]}" ixz="{off[1]}" iyz="{off[2]}"/></inertial></link>')


def joint(name, parent, child, kind="revolute", xyz="0 0 0.2", rpy="0 0 0", axis="0 1 0",
          limit='<limit lower="-3" upper="3" effort="10" velocity="2"/>', extra=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}{extra}</joint>')


def urdf(**parts):
    """A 2-joint arm base_link -j1(z)-> link1 -j2(y)-> link2 -fixed-> tool; override any part
    by keyword (None removes it), add more with new keywords."""
    default = dict(
        base=link("base_link", mass=None), l1=link("link1"), l2=link("link2"),
        tool=link("tool", mass=None),
        j1=joint("j1", "base_link", "link1", axis="0 0 1", xyz="0 0 0.1"),
        j2=joint("j2", "link1", "link2"),
        jt=joint("tool_joint", "link2", "tool", kind="fixed", xyz="0 0 0.3"),
    )
    default.update(parts)
    return '<robot name="t">' + "".join(v for v in default.values() if v) + "</robot>"


def raises(exc_type, source, *names, **kw):
    """Load must raise exc_type whose message contains every one of ``names``."""
    with pytest.raises(exc_type) as info:
        sd.load_urdf(source, **kw)
    for name in names:
        assert name in str(info.value), (name, str(info.value))
    return str(info.value)


def test_the_builder_makes_a_valid_arm():
    robot = sd.load_urdf(urdf())
    assert robot.joint_names == ["j1", "j2"] and robot.tip_link == "tool"


# ---------------------------------------------------------------- the file itself
@pytest.mark.parametrize("xml", [
    "<robot name='t'><link name='a'></robot>",                       # tag mismatch
    urdf()[:-30],                                                      # truncated
    urdf() + "<junk/>",                                                # content after the root
    urdf().replace('<link name="link2">', '<link name="link2" name="x">'),  # attribute twice
])
def test_malformed_xml(xml):
    raises(sd.URDFError, xml, "not well-formed XML")


def test_malformed_file_names_the_file(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text(urdf().replace("</joint>", "", 1))
    raises(sd.URDFError, str(path), "broken.urdf", "not well-formed")


def test_missing_file():
    raises(sd.URDFError, "/nonexistent/dir/arm.urdf", "/nonexistent/dir/arm.urdf", "not found")


def test_not_a_tree():
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "linkX")), "'j2'", "'linkX'")
    raises(sd.URDFError, urdf(orphan=link("orphan")), "root", "orphan")


@pytest.mark.parametrize("kw", [{}, {"base_link": "a"}, {"tip_link": "b"}])
def test_a_cycle_off_the_root_is_named(kw):
    """Links a, b with joints a -> b and b -> a: one root (base_link), so the old loader
    walked the cycle forever (issue 13, defect 2)."""
    cyclic = urdf(a=link("a"), b=link("b"), jab=joint("jab", "a", "b"), jba=joint("jba", "b", "a"))
    raises(sd.URDFError, cyclic, "cycle", "'jab'", "'jba'", "'a'", "'b'", **kw)


def test_duplicate_names_are_refused():
    """A second <link> of the same name used to replace the first silently, and a repeated
    joint name repeated itself in joint_names (issue 13, defect 3)."""
    raises(sd.URDFError, urdf(heavy=link("link2", mass="50")), "<link>", "'link2'", "unique")
    raises(sd.URDFError, urdf(j3=joint("j2", "link2", "extra"), extra=link("extra")),
           "<joint>", "'j2'", "unique")


# ---------------------------------------------------------------- inertias
# A file that reads but describes no physical body raises ModelError, as the README says
# (negative mass, inertia; issue 13: negative mass used to be a URDFError).
def test_negative_mass():
    raises(sd.ModelError, urdf(l2=link("link2", mass="-1.5")), "'link2'", "-1.5", "negative")


def test_inertia_not_positive_semidefinite():
    raises(sd.ModelError, urdf(l2=link("link2", I=("-0.01", "0.01", "0.01"))), "'link2'",
           "positive semi-definite")
    # positive diagonal, but a product of inertia too large for it
    raises(sd.ModelError, urdf(l1=link("link1", off=("0.02", "0", "0"))), "'link1'",
           "positive semi-definite")


def test_triangle_inequality():
    msg = raises(sd.ModelError, urdf(l2=link("link2", I=("0.01", "0.01", "0.05"))), "'link2'",
                 "triangle inequality")
    assert "0.05" in msg


def test_invalid_inertia_off_the_chain_is_found_too():
    """A fixed child is judged as part of the body it is lumped into (issue 52): here that
    body, (0.02, 0.02, 0.06) kg m^2 about one center of mass, is still no rigid body's."""
    xml = urdf(pl=link("payload", I=("0.01", "0.01", "0.05")),
               jp=joint("payload_joint", "link2", "payload", kind="fixed", xyz="0 0 0"))
    raises(sd.ModelError, xml, "'link2'", "'payload'", "triangle", "[0.02, 0.02, 0.06]",
           "repair_inertia=True")


@pytest.mark.parametrize("I, off", [
    (("1e-20", "-1e-20", "0"), ("0", "0", "0")),            # iCub's l_ankle_2: indefinite
    (("2.4e-35", "0", "-2.4e-35"), ("0", "0", "0")),        # iCub's head
    (("-5.4e-20", "-5.4e-20", "0"), ("0", "0", "0")),       # iCub's r_hip_2
    (("0", "0", "0"), ("1e-20", "0", "0")),                 # a product of inertia alone
])
def test_round_off_sized_inertias_are_point_masses(I, off):
    """Inertias of 1e-20 .. 1e-35 kg m^2 (physically zero) used to fail the purely relative
    check (issue 13): they load, and the arm equals the one with an exact point mass."""
    rounded = sd.load_urdf(urdf(l2=link("link2", I=I, off=off)))
    point = sd.load_urdf(urdf(l2=link("link2", I=("0", "0", "0"))))
    q, qd, qdd = np.array([0.3, -0.7]), np.array([1.0, 2.0]), np.array([-1.0, 0.5])
    np.testing.assert_allclose(rounded.inverse_dynamics(q, qd, qdd),
                               point.inverse_dynamics(q, qd, qdd), rtol=1e-15, atol=1e-15)


def test_the_round_off_floor_scales_with_mass_and_size():
    """The floor is 1e-12 m L^2 (L: the link's size), not a fixed number: the same negative
    moment is round-off on a 1 kg link of 0.1 m and refused on a 1 g link of 1 mm."""
    check = sd.model.inertia.check_inertia
    I = np.diag([-1e-16, 1e-16, 1e-16])
    check("big", 1.0, I, length=0.1)                       # floor 1e-14: round-off
    with pytest.raises(sd.ModelError, match="'small'.*positive semi-definite"):
        check("small", 1e-3, I, length=1e-3)               # floor 1e-21
    with pytest.raises(sd.ModelError, match="'nosize'"):
        check("nosize", 1.0, I)                            # no size given: relative only


@pytest.mark.parametrize("part, culprit, what", [
    (dict(l2=link("link2", mass="nan")), "'link2'", "mass"),
    (dict(l2=link("link2", mass="inf")), "'link2'", "mass"),
    (dict(l2=link("link2", com="0 nan 0.1")), "'link2'", "origin"),
    (dict(l1=link("link1", I=("0.01", "inf", "0.01"))), "'link1'", "inertia"),
    (dict(j2=joint("j2", "link1", "link2", xyz="0 0 nan")), "'j2'", "origin"),
    (dict(j2=joint("j2", "link1", "link2", rpy="0 inf 0")), "'j2'", "origin"),
    (dict(jt=joint("tool_joint", "link2", "tool", kind="fixed", xyz="nan 0 0")),
     "'tool_joint'", "origin"),
    (dict(j2=joint("j2", "link1", "link2", axis="0 nan 1")), "'j2'", "axis"),
    (dict(j1=joint("j1", "base_link", "link1", axis="0 0 1",
                   limit='<limit lower="nan" upper="1" effort="1" velocity="1"/>')), "'j1'", "lower"),
    (dict(j2=joint("j2", "link1", "link2",
                   limit='<limit lower="-1" upper="1" effort="1" velocity="nan"/>')), "'j2'", "velocity"),
    (dict(j2=joint("j2", "link1", "link2", extra='<dynamics damping="inf"/>')), "'j2'", "damping"),
    (dict(j2=joint("j2", "link1", "link2", extra='<dynamics friction="nan"/>')), "'j2'", "friction"),
])
def test_nan_or_inf_in_the_file(part, culprit, what):
    msg = raises(sd.URDFError, urdf(**part), culprit, what)
    assert "nan" in msg.lower() or "inf" in msg.lower()


def test_other_bad_joint_numbers():
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2", axis="0 0 0")), "'j2'", "zero axis")
    # an axis whose norm overflows (or underflows) is a direction all the same (issue 13:
    # "1e200 1e200 0" was refused as "axis is zero")
    for axis, unit in (("1e200 1e200 0", [1, 1, 0]), ("1e308 0 -1e308", [1, 0, -1]),
                       ("0 1e-200 0", [0, 1, 0])):
        with warnings.catch_warnings():
            warnings.simplefilter("error")                 # and no overflow on the way
            robot = sd.load_urdf(urdf(j2=joint("j2", "link1", "link2", axis=axis)))
        np.testing.assert_allclose(robot.model.axis[1], np.array(unit) / np.linalg.norm(unit),
                                   rtol=1e-15)
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2", extra='<dynamics damping="-1"/>')),
           "'j2'", "damping", "negative")
    raises(sd.URDFError, urdf(j2=joint(
        "j2", "link1", "link2", limit='<limit lower="2" upper="1" effort="1" velocity="1"/>')),
        "'j2'", "lower limit 2.0 > upper limit 1.0")


# ---------------------------------------------------------------- singular mass matrix
def test_joint_that_moves_no_mass():
    msg = raises(sd.ModelError, urdf(l2=link("link2", mass=None)), "'j2'", "moves no mass")
    assert "singular" in msg
    # a point mass on the axis of j2 (y): j2 moves it, but with no inertia about that axis
    raises(sd.ModelError, urdf(l2=link("link2", com="0 0.1 0", I=("0", "0", "0"))), "'j2'",
           "moves no mass")


def test_two_joints_moving_the_same_mass_the_same_way():
    """Two prismatic joints along z in a row: M = m [[1, 1], [1, 1]] is singular although no
    diagonal entry vanishes."""
    xml = urdf(l1=link("link1", mass=None),
               j1=joint("j1", "base_link", "link1", kind="prismatic", axis="0 0 1"),
               j2=joint("j2", "link1", "link2", kind="prismatic", axis="0 0 1"))
    raises(sd.ModelError, xml, "singular", "'base_link' -> 'tool'")


# ---------------------------------------------------------------- choosing the chain
def test_unknown_base_or_tip_link():
    msg = raises(sd.URDFError, urdf(), "base_link 'nope'", "link2", base_link="nope")
    assert "links are" in msg
    raises(sd.URDFError, urdf(), "tip_link 'hand'", "link1", tip_link="hand")


def test_tip_not_below_base():
    raises(sd.URDFError, urdf(), "'link1'", "'link2'", "not below", base_link="link2",
           tip_link="link1")


def test_no_movable_joint_between_base_and_tip():
    raises(sd.URDFError, urdf(), "no movable joint", "'link2'", "'tool'", base_link="link2",
           tip_link="tool")


@pytest.mark.parametrize("kind", ["floating"])     # planar: test_planar_joint.py
def test_unsupported_joint_type_on_the_chain(kind):
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2", kind=kind)), "'j2'", kind)


def test_mimic_joint_on_the_chain_is_the_reduced_system():
    xml = urdf(j2=joint("j2", "link1", "link2", axis="0 0 1",
                        extra='<mimic joint="j1" multiplier="2" offset="0.1"/>'))
    robot = sd.load_urdf(xml)
    assert robot.joint_names == ["j1"] and robot.all_joint_names == ["j1", "j2"]
    np.testing.assert_allclose(robot.all_joint_positions([0.3]), [0.3, 0.7])
    # j1 and j2 turn about parallel axes, j2 twice as fast: M = I1 + (1+2)^2 I2z + ...
    # checked against the two-joint chain's mass matrix through G = [1, 2]^T
    full = sd.load_urdf(urdf(j2=joint("j2", "link1", "link2", axis="0 0 1")))
    G = np.array([[1.0], [2.0]])
    M_all = full.mass_matrix([0.3, 0.7])
    np.testing.assert_allclose(robot.mass_matrix([0.3]), G.T @ M_all @ G, rtol=1e-13)


def test_mimic_errors_name_the_joint():
    three = dict(l3=link("link3"), j3=joint("j3", "link2", "link3", extra='<mimic joint="j2"/>'))
    # a mimic of a mimic
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2", extra='<mimic joint="j1"/>'),
                              **three), "'j3'", "mimics 'j2'", "mimic of a mimic")
    # (a leader off the chain holds its follower at the offset: test/urdf/test_loader_leniency.py)
    # a multiplier of 0
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2",
                                       extra='<mimic joint="j1" multiplier="0"/>')),
           "'j2'", "multiplier")


def test_off_chain_floating_and_mimic_joints_are_held():
    xml = urdf(f=link("finger"),
               jf=joint("finger_joint", "link2", "finger", kind="prismatic", axis="1 0 0",
                        extra='<mimic joint="j2"/>'),
               c=link("cam"), jc=joint("cam_mount", "link1", "cam", kind="floating"))
    with pytest.warns(sd.HeldJointsWarning) as record:
        robot = sd.load_urdf(xml, tip_link="tool")
    assert "finger_joint" in str(record[0].message) and "cam_mount" in str(record[0].message)
    assert robot.dof == 2


# ---------------------------------------------------------------- legal cases
def test_link_without_inertial_is_massless():
    """link1 without <inertial> loads; the arm behaves like the one with mass 0 there."""
    massless = sd.load_urdf(urdf(l1=link("link1", mass=None)))
    zero = sd.load_urdf(urdf(l1=link("link1", mass="0", I=("0", "0", "0"))))
    assert massless.model.mass[0] == 0
    rng = np.random.default_rng(0)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-2, 2, (3, 2))
        np.testing.assert_array_equal(massless.inverse_dynamics(q, qd, qdd),
                                      zero.inverse_dynamics(q, qd, qdd))
    # only link2 (1 kg, its center 0.1 m along z, at 0.2 m up j1's axis) feels gravity
    q = np.array([0.3, 0.4])
    # holding torque = -(r x m g)_y = -m g 0.1 sin(q2): gravity pulls the tilted link onward
    np.testing.assert_allclose(massless.gravity_torques(q), [0.0, -G * 0.1 * np.sin(0.4)], atol=1e-14)


def test_fixed_link_with_mass_is_lumped():
    """A payload on a rotated fixed joint equals link2 with the inertia merged by hand.

    link2: 2 kg, center (0, 0, 0.1), I = diag(0.02, 0.02, 0.01).
    payload at (0, 0, 0.3), rpy (0, pi/2, 0): 1 kg, center (0.05, 0, 0) and I = diag(1, 2, 3)e-3
    in its frame, i.e. center (0, 0, 0.25) and I = diag(3, 2, 1)e-3 in link2's frame.
    Merged: 3 kg at (0, 0, 0.15); parallel axes add 2 (0.05)^2 + 1 (0.1)^2 = 0.015 to Ixx, Iyy.
    """
    parts = dict(l2=link("link2", mass="2", com="0 0 0.1", I=("0.02", "0.02", "0.01")))
    lumped = sd.load_urdf(urdf(
        **parts, pl=link("payload", mass="1", com="0.05 0 0", I=("0.001", "0.002", "0.003")),
        jp=joint("payload_joint", "link2", "payload", kind="fixed", xyz="0 0 0.3",
                 rpy=f"0 {np.pi / 2!r} 0")))
    merged = sd.load_urdf(urdf(l2=link("link2", mass="3", com="0 0 0.15",
                                       I=("0.038", "0.037", "0.011"))))
    np.testing.assert_allclose(lumped.model.mass, merged.model.mass, rtol=1e-15)
    np.testing.assert_allclose(lumped.model.com, merged.model.com, atol=1e-15)
    np.testing.assert_allclose(lumped.model.inertia, merged.model.inertia, atol=1e-15)
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-2, 2, (3, 2))
        np.testing.assert_allclose(lumped.inverse_dynamics(q, qd, qdd),
                                   merged.inverse_dynamics(q, qd, qdd), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(lumped.mass_matrix(q), merged.mass_matrix(q), rtol=1e-13)
    # held off-chain movable joint: the same payload on a revolute joint at zero
    held_xml = urdf(**parts, pl=link("payload", mass="1", com="0.05 0 0",
                                     I=("0.001", "0.002", "0.003")),
                    jp=joint("gripper_joint", "link2", "payload", xyz="0 0 0.3",
                             rpy=f"0 {np.pi / 2!r} 0", axis="1 0 0"))
    with pytest.warns(sd.HeldJointsWarning, match="gripper_joint"):
        held = sd.load_urdf(held_xml, tip_link="tool")
    q, qd, qdd = rng.uniform(-2, 2, (3, 2))
    np.testing.assert_allclose(held.inverse_dynamics(q, qd, qdd), merged.inverse_dynamics(q, qd, qdd),
                               rtol=1e-13)


def test_fixed_joint_with_a_stray_mimic_tag_on_the_chain_loads():
    xml = urdf(jt=joint("tool_joint", "link2", "tool", kind="fixed", xyz="0 0 0.3",
                        extra='<mimic joint="j1"/>'))
    robot = sd.load_urdf(xml)
    assert robot.tip_link == "tool" and robot.dof == 2


def _rpy(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def test_tilted_base_falls_the_right_way():
    """world -(fixed, rpy)-> base_link -> arm: the gravity torques equal those of the untilted
    arm with world gravity rotated into the base frame by hand."""
    rpy = (0.3, -0.5, 1.1)
    tilted_xml = urdf(w=link("world", mass=None),
                      jw=joint("mount", "world", "base_link", kind="fixed", xyz="0.5 -0.2 1.0",
                               rpy=" ".join(repr(a) for a in rpy)))
    g_world = np.array([0.0, 0.0, -G])
    g_base = _rpy(*rpy).T @ g_world
    from_base = sd.load_urdf(tilted_xml, base_link="base_link")
    from_world = sd.load_urdf(tilted_xml)
    by_hand = sd.load_urdf(urdf(), gravity=g_base)
    np.testing.assert_allclose(from_base.gravity, g_base, atol=1e-14)
    assert from_world.base_link == "world"
    rng = np.random.default_rng(2)
    for q in rng.uniform(-3, 3, (4, 2)):
        expected = by_hand.gravity_torques(q)
        assert np.max(np.abs(expected)) > 0.1
        np.testing.assert_allclose(from_base.gravity_torques(q), expected, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(from_world.gravity_torques(q), expected, rtol=1e-12, atol=1e-13)
    # upright, j1 (about the base z) feels no gravity; tilted, it does
    assert abs(sd.load_urdf(urdf()).gravity_torques([0.0, 0.7])[0]) < 1e-14
    assert abs(from_base.gravity_torques([0.0, 0.7])[0]) > 0.1


def test_upside_down_base_hangs():
    """Ceiling mount (roll pi): gravity is +z in the base, and the arm's torque flips sign."""
    xml = urdf(w=link("world", mass=None),
               jw=joint("mount", "world", "base_link", kind="fixed", rpy=f"{np.pi!r} 0 0"))
    ceiling = sd.load_urdf(xml, base_link="base_link")
    floor = sd.load_urdf(urdf())
    np.testing.assert_allclose(ceiling.gravity, [0, 0, G], atol=1e-14)
    q = np.array([0.2, 0.9])
    np.testing.assert_allclose(ceiling.gravity_torques(q), -floor.gravity_torques(q), atol=1e-14)


def test_a_chain_longer_than_the_recursion_limit_loads():
    """The default tip was found by a recursive walk: a chain of about 1,000 joints raised
    RecursionError (issue 13, defect 6). Now an explicit stack."""
    import sys

    from serial_dynamics.builtin.synthetic import chain_urdf
    n = sys.getrecursionlimit() + 50
    robot = sd.load_urdf(chain_urdf(n))
    assert robot.dof == n and robot.tip_link == "tip"


@pytest.mark.parametrize("parts, culprit, what", [
    (dict(l2=link("link2", com="1e160 0 0")), "'link2'", "center of mass"),
    (dict(l2=link("link2", mass="1e9")), "'link2'", "mass"),
    (dict(l2=link("link2", I=("1e200", "1e200", "1e200"))), "'link2'", "inertia"),
    (dict(j2=joint("j2", "link1", "link2", xyz="0 0 1e200")), "'j2'", "origin xyz"),
])
def test_absurd_magnitudes_are_named(parts, culprit, what):
    """An inertial origin of 1e160 m used to surface as numpy's LinAlgError (eigenvalues
    did not converge) from the mass-matrix check (issue 13, defect 7)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")                     # and no overflow on the way
        raises(ValueError, urdf(**parts), culprit, what, "beyond any robot")


# ---------------------------------------------------------------- messages name the culprit
NO_PARENT = ('<joint name="j2" type="revolute"><child link="link2"/><axis xyz="0 1 0"/>'
             '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
BAD_FILES = {   # issue 13, defect 1: what each used to say, and what names the culprit now
    # "setting an array element with a sequence..."
    "axis of two numbers": (dict(j2=joint("j2", "link1", "link2", axis="1 2")),
                            ["joint 'j2'", '<axis xyz="1 2">', "three numbers"]),
    # "could not convert string to float: 'garbage'"
    "damping garbage": (dict(j2=joint("j2", "link1", "link2", extra='<dynamics damping="garbage"/>')),
                        ["joint 'j2'", 'damping="garbage"', "a number"]),
    "friction garbage": (dict(j2=joint("j2", "link1", "link2", extra='<dynamics friction="x"/>')),
                         ["joint 'j2'", 'friction="x"', "a number"]),
    # "'NoneType' object has no attribute 'get'"
    "joint without parent": (dict(j2=NO_PARENT), ["joint 'j2'", "<parent", "link="]),
    "joint without child": (dict(j2=NO_PARENT.replace("child", "parent").replace("link2", "link1")),
                            ["joint 'j2'", "<child"]),
    "parent without link": (dict(j2=joint("j2", "link1", "link2").replace('<parent link="link1"/>',
                                                                         "<parent/>")),
                            ["joint 'j2'", "<parent> has no link attribute"]),
    # "missing attribute 'name'"
    "link without name": (dict(extra="<link/>"), ["<link> on line", "5th", "no name"]),
    "joint without name": (dict(j2=joint("j2", "link1", "link2").replace(' name="j2"', "")),
                           ["<joint> on line", "2nd", "no name"]),
    "robot without name": ({}, ["<robot> has no name", '<robot name="...">']),
    # "could not convert string to float: 'a'"
    "origin of letters": (dict(j2=joint("j2", "link1", "link2", xyz="a b c")),
                          ["joint 'j2'", '<origin xyz="a b c">', "three numbers", "(m)"]),
    "origin of two numbers": (dict(j2=joint("j2", "link1", "link2", xyz="1 2")),
                              ["joint 'j2'", '<origin xyz="1 2">', "three numbers"]),
    "rpy garbage": (dict(j2=joint("j2", "link1", "link2", rpy="x 0 0")),
                    ["joint 'j2'", "rpy", "roll pitch yaw"]),
    "inertial origin garbage": (dict(l2=link("link2", com="a b c")),
                                ["link 'link2' <inertial>", '<origin xyz="a b c">']),
    "limit garbage": (dict(j2=joint("j2", "link1", "link2",
                                    limit='<limit lower="x" upper="1" effort="1" velocity="1"/>')),
                      ["joint 'j2'", '<limit lower="x">', "a number"]),
    "mass garbage": (dict(l2=link("link2", mass="heavy")), ["link 'link2'", 'value="heavy"', "(kg)"]),
    "inertia garbage": (dict(l2=link("link2", I=("a", "0.01", "0.01"))),
                        ["link 'link2'", 'ixx="a"', "kg m^2"]),
    "mimic multiplier garbage": (dict(j2=joint("j2", "link1", "link2",
                                               extra='<mimic joint="j1" multiplier="x"/>')),
                                 ["joint 'j2'", 'multiplier="x"']),
    # silently read as mass 0, or as ixx = 1 (yourdfpy's defaults), before
    "mass without value": (dict(l2=link("link2").replace('<mass value="1.0"/>', "<mass/>")),
                           ["link 'link2'", "<mass> has no value", '<mass value="..."/>']),
    "inertial without mass": (dict(l2=link("link2").replace('<mass value="1.0"/>', "")),
                              ["link 'link2'", "<inertial> has no <mass>"]),
    "inertia missing attributes": (dict(l2=link("link2").replace(' ixx="0.01"', "")),
                                   ["link 'link2'", "<inertia> has no ixx", "all six"]),
    "inertial without inertia": (dict(l2=link("link2").replace('<inertia ', '<foo ')),
                                 ["link 'link2'", "<inertial> has no <inertia>"]),
    # "on the chain is of type None", "mimics None"
    "joint without type": (dict(j2=joint("j2", "link1", "link2").replace(' type="revolute"', "")),
                           ["joint 'j2'", "no type", "'revolute'"]),
    "unknown joint type": (dict(j2=joint("j2", "link1", "link2", kind="hinge")),
                           ["joint 'j2'", "'hinge'", "'prismatic'"]),
    "mimic without joint": (dict(j2=joint("j2", "link1", "link2", extra='<mimic multiplier="2"/>')),
                            ["joint 'j2'", "<mimic> has no joint", '<mimic joint="..."']),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_value_is_named_with_what_is_expected(case):
    parts, names = BAD_FILES[case]
    xml = urdf(**parts)
    if case == "robot without name":
        xml = xml.replace('<robot name="t">', "<robot>")
    msg = raises(sd.URDFError, xml, *names)
    assert "NoneType" not in msg and "could not convert" not in msg and "sequence" not in msg
    assert "parse the URDF string" in msg      # where: the string, or the file's path


def test_a_bad_value_in_a_file_names_the_file(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(urdf(j2=joint("j2", "link1", "link2", axis="1 2")))
    raises(sd.URDFError, str(path), "arm.urdf", "joint 'j2'", "<axis")


def test_a_bad_file_deep_in_folders_is_still_named(tmp_path):
    """A path longer than errors.MAX_NAME is cut in the message, keeping its end: the file's
    name (cut from the start alone, it was lost under a deep tmp folder)."""
    path = tmp_path / ("folder_" * 15) / "arm.urdf"
    path.parent.mkdir()
    path.write_text(urdf(j2=joint("j2", "link1", "link2", axis="1 2")))
    raises(sd.URDFError, str(path), "folder_/arm.urdf'", f"({len(str(path))} characters)")


def test_the_root_must_be_a_robot():
    xml = urdf().replace('<robot name="t">', '<rob name="t">').replace("</robot>", "</rob>")
    raises(sd.URDFError, xml, "<rob>", "<robot")      # used to load, from a <rob>


def test_what_the_model_never_reads_is_not_checked():
    """<visual>, <collision>, <calibration>, <safety_controller> and materials are never
    used: garbage there does not refuse the arm (yourdfpy used to fail on it)."""
    junk = ('<visual><origin xyz="a"/><geometry><box size="1 x"/></geometry>'
            '<material name="m"><color rgba="red"/></material></visual><collision><geometry/>'
            '</collision></link>')
    xml = urdf(l2=link("link2").replace("</link>", junk),
               j2=joint("j2", "link1", "link2", extra='<calibration rising="x"/>'
                                                      '<safety_controller k_velocity="y"/>'),
               mat='<material name="m"><color rgba="1 2"/></material>')
    robot = sd.load_urdf(xml)
    plain = sd.load_urdf(urdf())
    np.testing.assert_array_equal(robot.mass_matrix([0.3, 0.4]), plain.mass_matrix([0.3, 0.4]))


def test_one_base_class_for_both_errors():
    """Users catch sd.RobotDescriptionError for a URDF that cannot be read and for a chain
    that is not physical; both remain ValueErrors (issue 13)."""
    assert issubclass(sd.URDFError, sd.RobotDescriptionError)
    assert issubclass(sd.ModelError, sd.RobotDescriptionError)
    assert issubclass(sd.RobotDescriptionError, ValueError)
    assert "RobotDescriptionError" in sd.__all__
    for xml in (urdf(j2=joint("j2", "link1", "link2", axis="1 2")),      # URDFError
                urdf(l2=link("link2", mass="-1")),                         # ModelError
                urdf(l2=link("link2", mass=None))):                        # singular M
        with pytest.raises(sd.RobotDescriptionError):
            sd.load_urdf(xml)


def test_the_readme_lists_each_error_under_its_class():
    """README: negative mass and bad inertias are ModelErrors; the code agrees (above)."""
    import os
    readme = open(os.path.join(os.path.dirname(__file__), "..", "..", "README.md")).read()
    paragraph = readme[readme.index("Bad input raises"):]
    paragraph = paragraph[:paragraph.index("\n\n")]
    model_part = paragraph[paragraph.index("`sd.ModelError`"):]
    assert "negative mass" in model_part and "negative mass" not in paragraph.split(
        "`sd.ModelError`")[0]
    assert "sd.RobotDescriptionError" in paragraph


def test_a_long_chain_loads_without_the_dense_check():
    """Loading 1,000 joints took 9.7 .. 26.5 s (issue 13): the mass-matrix check ran the
    NumPy CRBA, O(n^2), and an eigendecomposition, O(n^3), at three configurations. It is
    O(n) now (composite and articulated inertias in one pass), and the dense CRBA is not
    called for a chain without mimic joints. (Load times: bench/bench_load.py; no timing
    assertion here.)"""
    from serial_dynamics.builtin.synthetic import chain_urdf
    from serial_dynamics.urdf import mass_matrix as check_module
    calls = []
    dense = check_module.mass_matrix
    check_module.mass_matrix = lambda *a: calls.append(1) or dense(*a)
    try:
        robot = sd.load_urdf(chain_urdf(1000))
    finally:
        check_module.mass_matrix = dense
    assert robot.dof == 1000 and not calls


def test_the_singular_check_is_the_dense_one():
    """The O(n) check refuses what the dense one (G^T M G, eigenvalues) refuses, with the
    culprit named: here two coaxial joints (link1 massless), in a 30-joint chain."""
    import re

    from serial_dynamics.builtin.synthetic import chain_urdf
    xml = chain_urdf(30)
    xml = re.sub(r'<link name="link7">.*?</link>', '<link name="link7"/>', xml, flags=re.S)
    xml = re.sub(r'(<joint name="joint8".*?<origin xyz=")[^"]*(")', r"\g<1>0 0 0\2", xml, flags=re.S)
    axis7 = re.search(r'<joint name="joint7".*?<axis xyz="([^"]*)"', xml, re.S).group(1)
    xml = re.sub(r'(<joint name="joint8".*?<axis xyz=")[^"]*(")', rf"\g<1>{axis7}\2", xml, flags=re.S)
    msg = raises(sd.ModelError, xml, "singular", "'joint7'", "at q = 0", "same mass the same way")
    assert len(msg) < 600                   # a long q is summarized
