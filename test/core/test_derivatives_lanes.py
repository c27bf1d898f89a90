"""core/derivatives_lanes.py: the SIMD-lane batches of d tau/d (q, qd) and of d qdd/d (q, qd,
tau) give every row bitwise what the single-state kernels give that state alone
(core/derivatives.py), whatever its place in a block, for revolute and prismatic joints, a
tip wrench, a moving base, a huge angle."""
import numpy as np
import pytest

import serial_dynamics as sd
from floating_batch_rows import check_floating_rows
from serial_dynamics.core import K
from serial_dynamics.core import flags as F
from serial_dynamics.core.derivatives_lanes import DLANES
from serial_dynamics.core.layout import LANES, W_ALL, W_WRENCH
from serial_dynamics.builtin.synthetic import chain_urdf

ROBOTS = {
    "ur5e": sd.default_robot,
    "prismatic": lambda: sd.load_urdf(chain_urdf(
        5, kinds=["prismatic", "revolute", "prismatic", "revolute", "revolute"],
        masses=[2.0, 1.5, 1.0, 0.7, 0.4], lengths=[0.3, 0.25, 0.2, 0.15, 0.1]),
        gravity=(0.5, -1.0, -9.81), armature={"joint1": 0.2}),
}


@pytest.mark.parametrize("name", sorted(ROBOTS))
@pytest.mark.parametrize("flags", [0, F.WRENCH, F.WRENCH | F.BASE])
def test_every_row_is_the_single_state_bitwise(name, flags):
    robot = ROBOTS[name]()
    n, P = robot.dof, robot._P
    rng = np.random.default_rng(5)
    N = 3 * DLANES + 5                          # whole blocks and a partial one
    Q = rng.uniform(-3, 3, (N, n))
    Q[DLANES + 2, 1] = 3.0e5                    # a huge angle: libm's sine in that lane only
    V, A = rng.normal(size=(N, n)) * 2, rng.normal(size=(N, n)) * 2
    W = rng.normal(size=(N, W_ALL if flags & F.BASE else W_WRENCH))
    dq, dqd = np.full((N, n, n), np.nan), np.full((N, n, n), np.nan)
    assert K.rnea_derivatives_batch(P, Q, V, A, W, flags, dq, dqd) == 0
    out = np.empty((2, n, n))
    for k in range(N):
        assert K.rnea_derivatives(P, Q[k], V[k], A[k], W[k], flags, out) == 0
        np.testing.assert_array_equal(dq[k], out[0])
        np.testing.assert_array_equal(dqd[k], out[1])
    # forward dynamics: qdd, tau at the same states
    fq, fqd, fm = (np.full((N, n, n), np.nan) for _ in range(3))
    assert K.fd_derivatives_batch(P, Q, V, A, W, flags, fq, fqd, fm) == 0
    out3 = np.empty((3, n, n))
    for k in range(N):
        assert K.fd_derivatives(P, Q[k], V[k], A[k], W[k], flags, out3) == 0
        for a, b in zip((fq[k], fqd[k], fm[k]), out3):
            np.testing.assert_array_equal(a, b)
    # broadcast rows (1, n) are the same state in every lane
    dq1, dqd1 = np.empty((N, n, n)), np.empty((N, n, n))
    assert K.rnea_derivatives_batch(P, Q[:1], V, A[:1], W[:1], flags, dq1, dqd1) == 0
    K.rnea_derivatives(P, Q[0], V[N - 1], A[0], W[0], flags, out)
    np.testing.assert_array_equal(dq1[N - 1], out[0])


def test_a_nan_anywhere_is_reported():
    robot = sd.default_robot()
    N, n = 2 * DLANES, robot.dof
    Q, V, A = np.zeros((N, n)), np.zeros((N, n)), np.zeros((N, n))
    V[DLANES + 3, 2] = np.nan
    dq, dqd = np.empty((N, n, n)), np.empty((N, n, n))
    assert K.rnea_derivatives_batch(robot._P, Q, V, A, np.zeros((1, 6)), 0, dq, dqd) == 1
    assert K.fd_derivatives_batch(robot._P, Q, V, A, np.zeros((1, 6)), 0, dq, dqd, dq.copy()) == 1
    with pytest.raises(ValueError, match="qd"):
        robot.inverse_dynamics_derivatives(Q, V, A)


