"""URDF ``planar`` joints (urdf/joint_types.py): a mobile manipulator whose base moves in
the floor plane agrees with Pinocchio's ``JointModelPlanar`` (test/planar_base.py maps
the coordinates) in every algorithm, single and batch, compiled and reference; a tilted
plane is the same robot as three explicit joints; the simulator integrates it with every
method and keeps the horizontal momentum and the energy; its coordinates carry the names
<joint>/x, <joint>/y, <joint>/theta. (The GPU's agreement: test/gpu/test_agreement.py.)"""
import re

import numpy as np
import pytest

import serial_dynamics as sd
from planar_base import PlanarPinocchio, mobile_manipulator_urdf, states
from serial_dynamics.sim.methods import METHODS
from serial_dynamics.sim.session import Session
from serial_dynamics.urdf.joint_types import elementary_joints

TOL = 1e-9
NAMES = ["base_joint/x", "base_joint/y", "base_joint/theta"]


@pytest.fixture(scope="module")
def urdf_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("planar") / "mobile_ur5.urdf"
    path.write_text(mobile_manipulator_urdf())
    return str(path)


def robot_of(path, backend):
    return sd.Robot(sd.load_model(path), backend=backend)


def close(got, want):
    """|got - want| <= TOL (1 + |want|_max), a relative bound on the whole array."""
    np.testing.assert_array_less(np.abs(got - want), TOL * (1.0 + np.max(np.abs(want))))


def test_a_planar_joint_is_three_coordinates(urdf_path):
    robot = sd.load_urdf(urdf_path)
    assert robot.joint_names[:3] == NAMES and robot.dof == 9 and robot.nq == robot.nv == 9
    assert robot.joint_types[:3] == ["prismatic", "prismatic", "continuous"]
    assert np.all(np.isinf(robot.lower[:3])) and np.all(np.isinf(robot.upper[:3]))
    np.testing.assert_array_equal(robot.effort_limit[:3], 200.0)      # the URDF's <limit>
    np.testing.assert_array_equal(robot.velocity_limit[:3], 1.5)
    # the plane's axes: x, y of the joint's frame, placed at its origin (rotated 0.4 rad)
    x = np.array([0.7, -1.1, 0.0] + [0.0] * 6)
    pose = robot.forward_kinematics(x, "mobile_base")
    c, s = np.cos(0.4), np.sin(0.4)
    np.testing.assert_allclose(pose[:3, 3], [0.3 + 0.7 * c + 1.1 * s, -0.2 + 0.7 * s - 1.1 * c, 0.1],
                               atol=1e-15)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_agrees_with_pinocchio_planar_joint(urdf_path, backend):
    robot = robot_of(urdf_path, backend)
    pin = PlanarPinocchio(urdf_path, robot)
    Q, QD, QDD = states(np.random.default_rng(7), 6)
    for q, qd, qdd in zip(Q, QD, QDD):
        tau = pin.inverse_dynamics(q, qd, qdd)
        close(robot.inverse_dynamics(q, qd, qdd), tau)
        close(robot.mass_matrix(q), pin.mass_matrix(q))
        close(robot.bias_torques(q, qd), pin.inverse_dynamics(q, qd, 0 * qdd))
        for method in ("auto", "cholesky", "aba"):
            close(robot.forward_dynamics(q, qd, tau, method=method), qdd)
        for got, want in zip(robot.inverse_dynamics_derivatives(q, qd, qdd),
                             pin.inverse_dynamics_derivatives(q, qd, qdd)):
            close(got, want)
        for got, want in zip(robot.forward_dynamics_derivatives(q, qd, tau),
                             pin.forward_dynamics_derivatives(q, qd, tau)):
            close(got, want)
    # a batch: every row Pinocchio's, and bitwise its single call
    TAU = robot.inverse_dynamics(Q, QD, QDD)
    for k, (q, qd, qdd) in enumerate(zip(Q, QD, QDD)):
        close(TAU[k], pin.inverse_dynamics(q, qd, qdd))
        assert TAU[k].tobytes() == robot.inverse_dynamics(q, qd, qdd).tobytes()
    close(robot.forward_dynamics(Q, QD, TAU), QDD)
    M = robot.mass_matrix(Q)
    dq, dqd = robot.inverse_dynamics_derivatives(Q, QD, QDD)
    Fq, Fqd, Ft = robot.forward_dynamics_derivatives(Q, QD, TAU)
    for k, (q, qd, qdd) in enumerate(zip(Q, QD, QDD)):
        close(M[k], pin.mass_matrix(q))
        for got, want in zip((dq[k], dqd[k]), pin.inverse_dynamics_derivatives(q, qd, qdd)):
            close(got, want)
        for got, want in zip((Fq[k], Fqd[k], Ft[k]),
                             pin.forward_dynamics_derivatives(q, qd, TAU[k])):
            close(got, want)


