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
def test_negative_mass():
    raises(sd.URDFError, urdf(l2=link("link2", mass="-1.5")), "'link2'", "-1.5", "negative")


def test_inertia_not_positive_semidefinite():
    raises(sd.URDFError, urdf(l2=link("link2", I=("-0.01", "0.01", "0.01"))), "'link2'",
           "positive semi-definite")
    # positive diagonal, but a product of inertia too large for it
    raises(sd.URDFError, urdf(l1=link("link1", off=("0.02", "0", "0"))), "'link1'",
           "positive semi-definite")


def test_triangle_inequality():
    msg = raises(sd.URDFError, urdf(l2=link("link2", I=("0.01", "0.01", "0.05"))), "'link2'",
                 "triangle inequality")
    assert "0.05" in msg


def test_invalid_inertia_off_the_chain_is_found_too():
    """A fixed child that is lumped into the chain is checked like any chain link."""
    xml = urdf(pl=link("payload", I=("0.01", "0.01", "0.05")),
               jp=joint("payload_joint", "link2", "payload", kind="fixed"))
    raises(sd.URDFError, xml, "'payload'", "triangle")


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


def test_branches_without_tip_list_the_candidates():
    xml = urdf(l3=link("link3"), j3=joint("j3", "link1", "link3", axis="1 0 0"),
               l4=link("link4"), j4=joint("j4", "link3", "link4", axis="0 0 1"))
    msg = raises(sd.URDFError, xml, "branch", "tip_link", "'j2'", "'j3'", "'link2'", "'link4'")
    assert "'link3'" not in msg.split("one of")[1]       # not a branch end
    # naming a tip resolves it, and the other branch is held (with a warning naming it)
    with pytest.warns(sd.HeldJointsWarning, match="j2"):
        robot = sd.load_urdf(xml, tip_link="link4")
    assert robot.joint_names == ["j1", "j3", "j4"]


@pytest.mark.parametrize("kind", ["floating", "planar"])
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
    # the leader off the chain (the chain starts below it)
    raises(sd.URDFError, urdf(j2=joint("j2", "link1", "link2", extra='<mimic joint="j1"/>')),
           "'j2'", "'j1'", "not a movable joint of the chain", base_link="link1")
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


# ---------------------------------------------------------------- bad states and arguments
@pytest.fixture(scope="module", params=["numba", "numpy"])
def robot(request):
    return sd.Robot(sd.default_robot().model, backend=request.param)


@pytest.mark.parametrize("call, argname", [
    (lambda r, bad, ok: r.inverse_dynamics(bad, ok, ok), "q"),
    (lambda r, bad, ok: r.inverse_dynamics(ok, bad, ok), "qd"),
    (lambda r, bad, ok: r.inverse_dynamics(ok, ok, bad), "qdd"),
    (lambda r, bad, ok: r.mass_matrix(bad), "q"),
    (lambda r, bad, ok: r.bias_torques(ok, bad), "qd"),
    (lambda r, bad, ok: r.gravity_torques(bad), "q"),
    (lambda r, bad, ok: r.coriolis_matrix(ok, bad), "qd"),
    (lambda r, bad, ok: r.forward_dynamics(ok, ok, bad), "tau"),
    (lambda r, bad, ok: r.forward_dynamics(ok, ok, bad, method="qr"), "tau"),
    (lambda r, bad, ok: r.forward_dynamics(bad, ok, ok, method="aba"), "q"),
    (lambda r, bad, ok: r.forward_kinematics(bad), "q"),
    (lambda r, bad, ok: r.jacobian(bad), "q"),
    (lambda r, bad, ok: r.kinetic_energy(ok, bad), "qd"),
    (lambda r, bad, ok: r.potential_energy(bad), "q"),
])
def test_bad_states(robot, call, argname):
    ok = np.zeros(6)
    for bad in (np.zeros(5), np.zeros(7), np.zeros((3, 5)), np.zeros((2, 3, 6)), 0.0):
        with pytest.raises(ValueError, match=rf"^{argname} has shape"):
            call(robot, bad, ok)
    for value, joint_name in ((np.nan, "shoulder_lift_joint"), (np.inf, "wrist_3_joint"),
                              (-np.inf, "shoulder_pan_joint")):
        bad = np.zeros(6)
        bad[robot.joint_names.index(joint_name)] = value
        with pytest.raises(ValueError, match=rf"^{argname} has a NaN or Inf entry \(joint '{joint_name}'\)"):
            call(robot, bad, ok)
        with pytest.raises(ValueError, match=rf"^{argname} has a NaN or Inf"):   # in a batch
            call(robot, np.vstack([np.zeros(6), bad]), ok)


def test_batch_sizes_must_agree(robot):
    with pytest.raises(ValueError, match="batch sizes differ"):
        robot.inverse_dynamics(np.zeros((3, 6)), np.zeros((4, 6)), np.zeros(6))


@pytest.mark.parametrize("wrench", [np.zeros(5), np.zeros(7), np.zeros((2, 6)), np.zeros((3, 3)), 1.0])
def test_wrong_wrench_shape(robot, wrench):
    q = np.zeros((4, 6))
    for call in (lambda: robot.inverse_dynamics(q, q, q, wrench=wrench),
                 lambda: robot.bias_torques(q, q, wrench=wrench),
                 lambda: robot.forward_dynamics(q, q, q, wrench=wrench)):
        with pytest.raises(ValueError, match="wrench has shape"):
            call()


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_nan_or_inf_wrench(robot, value):
    w = np.array([1.0, 2.0, value, 0.0, 0.0, 0.0])
    for q in (np.zeros(6), np.zeros((3, 6))):
        for call in (lambda: robot.inverse_dynamics(q, q, q, wrench=w),
                     lambda: robot.bias_torques(q, q, wrench=w),
                     lambda: robot.forward_dynamics(q, q, q, wrench=w),
                     lambda: robot.forward_dynamics(q, q, q, wrench=w, method="qr")):
            with pytest.raises(ValueError, match="wrench has a NaN or Inf entry"):
                call()


def test_unknown_link_in_kinematics(robot):
    for call in (robot.forward_kinematics, robot.jacobian):
        with pytest.raises(ValueError, match="link 'gripper' is not in the model") as info:
            call(np.zeros(6), link="gripper")
        assert "wrist_3_link" in str(info.value)       # lists the known links


def test_unknown_forward_dynamics_method(robot):
    with pytest.raises(ValueError, match="'lu'"):
        robot.forward_dynamics(np.zeros(6), np.zeros(6), np.zeros(6), method="lu")


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

    from serial_dynamics.robots.synthetic import chain_urdf
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