@pytest.mark.parametrize("n", [20, 72, 73])
def test_long_chains_fewer_lanes_or_one_state_at_a_time(n):
    """derivative_lanes: a block holds as many lanes as keep its tangents on the stack (11 at
    n = 20, 1 at n = 72) and from n = 73 on the batch runs one state at a time; either way
    every row is bitwise the single-state derivatives."""
    from serial_dynamics.core.derivatives_lanes import derivative_lanes
    robot = sd.load_urdf(chain_urdf(n))
    P = robot._P
    assert derivative_lanes(n, 32) == {20: 11, 72: 1, 73: 0}[n]
    rng = np.random.default_rng(n)
    N = 13
    Q, V, A = rng.uniform(-2, 2, (N, n)), rng.normal(size=(N, n)), rng.normal(size=(N, n))
    W = np.zeros((1, W_WRENCH))
    dq, dqd = np.empty((N, n, n)), np.empty((N, n, n))
    fq, fqd, fm = (np.empty((N, n, n)) for _ in range(3))
    assert K.rnea_derivatives_batch(P, Q, V, A, W, 0, dq, dqd) == 0
    assert K.fd_derivatives_batch(P, Q, V, A, W, 0, fq, fqd, fm) == 0
    out, out3 = np.empty((2, n, n)), np.empty((3, n, n))
    for k in (0, 5, N - 1):
        assert K.rnea_derivatives(P, Q[k], V[k], A[k], W[0], 0, out) == 0
        assert dq[k].tobytes() == out[0].tobytes() and dqd[k].tobytes() == out[1].tobytes()
        assert K.fd_derivatives(P, Q[k], V[k], A[k], W[0], 0, out3) == 0
        assert all(a.tobytes() == b.tobytes() for a, b in zip((fq[k], fqd[k], fm[k]), out3))
    # and the numbers are right: d tau/d qd by central differences of inverse dynamics
    e = 1e-6
    fdiff = (robot.inverse_dynamics(Q[5], V[5] + e * np.eye(n)[3], A[5])
             - robot.inverse_dynamics(Q[5], V[5] - e * np.eye(n)[3], A[5])) / (2 * e)
    assert np.max(np.abs(fdiff - dqd[5][:, 3])) <= 1e-6 * max(1.0, np.max(np.abs(dqd[5])))


BASE_LINK = ('<link name="base_link"><inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="3"/>'
             '<inertia ixx="0.1" iyy="0.2" izz="0.15" ixy="0" ixz="0" iyz="0"/></inertial></link>')


@pytest.mark.parametrize("joints, L", [(6, 29), (8, 22), (67, 0)])
def test_a_floating_chain_is_the_single_state_bitwise(joints, L):
    """floating_*_derivatives_batch on a chain: each state's instantaneous-chain inputs, its
    derivatives (forward: qdd and M's factor too) in lanes, the base's columns, the tip
    wrench turned with the base and the solves per state: every row its single call's bits
    (6 and 8 joints on a floating base: 12 and 14 coordinates, blocks of 29 and 22 lanes
    and a partial one; 67 joints: 73 coordinates, one state at a time), with and without a
    world wrench, the quaternion of any length, a huge joint angle in one lane."""
    from serial_dynamics.core.derivatives_lanes import derivative_lanes
    urdf = sd.builtin_path("ur5e") if joints == 6 else chain_urdf(
        joints, kinds=["revolute", "prismatic"] * (joints // 2) + ["revolute"] * (joints % 2),
        masses=0.8, lengths=0.2).replace('<link name="base_link"/>', BASE_LINK)
    robot = sd.load_urdf(urdf, floating_base=True)
    k, P = robot._k, robot._chain
    nv = P.shape[0] - 1
    assert nv == joints + 6 and derivative_lanes(nv, int(P[nv, LANES])) == L
    rng = np.random.default_rng(joints)
    N = 2 * L + 5 if L else 3
    q, v = robot.random_state(rng, batch=N)
    q = np.ascontiguousarray(q)
    q[:, 3:7] *= 1.3                              # normalized alike on both paths
    q[N // 2, 8] = 3.0e5                          # a huge joint angle in one lane
    a, tau = rng.normal(size=(N, nv)), rng.normal(size=(N, nv)) * 5
    gw = check_floating_rows(k, P, q, v, a, tau, rng)
    o3 = np.empty((3, nv, nv))
    dq, dv, fq, fv, fm = (np.empty((N, nv, nv)) for _ in range(5))
    # joint torques only (the base free): the same forces with six zeros in front
    fj = [np.empty((N, nv, nv)) for _ in range(3)]
    assert k.floating_fd_derivatives_batch(P, q, v, np.ascontiguousarray(tau[:, 6:]), gw, 0,
                                           *fj) == 0
    tz = tau.copy()
    tz[:, :6] = 0.0
    assert k.floating_fd_derivatives(P, q[0], v[0], tz[0], gw[0], 0, o3) == 0
    assert all(x.tobytes() == y.tobytes() for x, y in zip((fj[0][0], fj[1][0], fj[2][0]), o3))
    # a NaN in the last state is reported, the others computed
    v[N - 1, 2] = np.nan
    assert k.floating_rnea_derivatives_batch(P, q, v, a, gw, 0, dq, dv) == 1
    assert k.floating_fd_derivatives_batch(P, q, v, tau, gw, 0, fq, fv, fm) == 1
