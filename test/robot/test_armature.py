"""Armature (reflected rotor inertia) against Pinocchio's ``model.armature``: inverse and
forward dynamics, the mass matrix, the kinetic energy; compiled against the reference;
batch rows against single calls.

The cases and their oracles: test/modelling_cases.py."""
import numpy as np
import pytest

from modelling_cases import (BACKENDS, FD_METHODS, RTOL, XTOL, batch, case, pin_fext_fixed,
                             rel_err, states, tmpdir_chains)  # noqa: F401  (fixtures)


@pytest.mark.parametrize("backend", BACKENDS)
def test_armature_inverse_dynamics_and_mass_matrix(case, backend):
    robot, ref, ref0 = case.robots[backend], case.ref, case.ref0
    for q, qd, qdd, _ in states(robot):
        tau = ref.rnea(q, qd, qdd)
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), tau) <= RTOL
        assert rel_err(ref0.rnea(q, qd, qdd), tau) > 1e-4                # the armature matters
        np.testing.assert_allclose(tau - ref0.rnea(q, qd, qdd), robot.armature * qdd,
                                   rtol=1e-9, atol=1e-9 * np.max(np.abs(tau)))
        M = ref.mass_matrix(q)
        assert rel_err(robot.mass_matrix(q), M) <= RTOL
        # the bias and gravity torques do not see the armature
        assert rel_err(robot.bias_torques(q, qd), ref.rnea(q, qd, 0 * qdd)) <= RTOL
        assert rel_err(robot.gravity_torques(q), ref.gravity(q)) <= RTOL
    Q, QD, QDD, _ = batch(robot, 7, seed=1)
    expect = np.array([ref.rnea(*s) for s in zip(Q, QD, QDD)])
    assert rel_err(robot.inverse_dynamics(Q, QD, QDD), expect) <= RTOL
    assert rel_err(robot.mass_matrix(Q), np.array([ref.mass_matrix(q) for q in Q])) <= RTOL


@pytest.mark.parametrize("backend", BACKENDS)
def test_armature_forward_dynamics(case, backend):
    robot, ref = case.robots[backend], case.ref
    Q, QD, QDD, W = batch(robot, 5, seed=2)
    TAU = np.array([ref.rnea(*s) for s in zip(Q, QD, QDD)])
    expect = np.array([ref.aba(q, qd, tau) for q, qd, tau in zip(Q, QD, TAU)])
    assert rel_err(expect, QDD) <= 1e-9                    # Pinocchio is consistent
    for method in FD_METHODS:
        for k in range(2):
            got = robot.forward_dynamics(Q[k], QD[k], TAU[k], method=method)
            assert rel_err(got, expect[k]) <= RTOL, method
        assert rel_err(robot.forward_dynamics(Q, QD, TAU, method=method), expect) <= RTOL, method
    # with a tip wrench: Pinocchio's torques against it give the same qdd back
    for k in range(2):
        fext = pin_fext_fixed(ref, robot, Q[k], W[k])
        tau_w = ref.rnea(Q[k], QD[k], QDD[k], fext)
        for method in FD_METHODS:
            assert rel_err(robot.forward_dynamics(Q[k], QD[k], tau_w, wrench=W[k], method=method),
                           QDD[k]) <= 1e-8, method





@pytest.mark.parametrize("backend", BACKENDS)
def test_kinetic_energy_includes_the_armature(case, backend):
    robot, ref = case.robots[backend], case.ref
    Q, QD, _, _ = batch(robot, 6, seed=3)
    T = np.array([0.5 * qd @ ref.mass_matrix(q) @ qd for q, qd in zip(Q, QD)])
    T0 = np.array([0.5 * qd @ case.ref0.mass_matrix(q) @ qd for q, qd in zip(Q, QD)])
    assert np.all(T - T0 > 1e-6 * T)                     # the rotors carry energy
    np.testing.assert_allclose(T - T0, 0.5 * np.sum(robot.armature * QD**2, axis=1), rtol=1e-9)
    assert abs(robot.kinetic_energy(Q[0], QD[0]) - T[0]) <= RTOL * T[0]
    np.testing.assert_allclose(robot.kinetic_energy(Q, QD), T, rtol=RTOL)
    M = robot.mass_matrix(Q)
    np.testing.assert_allclose(robot.kinetic_energy(Q, QD),
                               0.5 * np.einsum("ni,nij,nj->n", QD, M, QD), rtol=1e-13)


def test_armature_compiled_matches_reference(case):
    fast, slow = case.robots["numba"], case.robots["numpy"]
    Q, QD, QDD, W = batch(fast, 9, seed=4)
    for args in ((Q, QD, QDD), (Q[0], QD[0], QDD[0])):
        assert rel_err(fast.inverse_dynamics(*args), slow.inverse_dynamics(*args)) <= XTOL
    assert rel_err(fast.inverse_dynamics(Q, QD, QDD, wrench=W),
                   slow.inverse_dynamics(Q, QD, QDD, wrench=W)) <= XTOL
    assert rel_err(fast.mass_matrix(Q), slow.mass_matrix(Q)) <= XTOL
    TAU = slow.inverse_dynamics(Q, QD, QDD)
    for method in FD_METHODS:
        assert rel_err(fast.forward_dynamics(Q, QD, TAU, method=method),
                       slow.forward_dynamics(Q, QD, TAU, method=method)) <= 1e-11, method
    assert rel_err(fast.kinetic_energy(Q, QD), slow.kinetic_energy(Q, QD)) <= XTOL


def test_armature_batch_rows_are_single_calls_bitwise(case):
    robot = case.robots["numba"]
    Q, QD, QDD, W = batch(robot, 37, seed=5)          # one 32-lane block and a remainder
    out = robot.inverse_dynamics(Q, QD, QDD)
    out_w = robot.inverse_dynamics(Q, QD, QDD, wrench=W)
    for k in range(len(Q)):
        np.testing.assert_array_equal(out[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k]))
        np.testing.assert_array_equal(out_w[k], robot.inverse_dynamics(Q[k], QD[k], QDD[k],
                                                                       wrench=W[k]))
