"""Hard cases for the simulator, each asserting numbers: energy conservation and balance,
a stiff chain, an ill-conditioned chain against an extended-precision reference, a
100-joint chain, a high-speed spin and a 60 s horizon.

Relative energy errors are max_t |E(t) - E(0) - W(t)| divided by the energy scale of the
run (the largest of the kinetic energy, the swing of the potential energy and the works),
so that the arbitrary zero of the potential energy does not flatter them.
"""
import mpmath
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import (chain_urdf, ill_conditioned_chain_urdf,
                                              stiff_chain_urdf)
from serial_dynamics.sim.methods import SimulationError

EPS = np.finfo(float).eps
Q0 = np.array([0.3, -1.0, 0.8, -0.5, 0.4, 0.2])


@pytest.fixture(scope="module")
def ur5e():
    return sd.default_robot()


def drift(res):
    e = res.energy
    return np.max(np.abs(e - e[0])) / res.energy_scale()


# ----------------------------------------------------------------------------- energy
def test_energy_conserved_over_10s(ur5e):
    """No dissipation, no torque: E is conserved to 1e-8 over 10 s (DOP853, tight)."""
    res = sd.simulate(ur5e, 10.0, Q0, None, method="DOP853", rtol=1e-12, atol=1e-12,
                      dissipation=False)
    assert drift(res) <= 1e-8
    e = res.energy
    assert np.max(np.abs(e - e[0])) / abs(e[0]) <= 1e-8
    assert np.max(res.kinetic) > 30.0            # a real swing, not a robot at rest


@pytest.fixture(scope="module")
def rough_ur5e():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(
        viscous=[0.8, 0.8, 0.5, 0.1, 0.1, 0.05], coulomb=[2, 2, 1.5, 0.3, 0.3, 0.1],
        stribeck=[1, 1, 0.5, 0.1, 0.1, 0.05], stribeck_rate=5.0)
    return robot


AMP = np.array([20, 40, 15, 3, 2, 0.5])
FREQ = 2 * np.pi * np.array([0.5, 0.7, 1.1, 1.3, 1.7, 2.3])


def shaking(t, q, qd):
    return AMP * np.sin(FREQ * t)


@pytest.mark.parametrize("method", ["Radau", "LSODA"])
def test_energy_balance_with_dissipation_and_torque(rough_ur5e, method):
    """E(t) - E(0) = int tau.qd + int delta.qd to 1e-6 (relative), with viscous, Coulomb and
    Stribeck friction (regularized) and time-varying torques."""
    res = sd.simulate(rough_ur5e, 3.0, Q0, None, shaking, method=method, rtol=1e-8,
                      atol=1e-10)
    assert res.relative_energy_error() <= 1e-6
    assert res.energy_dissipated[-1] > 100.0 and res.work_actuators[-1] > 100.0
    assert np.all(np.diff(res.work_dissipation) <= 1e-12)     # dissipation only takes
    # the integrated works agree with quadrature of the recorded powers
    p_act = np.einsum("ij,ij->i", res.tau, res.qd)
    w = np.concatenate([[0], np.cumsum(np.diff(res.t) * 0.5 * (p_act[1:] + p_act[:-1]))])
    assert np.max(np.abs(w - res.work_actuators)) < 1e-3 * res.energy_scale()


def test_energy_balance_fixed_step_stick_slip(rough_ur5e):
    """The fixed-step methods with stick-slip keep the balance to their (lower) order."""
    for method, dt, bound in (("rk4", 1e-4, 3e-3), ("implicit_midpoint", 1e-3, 2e-2)):
        res = sd.simulate(rough_ur5e, 3.0, Q0, None, shaking, method=method, dt=dt)
        assert res.relative_energy_error() <= bound, method


# ----------------------------------------------------------------------------- stiff chain
@pytest.fixture(scope="module")
def stiff():
    robot = sd.load_urdf(stiff_chain_urdf())
    q0 = np.array([0.3, 0.8, -0.5, 0.6])
    ref = sd.simulate(robot, 0.5, q0, method="Radau", rtol=1e-10, atol=1e-12)
    return robot, q0, ref


