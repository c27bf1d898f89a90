"""A base with known motion (``sd.BaseMotion``) against Pinocchio with a free-flyer root at
the identity pose: inverse and forward dynamics, batches, gravity as a base acceleration.

The cases and their oracles: test/modelling_cases.py."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import chain_urdf
from pin_reference import PinReference
from modelling_cases import (BACKENDS, BM, FD_METHODS, G_WORLD, RTOL, XTOL, batch, case,
                             rel_err, states, tmpdir_chains)  # noqa: F401  (fixtures)


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_inverse_dynamics(case, backend):
    robot, ff = case.robots[backend], case.ff
    for q, qd, qdd, w in states(robot, seed=13):
        tau = ff.rnea(q, qd, qdd, BM)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=BM), tau) <= RTOL
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) > 1e-4       # it matters
        tau_w = ff.rnea(q, qd, qdd, BM, w)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, wrench=w, base_motion=BM), tau_w) <= RTOL
        assert rel_err(robot.bias_torques(q, qd, base_motion=BM),
                       ff.rnea(q, qd, 0 * qdd, BM)) <= RTOL
        assert rel_err(robot.bias_torques(q, qd, wrench=w, base_motion=BM),
                       ff.rnea(q, qd, 0 * qdd, BM, w)) <= RTOL
    # the free-flyer oracle without base motion is the fixed-base one
    rest = sd.BaseMotion()
    assert rel_err(ff.rnea(q, qd, qdd, rest), case.ref.rnea(q, qd, qdd)) <= 1e-12
    assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=rest),
                   robot.inverse_dynamics(q, qd, qdd)) <= 1e-14
    # each component of the motion alone
    for bm in (sd.BaseMotion(angular_velocity=(0.0, 0.0, 2.0)),
               sd.BaseMotion(angular_acceleration=(1.0, -3.0, 0.5)),
               sd.BaseMotion(linear_acceleration=(0.0, 4.0, -1.0))):
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=bm),
                       ff.rnea(q, qd, qdd, bm)) <= RTOL, bm


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_batch(case, backend):
    robot, ff = case.robots[backend], case.ff
    Q, QD, QDD, W = batch(robot, 11, seed=14)
    expect = np.array([ff.rnea(*s, BM) for s in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, base_motion=BM), expect) <= RTOL
    expect_w = np.array([ff.rnea(q, qd, qdd, BM, w) for q, qd, qdd, w in zip(Q, QD, QDD, W)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, wrench=W, base_motion=BM), expect_w) <= RTOL
    # one wrench broadcast over the batch
    expect_w0 = np.array([ff.rnea(q, qd, qdd, BM, W[0]) for q, qd, qdd in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD, wrench=W[0], base_motion=BM), expect_w0) <= RTOL
    assert rel_err(robot.bias_torques(Q, QD, base_motion=BM),
                   np.array([ff.rnea(q, qd, 0 * q, BM) for q, qd in zip(Q, QD)])) <= RTOL
    tau = np.random.default_rng(15).uniform(-20, 20, Q.shape)
    qdd = np.array([ff.forward(q, qd, t, BM) for q, qd, t in zip(Q, QD, tau)])
    qdd_w = np.array([ff.forward(q, qd, t, BM, w) for q, qd, t, w in zip(Q, QD, tau, W)])
    for method in FD_METHODS:
        assert rel_err(robot.forward_dynamics(Q, QD, tau, base_motion=BM, method=method), qdd) <= 1e-8
        assert rel_err(robot.forward_dynamics(Q, QD, tau, wrench=W, base_motion=BM, method=method),
                       qdd_w) <= 1e-8


@pytest.mark.parametrize("method", FD_METHODS)
@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_forward_dynamics(case, backend, method):
    robot, ff = case.robots[backend], case.ff
    rng = np.random.default_rng(16)
    for q, qd, _, w in states(robot, count=2, seed=17):
        tau = rng.uniform(-20, 20, robot.dof)
        qdd = robot.forward_dynamics(q, qd, tau, base_motion=BM, method=method)
        assert rel_err(qdd, ff.forward(q, qd, tau, BM)) <= 1e-8
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, base_motion=BM), tau) <= 1e-9
        assert rel_err(robot.forward_dynamics(q, qd, tau, method=method), qdd) > 1e-4
        qdd_w = robot.forward_dynamics(q, qd, tau, wrench=w, base_motion=BM, method=method)
        assert rel_err(qdd_w, ff.forward(q, qd, tau, BM, w)) <= 1e-8
        assert rel_err(robot.inverse_dynamics(q, qd, qdd_w, wrench=w, base_motion=BM), tau) <= 1e-9


def test_base_motion_compiled_matches_reference(case):
    fast, slow = case.robots["numba"], case.robots["numpy"]
    Q, QD, QDD, W = batch(fast, 9, seed=18)
    for kw in (dict(base_motion=BM), dict(base_motion=BM, wrench=W)):
        assert rel_err(fast.inverse_dynamics(Q, QD, QDD, **kw),
                       slow.inverse_dynamics(Q, QD, QDD, **kw)) <= XTOL
        assert rel_err(fast.bias_torques(Q, QD, **kw), slow.bias_torques(Q, QD, **kw)) <= XTOL
        for method in FD_METHODS:
            assert rel_err(fast.forward_dynamics(Q, QD, QDD, method=method, **kw),
                           slow.forward_dynamics(Q, QD, QDD, method=method, **kw)) <= 1e-11
    for k in range(2):
        for kw in (dict(base_motion=BM), dict(base_motion=BM, wrench=W[k])):
            assert rel_err(fast.inverse_dynamics(Q[k], QD[k], QDD[k], **kw),
                           slow.inverse_dynamics(Q[k], QD[k], QDD[k], **kw)) <= XTOL
            assert rel_err(fast.bias_torques(Q[k], QD[k], **kw),
                           slow.bias_torques(Q[k], QD[k], **kw)) <= XTOL
            for method in FD_METHODS:
                assert rel_err(fast.forward_dynamics(Q[k], QD[k], QDD[k], method=method, **kw),
                               slow.forward_dynamics(Q[k], QD[k], QDD[k], method=method, **kw)) <= 1e-11


def test_base_motion_batch_rows_are_single_calls_bitwise(case):
    robot = case.robots["numba"]
    Q, QD, QDD, W = batch(robot, 37, seed=19)
    out = robot.inverse_dynamics(Q, QD, QDD, base_motion=BM)
    out_w = robot.inverse_dynamics(Q, QD, QDD, wrench=W, base_motion=BM)
    out_b = robot.bias_torques(Q, QD, base_motion=BM)
    for k in range(len(Q)):
        np.testing.assert_array_equal(out[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k],
                                                                     base_motion=BM))
        np.testing.assert_array_equal(out_w[k], robot.inverse_dynamics(
            Q[k], QD[k], QDD[k], wrench=W[k], base_motion=BM))
        np.testing.assert_array_equal(out_b[k], robot.bias_torques(Q[k], QD[k], base_motion=BM))


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_translation_is_a_change_of_gravity(case, backend):
    """A base accelerating at a_0 (no rotation) is the base at rest under gravity g - a_0."""
    robot = case.robots[backend]
    a0 = np.array([1.5, -2.0, 3.25])
    shifted = _with_gravity(case, G_WORLD - a0, backend)
    np.testing.assert_array_equal(shifted.gravity, G_WORLD - a0)
    bm = sd.BaseMotion(linear_acceleration=a0)
    Q, QD, QDD, _ = batch(robot, 6, seed=20)
    # the oracles agree on it too (a_0 is the classical acceleration of the base origin)
    ref = PinReference(robot, case.path)
    ref.model.gravity.linear[:] = G_WORLD - a0
    ref.model.armature[ref.iv] = robot.armature
    ref.data = ref.model.createData()
    assert rel_err(case.ff.rnea(Q[0], QD[0], QDD[0], bm), ref.rnea(Q[0], QD[0], QDD[0])) <= 1e-12
    assert rel_err(robot.inverse_dynamics(Q[0], QD[0], QDD[0], base_motion=bm),
                   ref.rnea(Q[0], QD[0], QDD[0])) <= RTOL
    np.testing.assert_array_equal(robot.inverse_dynamics(Q, QD, QDD, base_motion=bm),
                                  shifted.inverse_dynamics(Q, QD, QDD))
    np.testing.assert_array_equal(robot.inverse_dynamics(Q[0], QD[0], QDD[0], base_motion=bm),
                                  shifted.inverse_dynamics(Q[0], QD[0], QDD[0]))
    np.testing.assert_array_equal(robot.bias_torques(Q, QD, base_motion=bm),
                                  shifted.bias_torques(Q, QD))
    assert rel_err(robot.forward_dynamics(Q, QD, QDD, base_motion=bm),
                   shifted.forward_dynamics(Q, QD, QDD)) <= 1e-12


def _with_gravity(case, g, backend):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        r = sd.load_urdf(case.path, case.base, case.tip, gravity=g, armature=case.arm)
    return sd.Robot(r.model, backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_base_motion_bad_input(backend):
    robot = sd.Robot(sd.load_urdf(chain_urdf(4, kinds=["revolute", "prismatic"] * 2)).model,
                     backend=backend)
    n = robot.dof
    q, Q = np.zeros(n), np.zeros((3, n))
    for field in ("angular_velocity", "angular_acceleration", "linear_acceleration"):
        with pytest.raises(ValueError, match=f"{field}.*NaN"):
            sd.BaseMotion(**{field: (0.0, float("nan"), 0.0)})
        with pytest.raises(ValueError, match=f"{field}.*Inf"):
            sd.BaseMotion(**{field: (float("inf"), 0.0, 0.0)})
        for bad in ((1.0, 2.0), np.zeros((3, 1)), (1, 2, 3, 4)):
            with pytest.raises(ValueError, match=f"{field} has shape"):
                sd.BaseMotion(**{field: bad})
    for bad in ((0.0, 0.0, 1.0), np.zeros(9), {"angular_velocity": (0, 0, 1)}, "BM"):
        for x in (q, Q):
            for call in (lambda: robot.inverse_dynamics(x, x, x, base_motion=bad),
                         lambda: robot.inverse_dynamics(x, x, x, wrench=np.zeros(6), base_motion=bad),
                         lambda: robot.bias_torques(x, x, base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, method="aba", base_motion=bad),
                         lambda: robot.forward_dynamics(x, x, x, method="qr", base_motion=bad)):
                with pytest.raises(TypeError, match="BaseMotion"):
                    call()
    # a BaseMotion is immutable: its arrays cannot be changed behind the robot's back
    bm = sd.BaseMotion(angular_velocity=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError):
        bm.angular_velocity[0] = 5.0
    # the state is still validated, naming the argument
    with pytest.raises(ValueError, match="qd"):
        robot.inverse_dynamics(q, np.zeros(n + 1), q, base_motion=bm)
    with pytest.raises(ValueError, match="wrench"):
        robot.inverse_dynamics(q, q, q, wrench=np.zeros(5), base_motion=bm)
