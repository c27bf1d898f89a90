"""core/floating_derivatives.py: the derivatives of a free-floating base in one compiled
call, against central differences along the tangent of q (q (+) dq: robot.integrate),
against the NumPy reference, and batch rows against single calls bit for bit.
(Pinocchio's computeRNEADerivatives / computeABADerivatives on every tree of
example-robot-data: test/oracles/test_pinocchio_trees.py.)"""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import two_arm_urdf

PRISMATIC_SECOND = ["revolute", "prismatic", "revolute"]

ROBOTS = {
    # a chain, and a tree of two arms with a prismatic joint each (the sparse factor's solves)
    "ur5e": lambda: sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True),
    "two_arms": lambda: sd.load_urdf(two_arm_urdf(3, base_mass=4.0, kinds=PRISMATIC_SECOND),
                                     floating_base=True),
}


def rel_err(a, b):
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


def states(robot, seed, N=None):
    rng = np.random.default_rng(seed)
    q, v = robot.random_state(rng, batch=N)
    x = rng.uniform(-2, 2, v.shape)
    return q, v, x


def central(f, robot, q, v, x, h=1e-6):
    """d f/d q along the tangent (integrate(q, e_k, h)) and d f/d v, by central differences."""
    nv = robot.nv
    dq, dv = np.empty((nv, nv)), np.empty((nv, nv))
    for k in range(nv):
        e = np.zeros(nv)
        e[k] = 1.0
        dq[:, k] = (f(robot.integrate(q, e, h), v, x) - f(robot.integrate(q, e, -h), v, x)) / (2 * h)
        dv[:, k] = (f(q, v + h * e, x) - f(q, v - h * e, x)) / (2 * h)
    return dq, dv


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("wrench", [None, (3.0, -2.0, 5.0, 0.4, -0.7, 0.2)])
def test_the_derivatives_are_those_of_the_dynamics_along_the_tangent(name, wrench):
    """With a tip wrench (world coordinates) the base's turn turns it in the base frame:
    its columns are checked by the same differences."""
    robot = ROBOTS[name]()
    q, v, a = states(robot, 1)
    ID = lambda q, v, a: robot.inverse_dynamics(q, v, a, wrench)      # noqa: E731
    FD = lambda q, v, t: robot.forward_dynamics(q, v, t, wrench)      # noqa: E731
    dq, dv = robot.inverse_dynamics_derivatives(q, v, a, wrench)
    nq, nv = central(ID, robot, q, v, a)
    assert rel_err(dq, nq) < 1e-7 and rel_err(dv, nv) < 1e-7
    assert np.all(dq[:, :3] == 0.0)                  # nothing sees where the base is
    tau = ID(q, v, a)
    fq, fv, Minv = robot.forward_dynamics_derivatives(q, v, tau, wrench)
    mq, mv = central(FD, robot, q, v, tau)
    assert rel_err(fq, mq) < 1e-6 and rel_err(fv, mv) < 1e-6
    assert rel_err(Minv, np.linalg.inv(robot.mass_matrix(q))) < 1e-10
    if wrench is not None:                           # the wrench's own columns are there
        assert rel_err(dq, robot.inverse_dynamics_derivatives(q, v, a)[0]) > 1e-3
    # joint torques only (the base free) are the same forces with six zeros in front
    fj = robot.forward_dynamics_derivatives(q, v, tau[6:])
    ref = robot.forward_dynamics_derivatives(q, v, np.r_[np.zeros(6), tau[6:]])
    for x, y in zip(fj, ref):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("name", ROBOTS)
def test_the_compiled_derivatives_agree_with_the_reference(name):
    robot = ROBOTS[name]()
    ref = sd.Robot(robot.model, backend="numpy")
    q, v, a = states(robot, 2, N=3)
    for ours, theirs in zip(robot.inverse_dynamics_derivatives(q, v, a),
                            ref.inverse_dynamics_derivatives(q, v, a)):
        assert rel_err(ours, theirs) < 1e-10
    for ours, theirs in zip(robot.forward_dynamics_derivatives(q, v, a),
                            ref.forward_dynamics_derivatives(q, v, a)):
        assert rel_err(ours, theirs) < 1e-8


@pytest.mark.parametrize("name", ROBOTS)
def test_batch_rows_are_single_calls_bit_for_bit(name):
    robot = ROBOTS[name]()
    q, v, x = states(robot, 3, N=5)
    q[:, 3:7] *= 1.7                                 # a quaternion of any length: normalized alike
    batch_id = robot.inverse_dynamics_derivatives(q, v, x)
    batch_fd = robot.forward_dynamics_derivatives(q, v, x[:, 6:])
    w = np.random.default_rng(6).normal(size=(5, 6))
    wrench_id = robot.inverse_dynamics_derivatives(q, v, x, w)
    wrench_fd = robot.forward_dynamics_derivatives(q, v, x, w)
    for k in range(5):
        for one, rows in zip(robot.inverse_dynamics_derivatives(q[k], v[k], x[k]), batch_id):
            np.testing.assert_array_equal(one, rows[k])
        for one, rows in zip(robot.forward_dynamics_derivatives(q[k], v[k], x[k, 6:]), batch_fd):
            np.testing.assert_array_equal(one, rows[k])
        for one, rows in zip(robot.inverse_dynamics_derivatives(q[k], v[k], x[k], w[k]),
                             wrench_id):
            np.testing.assert_array_equal(one, rows[k])
        for one, rows in zip(robot.forward_dynamics_derivatives(q[k], v[k], x[k], w[k]),
                             wrench_fd):
            np.testing.assert_array_equal(one, rows[k])
    # a row broadcast over the batch, and lists, take the general path with the same bits
    bc = robot.inverse_dynamics_derivatives(q[:1], v, x)
    np.testing.assert_array_equal(bc[1][0], batch_id[1][0])
    np.testing.assert_array_equal(robot.forward_dynamics_derivatives(
        list(q[0]), list(v[0]), list(x[0, 6:]))[0], batch_fd[0][0])


def test_bad_input_names_the_culprit():
    robot = ROBOTS["two_arms"]()
    q, v, a = states(robot, 4)
    with pytest.raises(ValueError, match="a has a NaN"):
        robot.inverse_dynamics_derivatives(q, v, np.full(robot.nv, np.nan))
    with pytest.raises(ValueError, match="zero length"):
        robot.forward_dynamics_derivatives(np.r_[q[:3], np.zeros(4), q[7:]], v, a)
    with pytest.raises(ValueError, match=r"tau has shape \(3,\)"):
        robot.forward_dynamics_derivatives(q, v, a[:3])
    with pytest.raises(ValueError, match="wrench"):
        robot.inverse_dynamics_derivatives(q, v, a, wrench=np.ones(5))
    with pytest.raises(ValueError, match="moves by its own dynamics"):
        robot.forward_dynamics_derivatives(q, v, a, base_motion=sd.BaseMotion())
