"""A payload attached at run time (``with_payload``) against Pinocchio with the same inertia
added to the body: dynamics, properties, ``without_payload`` bitwise, bad input.

The cases and their oracles: test/modelling_cases.py."""
import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import erd
from modelling_cases import (BACKENDS, BM, PAYLOAD, RTOL, XTOL, batch, case, fixed_reference,
                             pin_fext_fixed, quiet_load, rel_err, states, tilted_chain_urdf,
                             tmpdir_chains)  # noqa: F401  (fixtures)


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
    # from the torso: the root is above the base, not a link of the model
    torso = quiet_load(erd("tiago_description/robots/tiago_no_hand.urdf"), "torso_fixed_link",
                       "wrist_ft_tool_link")
    with pytest.raises(ValueError, match="payload link 'base_footprint' is not a link of the model"):
        torso.with_payload(1.0, link="base_footprint")
