"""Physical consistency is judged on the bodies the dynamics uses (issue 52): a link with a
placeholder inertia that its fixed neighbours make physical loads; a lumped body that is
still no rigid body's is refused with a message naming ``repair_inertia=True``; with it the
body gets the nearest physical inertia (mass, center of mass and principal axes kept) and one
``sd.InertiaRepairWarning``."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.model.inertia import nearest_physical_inertia

from test_errors import joint, link


def arm(**parts):
    """base_link -j1(z)-> link1 -j2(y)-> link2; override or add parts by keyword."""
    default = dict(base=link("base_link", mass=None), l1=link("link1"), l2=link("link2"),
                   j1=joint("j1", "base_link", "link1", axis="0 0 1", xyz="0 0 0.1"),
                   j2=joint("j2", "link1", "link2"))
    default.update(parts)
    return '<robot name="t">' + "".join(v for v in default.values() if v) + "</robot>"


# a placeholder: 1e-6 kg and every inertia entry 1e-6 kg m^2 (rank one: moments 0, 0, 3e-6)
DUMMY = dict(mass="1e-6", com="0 0 0", I=("1e-6",) * 3, off=("1e-6",) * 3)
Q = np.array([0.4, -0.9])


def repairs(source, **kw):
    """(robot, [InertiaRepairWarning messages]) of loading with repair_inertia=True."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = sd.load_urdf(source, repair_inertia=True, **kw)
    return robot, [str(w.message) for w in caught if w.category is sd.InertiaRepairWarning]


def test_a_placeholder_link_with_its_body_fixed_to_it_loads():
    """ANYmal's pattern: the joint's child link carries a placeholder, the real body hangs
    from it by a fixed joint. The lumped body is physical: it loads as the link carrying the
    real body itself would, but for the placeholder: its own 3e-6 kg m^2 at most, and its
    1e-6 kg at under 0.5 m from the joints (2.5e-7 kg m^2)."""
    placeholder = sd.load_urdf(arm(
        l2=link("link2", **DUMMY),
        body=link("link2_body", mass="2.0", com="0 0 0.05", I=("0.02", "0.02", "0.01")),
        jb=joint("link2_body_joint", "link2", "link2_body", kind="fixed", xyz="0 0 0.1")))
    direct = sd.load_urdf(arm(l2=link("link2", mass="2.0", com="0 0 0.15",
                                      I=("0.02", "0.02", "0.01"))))
    np.testing.assert_allclose(placeholder.mass_matrix(Q), direct.mass_matrix(Q), rtol=0,
                               atol=3.3e-6)
    np.testing.assert_allclose(placeholder.gravity_torques(Q), direct.gravity_torques(Q),
                               rtol=0, atol=1e-6 * 9.81 * 0.5)
    assert np.abs(placeholder.mass_matrix(Q) - direct.mass_matrix(Q)).max() > 1e-7


def test_a_placeholder_base_of_a_floating_robot_loads():
    body = link("trunk", mass="10.0", com="0 0 0", I=("0.1", "0.2", "0.25"))
    xml = arm(base=link("base_link", **DUMMY), trunk=body,
              jt=joint("trunk_joint", "base_link", "trunk", kind="fixed", xyz="0 0 0"))
    robot = sd.load_urdf(xml, floating_base=True)
    assert robot.is_floating and robot.model.base_mass == pytest.approx(10.0 + 1e-6)
    with pytest.raises(sd.ModelError) as e:          # the placeholder alone: no body
        sd.load_urdf(arm(base=link("base_link", **DUMMY)), floating_base=True)
    assert str(e.value).startswith("link 'base_link' (the floating base)")
    assert "repair_inertia=True" in str(e.value)
    robot, said = repairs(arm(base=link("base_link", **DUMMY)), floating_base=True)
    assert len(said) == 1 and said[0].startswith("link 'base_link' (the floating base)")
    s = np.linalg.eigvalsh(robot.model.base_inertia)
    assert s[0] + s[1] >= s[2] - 1e-18 and s[0] >= 0


def test_a_lumped_body_that_is_still_not_physical_is_refused_naming_the_option():
    """link2, (0.01, 0.01, 0.05) kg m^2, and the tool, (0.01, 0.01, 0.01), share a center of
    mass: the lumped body has (0.02, 0.02, 0.06), still no rigid body's."""
    xml = arm(l2=link("link2", I=("0.01", "0.01", "0.05")),
              tool=link("tool", mass="0.1", com="0 0 0"),
              jt=joint("tool_joint", "link2", "tool", kind="fixed", xyz="0 0 0.1"))
    with pytest.raises(sd.ModelError) as e:
        sd.load_urdf(xml)
    msg = str(e.value)
    assert msg.startswith("link 'link2' (the body of joint 'j2', with ['tool'] fixed to it): "
                          "principal moments [0.02, 0.02, 0.06]"), msg
    assert "triangle inequality" in msg and "repair_inertia=True" in msg