def final_error(res, ref):
    return np.max(np.abs(np.r_[res.q[-1] - ref.q[-1], res.qd[-1] - ref.qd[-1]]))


def test_stiff_chain_is_stiff(stiff):
    robot, q0, _ = stiff
    rates = np.sort(np.abs(np.linalg.eigvals(np.linalg.solve(
        robot.mass_matrix(q0), np.diag(robot.dissipation.viscous)))))
    assert rates[-1] > 5e3 and rates[-1] / rates[0] > 1e3


def test_stiff_chain_reference_agrees(stiff):
    robot, q0, ref = stiff
    other = sd.simulate(robot, 0.5, q0, method="BDF", rtol=1e-11, atol=1e-13)
    assert final_error(other, ref) < 1e-8


def test_stiff_chain_implicit_beats_explicit(stiff):
    """Radau, BDF and LSODA reach the reference within 1e-6 with at least 10x fewer
    dynamics evaluations than RK45, counting every perturbed state of their Jacobians."""
    robot, q0, ref = stiff
    rk45 = sd.simulate(robot, 0.5, q0, method="RK45", rtol=1e-6, atol=1e-8)
    assert final_error(rk45, ref) < 1e-6
    lam = 5e3    # RK45's stability bound on the negative real axis is about 3.3 / h
    assert rk45.stats.steps + rk45.stats.rejected > lam * 0.5 / 3.5
    counts = {}
    for method, rtol in (("Radau", 1e-6), ("BDF", 1e-7), ("LSODA", 1e-7)):
        res = sd.simulate(robot, 0.5, q0, method=method, rtol=rtol, atol=rtol * 1e-2)
        assert final_error(res, ref) < 1e-6, method
        counts[method] = res.stats.dynamics_states
        assert 10 * res.stats.dynamics_states <= rk45.stats.dynamics_states, (method, counts)
        assert res.stats.nfev * 10 <= rk45.stats.nfev


def test_stiff_chain_fixed_step(stiff):
    """At 1 ms the implicit midpoint rule is stable (and accurate); explicit ones diverge."""
    robot, q0, ref = stiff
    res = sd.simulate(robot, 0.5, q0, method="implicit_midpoint", dt=1e-3)
    assert final_error(res, ref) < 1e-5
    assert np.all(np.diff(res.energy) <= 1e-12)     # damped, unforced: E never rises
    for method in ("semi_implicit_euler", "rk4"):
        with pytest.raises(SimulationError, match="implicit"):
            sd.simulate(robot, 0.5, q0, method=method, dt=1e-3)