def test_a_tilted_plane_is_its_three_joints(urdf_path):
    """A plane normal to (1, 2, 2)/3: the planar joint is the robot written with the two
    prismatic joints and the continuous one it stands for (same numbers to 1e-13)."""
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    text = mobile_manipulator_urdf().replace('<axis xyz="0 0 1"/>\n    <limit effort="200"',
                                             '<axis xyz="1 2 2"/>\n    <limit effort="200"')
    (ex, ey, ez) = (e.axis for e in elementary_joints("planar", n))
    np.testing.assert_allclose([ex @ n, ey @ n, ex @ ey, np.cross(ex, ey) @ n], [0, 0, 0, 1],
                               atol=1e-15)
    np.testing.assert_array_equal(ez, n)
    joint = re.search(r'<joint name="base_joint" type="planar">.*?</joint>', text, re.S).group(0)
    origin = re.search(r"<origin [^>]*/>", joint).group(0)
    explicit = ""
    for k, (name, kind, axis, parent, child) in enumerate([
            ("x", "prismatic", ex, "map", "base_joint/x"),
            ("y", "prismatic", ey, "base_joint/x", "base_joint/y"),
            ("theta", "continuous", n, "base_joint/y", "mobile_base")]):
        limit = '<limit lower="0" upper="0" effort="200" velocity="1.5"/>' if kind == "prismatic" else ""
        explicit += (f'<joint name="base_joint/{name}" type="{kind}"><parent link="{parent}"/>'
                     f'<child link="{child}"/>{origin if k == 0 else ""}'
                     f'<axis xyz="{float(axis[0])!r} {float(axis[1])!r} {float(axis[2])!r}"/>{limit}</joint>')
        if child != "mobile_base":
            explicit += f'<link name="{child}"/>'
    explicit_text = text.replace(joint, explicit)
    planar, three = sd.load_urdf(text), sd.load_urdf(explicit_text)
    assert planar.joint_names == three.joint_names
    Q, QD, QDD = states(np.random.default_rng(3), 4)
    np.testing.assert_allclose(planar.inverse_dynamics(Q, QD, QDD),
                               three.inverse_dynamics(Q, QD, QDD), rtol=1e-13, atol=1e-11)
    np.testing.assert_allclose(planar.mass_matrix(Q), three.mass_matrix(Q), rtol=1e-13, atol=1e-13)


def test_mimic_and_planar_refused(urdf_path):
    text = mobile_manipulator_urdf()
    with pytest.raises(sd.URDFError, match="base_joint.*only a joint of one coordinate"):
        sd.load_urdf(text.replace('<axis xyz="0 0 1"/>\n    <limit effort="200"',
                                  '<axis xyz="0 0 1"/><mimic joint="elbow_joint"/>\n    '
                                  '<limit effort="200"'))
    follower = re.sub(r'(<joint name="elbow_joint" type="revolute">)',
                      r'\1<mimic joint="base_joint" multiplier="1"/>', text)
    with pytest.raises(sd.URDFError, match="elbow_joint.*mimics 'base_joint', a joint of "
                                           "several coordinates"):
        sd.load_urdf(follower)


@pytest.mark.parametrize("method", METHODS)
def test_simulated_with_every_method(urdf_path, method):
    """Released at rest with the arm out, no friction: nothing pushes the robot along the
    floor, so its center of mass keeps its place in the plane while the arm falls and the
    base recoils; no energy is made or lost (beyond each method's error)."""
    robot = sd.load_urdf(urdf_path)
    robot.dissipation = robot.dissipation.override(
        viscous={j: 0.0 for j in robot.joint_names}, coulomb={j: 0.0 for j in robot.joint_names})
    q0 = np.array([0.5, -0.3, 0.2, 0.3, -0.4, 0.8, -0.5, 0.6, 0.1])
    res = sd.simulate(robot, 0.3, q0, np.zeros(9), method=method)
    com = robot.center_of_mass(res.q)
    assert np.ptp(res.q[:, 0]) > 1e-3 or np.ptp(res.q[:, 1]) > 1e-3   # the base did move
    drift = np.max(np.abs(com[:, :2] - com[0, :2]))           # m
    made = np.max(np.abs(res.kinetic + res.potential - res.kinetic[0] - res.potential[0]))
    first_order = method in ("semi_implicit_euler", "symplectic_euler")    # O(dt) methods
    # measured 2026-12-07: 1.5e-4 m and 4e-3 of the fall (Euler, dt 1 ms); <= 1e-7 m, 5e-7 else
    assert drift < (5e-4 if first_order else 1e-6), (method, drift)
    assert made < (1e-2 if first_order else 1e-5) * np.ptp(res.potential), (method, made)


def test_the_simulator_names_its_coordinates(urdf_path):
    robot = sd.load_urdf(urdf_path)
    session = Session(robot, np.zeros(9))
    session.step(force=True)
    assert list(session.joint_names[:3]) == NAMES and session.joint_state().position.shape == (9,)