def test_repair_gives_the_nearest_physical_inertia_and_one_warning_per_body():
    """link1: a negative moment, (-0.01, 0.02, 0.02): second moments s = (0.025, -0.005,
    -0.005) -> (0.025, 0, 0), a rod along x, moments (0, 0.025, 0.025). link2, its inertial
    frame turned: (0.01, 0.01, 0.05), s = (0.025, 0.025, -0.015) -> (0.025, 0.025, 0), a flat
    body, moments (0.025, 0.025, 0.05) about the same axes. Mass and com are kept."""
    rpy = "0.3 -0.5 1.1"
    xml = arm(l1=link("link1", I=("-0.01", "0.02", "0.02")),
              l2=link("link2", mass="1.5", com="0.02 0 0.1", I=("0.01", "0.01", "0.05"), rpy=rpy))
    with pytest.raises(sd.ModelError, match=r"^link 'link1' \(the body of joint 'j1'\): "
                       r"inertia is not positive semi-definite.*repair_inertia=True"):
        sd.load_urdf(xml)
    robot, said = repairs(xml)
    assert len(said) == 2, said
    assert said[0].startswith("link 'link1' (the body of joint 'j1'): inertia not physical, "
                              "principal moments [-0.01, 0.02, 0.02] kg m^2; repaired")
    assert "to [0.0, 0.025, 0.025] kg m^2" in said[0]
    assert said[1].startswith("link 'link2'") and "[0.01, 0.01, 0.05]" in said[1]
    assert "to [0.025, 0.025, 0.05] kg m^2" in said[1]
    m = robot.model
    np.testing.assert_allclose(m.inertia[0], np.diag([0.0, 0.025, 0.025]), atol=1e-17)
    cr, sr = np.cos([0.3, -0.5, 1.1]), np.sin([0.3, -0.5, 1.1])
    Rx = np.array([[1, 0, 0], [0, cr[0], -sr[0]], [0, sr[0], cr[0]]])
    Ry = np.array([[cr[1], 0, sr[1]], [0, 1, 0], [-sr[1], 0, cr[1]]])
    Rz = np.array([[cr[2], -sr[2], 0], [sr[2], cr[2], 0], [0, 0, 1]])
    R = Rz @ Ry @ Rx                                   # URDF rpy: fixed axes x, y, z
    np.testing.assert_allclose(m.inertia[1], R @ np.diag([0.025, 0.025, 0.05]) @ R.T,
                               atol=1e-15)
    np.testing.assert_array_equal(m.mass, [1.0, 1.5])
    np.testing.assert_allclose(m.com, [[0, 0, 0.1], [0.02, 0, 0.1]], atol=1e-16)


def test_a_physical_robot_is_untouched_by_the_option():
    xml = arm()
    robot, said = repairs(xml)
    plain = sd.load_urdf(xml)
    assert said == []
    np.testing.assert_array_equal(robot.model.inertia, plain.model.inertia)


def test_a_negative_mass_is_refused_even_when_lumped_into_a_heavier_body():
    xml = arm(neg=link("ballast", mass="-0.5"),
              jn=joint("ballast_joint", "link2", "ballast", kind="fixed"))
    for kw in ({}, {"repair_inertia": True}):
        with pytest.raises(sd.ModelError, match="'ballast': mass -0.5 is negative"):
            sd.load_urdf(xml, **kw)


def _second_moments(I):
    """Sigma = tr(I)/2 1 - I: int x x^T dm about the center of mass."""
    return np.trace(I) / 2 * np.eye(3) - I


def test_the_repair_is_the_nearest_physical_inertia():
    """Nothing physical is nearer in the Frobenius norm of the pseudo-inertia (its Sigma
    block; mass and com fixed): checked against random physical inertias around the
    answer and far from it. Physical: Sigma positive semi-definite (a density >= 0)."""
    rng = np.random.default_rng(52)
    for _ in range(50):
        A = rng.standard_normal((3, 3))
        I = A @ A.T + rng.uniform(-1.5, 1.5) * np.trace(A @ A.T) * np.eye(3) / 3
        repaired, before, after = nearest_physical_inertia(I)
        S, S_rep = _second_moments(I), _second_moments(repaired)
        assert np.linalg.eigvalsh(S_rep)[0] >= -1e-12 * np.abs(S).max()
        np.testing.assert_allclose(np.linalg.eigvalsh(repaired), np.sort(after), atol=1e-12)
        best = np.linalg.norm(S_rep - S)
        for scale in (1e-3, 1e-1, 1.0):
            for _ in range(40):
                B = rng.standard_normal((3, 3))
                cand = S_rep + scale * np.abs(S).max() * (B + B.T)
                if np.linalg.eigvalsh(cand)[0] >= 0:          # a physical body
                    assert np.linalg.norm(cand - S) >= best * (1 - 1e-12)
        if np.linalg.eigvalsh(S)[0] >= 0:
            np.testing.assert_allclose(repaired, I, atol=1e-12 * np.abs(I).max())