# ----------------------------------------------------------------------------- ill-conditioned
def _mp_rnea(model, q, qd, qdd, g):
    """Recursive Newton-Euler in mpmath (outward velocities/accelerations, inward forces),
    written independently of the library from the model's (exact, float64) data."""
    def vec(x):
        return mpmath.matrix([mpmath.mpf(float(v)) for v in np.asarray(x).reshape(-1)])

    def mat(A):
        return mpmath.matrix([[mpmath.mpf(float(v)) for v in row] for row in np.asarray(A)])

    def cross(a, b):
        return mpmath.matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                              a[0] * b[1] - a[1] * b[0]])

    n = model.dof
    R, p = [], []
    for i in range(n):
        k = vec(model.axis[i])
        K = mpmath.matrix([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        Rot = mpmath.eye(3) + mpmath.sin(q[i]) * K + (1 - mpmath.cos(q[i])) * (K * K)  # Rodrigues
        R.append(mat(model.R_parent[i]) * Rot)
        p.append(vec(model.p_parent[i]))
    om, al, acc = mpmath.matrix(3, 1), mpmath.matrix(3, 1), -g
    F, N = [], []
    for i in range(n):
        a, Rt = vec(model.axis[i]), R[i].T
        acc = Rt * (acc + cross(al, p[i]) + cross(om, cross(om, p[i])))
        om, al = Rt * om, Rt * al
        al = al + cross(om, a * qd[i]) + a * qdd[i]
        om = om + a * qd[i]
        c, I, m = vec(model.com[i]), mat(model.inertia[i]), mpmath.mpf(float(model.mass[i]))
        F.append(m * (acc + cross(al, c) + cross(om, cross(om, c))))
        N.append(I * al + cross(om, I * om))
    f, mo, tau = mpmath.matrix(3, 1), mpmath.matrix(3, 1), [None] * n
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            f_out = R[i + 1] * f
            mo = R[i + 1] * mo + cross(p[i + 1], f_out)
            f = f_out
        f = f + F[i]
        mo = mo + N[i] + cross(vec(model.com[i]), F[i])
        tau[i] = (mo.T * vec(model.axis[i]))[0]
    return mpmath.matrix(tau)


def _mp_forward(model, q, qd, tau):
    """qdd solving M qdd = tau - b in 50-digit arithmetic, for the float64 model and inputs
    taken as exact: the answer an exact algorithm would give for these numbers."""
    n = model.dof
    qm = [mpmath.mpf(float(v)) for v in q]
    zero = [mpmath.mpf(0)] * n
    b = _mp_rnea(model, qm, [mpmath.mpf(float(v)) for v in qd], zero,
                 mpmath.matrix([mpmath.mpf(float(v)) for v in model.gravity]))
    M = mpmath.matrix(n, n)
    for j in range(n):
        col = _mp_rnea(model, qm, zero, [mpmath.mpf(int(i == j)) for i in range(n)],
                       mpmath.matrix(3, 1))
        for i in range(n):
            M[i, j] = col[i]
    rhs = mpmath.matrix([mpmath.mpf(float(v)) for v in tau]) - b
    return M, b, mpmath.lu_solve(M, rhs)


def test_ill_conditioned_chain_against_extended_precision():
    """cond(M) ~ 2e10. Reference: the exact solution for the float64 model and inputs
    (50 digits). The conditioning is in the scales (masses from 10 kg to 1e-5 kg): the
    diagonally scaled matrix H = D^-1/2 M D^-1/2 has cond ~ 3, and both routes are
    invariant to that scaling (van der Sluis; Demmel, *Applied Numerical Linear Algebra*,
    Sec. 2.5), so their errors are bounded by c n cond(H) eps, not cond(M) eps = 4e-6.
    Measured (4 seeded states), componentwise: Cholesky (compiled) <= 3.2e-15, QR of P
    <= 4.4e-14; the NumPy reference CRBA keeps composite inertias about each joint's origin
    and errs by <= 3.5e-13 (summing about the base origin lost 4-5 digits: 1.3e-11)."""
    mpmath.mp.dps = 50
    robot = sd.load_urdf(ill_conditioned_chain_urdf())
    reference_path = sd.Robot(robot.model, backend="numpy")
    n = robot.dof
    rng = np.random.default_rng(7)
    worst = {"cholesky": 0.0, "qr": 0.0, "cholesky (numpy)": 0.0}
    for _ in range(4):
        q, qd = robot.random_state(rng)
        tau = rng.uniform(-1, 1, n) * np.geomspace(10, 1e-5, n)
        M, b, x = _mp_forward(robot.model, q, qd, tau)
        ref = np.array([float(v) for v in x])
        Mf = np.array([[float(M[i, j]) for j in range(n)] for i in range(n)])
        d = np.sqrt(np.diag(Mf))
        assert np.max(np.abs(robot.mass_matrix(q) - Mf) / np.outer(d, d)) < 10 * n * EPS
        kappa = np.linalg.cond(Mf)
        kappa_h = np.linalg.cond(Mf / np.outer(d, d))
        assert 1e10 < kappa < 5e10 and kappa_h < 10
        # what rounding M and b to float64 alone does: solve the rounded system exactly
        x_r = mpmath.lu_solve(mpmath.matrix(Mf.tolist()), mpmath.matrix(tau.tolist())
                              - mpmath.matrix([float(v) for v in b]))
        assert np.max(np.abs(np.array([float(v) for v in x_r]) / ref - 1)) < 4 * n * kappa_h * EPS
        for method, r in (("cholesky", robot), ("qr", robot), ("cholesky (numpy)", reference_path)):
            qdd = r.forward_dynamics(q, qd, tau, method=method.split()[0])
            comp = np.max(np.abs(qdd - ref) / np.abs(ref))
            scaled = np.linalg.norm(d * (qdd - ref)) / np.linalg.norm(d * ref)
            worst[method] = max(worst[method], comp)
            assert np.linalg.norm(qdd - ref) / np.linalg.norm(ref) <= kappa * EPS
            # the NumPy reference forms the last joint's tiny torque (a 1e-5 kg rod spun about
            # its own axis) from moments about the body origin, with round-off cancellation
            # (measured 4.3e-14 scaled, 3.5e-13 componentwise); the compiled kernels stay within 10 n cond(H) eps
            factor = 100 if r is reference_path else 10
            assert scaled <= factor * n * kappa_h * EPS, (method, scaled)
            assert comp <= 10 * factor * n * kappa_h * EPS, (method, comp)
    print(f"ill-conditioned chain, worst componentwise relative error: {worst}")


# ----------------------------------------------------------------------------- long chain
@pytest.fixture(scope="module")
def chain100():
    return sd.load_urdf(chain_urdf(100))


def test_long_chain_forward_inverse(chain100):
    """forward(inverse(qdd)) = qdd to cond(M) eps on a 100-joint chain (cond ~ 1e9),
    for every forward-dynamics route."""
    robot = chain100
    rng = np.random.default_rng(3)
    q = rng.uniform(-0.3, 0.3, (4, 100))
    qd, qdd = rng.uniform(-1, 1, (2, 4, 100))
    tau = robot.inverse_dynamics(q, qd, qdd)
    kappa = np.linalg.cond(robot.mass_matrix(q))
    assert np.all(kappa > 1e8)
    for method in ("cholesky", "aba", "qr"):
        back = robot.forward_dynamics(q, qd, tau, method=method)
        err = np.linalg.norm(back - qdd, axis=1) / np.linalg.norm(qdd, axis=1)
        assert np.all(err <= kappa * EPS), (method, err, kappa * EPS)


def test_long_chain_energy(chain100):
    rng = np.random.default_rng(4)
    q0 = rng.uniform(-0.3, 0.3, 100)
    res = sd.simulate(chain100, 1.0, q0, None, method="DOP853", rtol=1e-10, atol=1e-12)
    assert drift(res) <= 1e-8
    assert np.max(np.abs(res.qd)) > 10.0


# ----------------------------------------------------------------------------- spin, horizon
def test_high_speed_spin(ur5e):
    """Wrists spinning at 25-40 rad/s: the velocity-product (gyroscopic, centrifugal)
    torques dwarf gravity. Energy and the momentum about the vertical base axis (joint 1,
    about which gravity exerts no torque) are conserved."""
    qd0 = np.array([2.0, 1.0, -1.5, 25.0, -30.0, 40.0])
    velocity_torques = ur5e.bias_torques(Q0, qd0) - ur5e.gravity_torques(Q0)
    assert np.linalg.norm(velocity_torques) > 3 * np.linalg.norm(ur5e.gravity_torques(Q0))
    for method, kw, bound in (("DOP853", dict(rtol=1e-12, atol=1e-12), 1e-9),
                              ("rk4", dict(dt=1e-4), 1e-8)):
        res = sd.simulate(ur5e, 2.0, Q0, qd0, method=method, **kw)
        assert drift(res) <= bound, method
        p1 = np.einsum("kj,kj->k", ur5e.mass_matrix(res.q)[:, 0, :], res.qd)
        assert np.max(np.abs(p1 - p1[0])) <= bound * np.max(np.abs(p1)), method
        assert np.max(np.abs(res.qd)) > 100.0


def test_60s_horizon(ur5e):
    """A minute of free swing (chaotic: the wrists whip up to ~150 rad/s): DOP853 keeps E
    to 1e-8 (measured 5e-10). RK4 at 1 ms: measured 1e-5 .. 9e-5 over initial states
    perturbed by 1e-9 rad (the chaos decides how fast the wrist gets), bound 5e-4."""
    res = sd.simulate(ur5e, 60.0, Q0, None, method="DOP853", rtol=1e-10, atol=1e-12,
                      output_dt=0.01)
    assert drift(res) <= 1e-8
    rk4 = sd.simulate(ur5e, 60.0, Q0, None, method="rk4", dt=1e-3, output_dt=0.01)
    assert drift(rk4) <= 5e-4
