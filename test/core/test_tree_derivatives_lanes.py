"""core/tree_derivatives_lanes.py: the SIMD-lane batches of d tau/d (q, qd) and d qdd/d (q,
qd, tau) on a fixed-base tree, and on a floating base's instantaneous tree, give every
row bitwise what the single-state kernels give that state alone (core/tree_derivatives.py,
core/floating_derivatives.py), whatever its place in a block: trees of the
example-robot-data, a tree whose bodies are not in depth-first order, trees too big for
a full block (fewer lanes) or for any (one state at a time)."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from floating_batch_rows import check_floating_rows
from pin_reference import erd
from serial_dynamics.core import flags as F
from serial_dynamics.core.layout import W_ALL, W_WRENCH
from serial_dynamics.core.tree_derivatives_lanes import tree_derivative_lanes, tree_walk
from serial_dynamics.model.model import Model
from serial_dynamics.builtin.synthetic import two_arm_urdf

TREES = ["solo_description/robots/solo12.urdf", "talos_data/robots/talos_reduced.urdf",
         "baxter_description/urdf/baxter.urdf"]


def load(rel):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd(rel), gravity=(0.5, -1.0, -9.7))


def lanes(robot):
    P = robot._P
    return tree_derivative_lanes.py_func(P, *tree_walk.py_func(P, np.empty((5, 2 * P.shape[0] + 3))))


def check_rows(robot, N, flags, rng, rows=None):
    """Both batches of N states against the single-state kernels, row by row (bitwise)."""
    k, P, n = robot._k, robot._P, robot._P.shape[0] - 1
    Q = rng.uniform(-3, 3, (N, n))
    Q[min(3, N - 1)] *= 1e-9                    # a block of tiny and huge angles
    Q[N // 2, 1] = 3.0e5
    V, A = rng.normal(size=(N, n)) * 2, rng.normal(size=(N, n)) * 2
    W = rng.normal(size=(N, W_ALL if flags & F.BASE else W_WRENCH))
    dq, dqd = np.full((N, n, n), np.nan), np.full((N, n, n), np.nan)
    assert k.rnea_derivatives_batch(P, Q, V, A, W, flags, dq, dqd) == 0
    fq, fqd, fm = (np.full((N, n, n), np.nan) for _ in range(3))
    assert k.fd_derivatives_batch(P, Q, V, A, W, flags, fq, fqd, fm) == 0
    o2, o3 = np.empty((2, n, n)), np.empty((3, n, n))
    for i in (range(N) if rows is None else rows):
        assert k.rnea_derivatives(P, Q[i], V[i], A[i], W[i], flags, o2) == 0
        assert dq[i].tobytes() == o2[0].tobytes() and dqd[i].tobytes() == o2[1].tobytes(), i
        assert k.fd_derivatives(P, Q[i], V[i], A[i], W[i], flags, o3) == 0
        assert all(a.tobytes() == b.tobytes() for a, b in zip((fq[i], fqd[i], fm[i]), o3)), i
    return Q, V, A, dq, dqd


@pytest.mark.parametrize("rel", TREES)
@pytest.mark.parametrize("flags", [0, F.WRENCH, F.WRENCH | F.BASE])
def test_every_row_is_the_single_state_bitwise(rel, flags):
    robot = load(rel)
    L = lanes(robot)
    assert L >= 16 and L % 8 == 0                # Talos reduced: 16, Baxter and Solo12 32
    check_rows(robot, 2 * L + 5, flags, np.random.default_rng(5))


def test_broadcast_rows_and_a_nan_anywhere():
    robot = load(TREES[0])
    k, P, n = robot._k, robot._P, robot.dof
    N = 40
    rng = np.random.default_rng(2)
    Q, V, A = rng.uniform(-2, 2, (N, n)), rng.normal(size=(N, n)), rng.normal(size=(N, n))
    dq, dqd = np.empty((N, n, n)), np.empty((N, n, n))
    W0 = np.zeros((1, W_WRENCH))
    assert k.rnea_derivatives_batch(P, Q[:1], V, A[:1], W0, 0, dq, dqd) == 0
    out = np.empty((2, n, n))
    assert k.rnea_derivatives(P, Q[0], V[N - 1], A[0], W0[0], 0, out) == 0
    assert dq[N - 1].tobytes() == out[0].tobytes()
    V[35, 2] = np.nan                            # in the second block
    assert k.rnea_derivatives_batch(P, Q, V, A, W0, 0, dq, dqd) == 1
    assert k.fd_derivatives_batch(P, Q, V, A, W0, 0, dq, dqd, dq.copy()) == 1


def breadth_first(model):
    """The same tree with its bodies renumbered breadth first (still topological: a parent
    before its children, but a subtree's bodies no longer consecutive), and the order."""
    n, parent = model.dof, list(model.parent)
    order, frontier = [], [i for i in range(n) if parent[i] < 0]
    while frontier:
        order += frontier
        frontier = [c for p in frontier for c in range(n) if parent[c] == p]
    new = {old: k for k, old in enumerate(order)}
    pick = lambda x: np.asarray(x)[order]         # noqa: E731
    return Model.build(
        name=model.name, joint_names=tuple(pick(model.joint_names)),
        joint_types=tuple(pick(model.joint_types)), link_names=tuple(pick(model.link_names)),
        base_link=model.base_link, tip_link=model.link_names[order[-1]],
        R_parent=pick(model.R_parent), p_parent=pick(model.p_parent), axis=pick(model.axis),
        mass=pick(model.mass), com=pick(model.com), inertia=pick(model.inertia),
        gravity=model.gravity, lower=pick(model.lower), upper=pick(model.upper),
        parent=np.array([-1 if parent[o] < 0 else new[parent[o]] for o in order])), order


def test_a_tree_not_in_depth_first_order():
    """tree_walk walks any topological order; the batch rows are the single calls' bits
    and, renumbered, the derivatives of the depth-first numbering to 1e-12."""
    dfs = sd.load_urdf(two_arm_urdf(4), gravity=(0.5, -1.0, -9.7))
    model, order = breadth_first(dfs.model)
    assert list(model.parent) == [-1, -1, 0, 1, 2, 3, 4, 5]
    bfs = sd.Robot(model)
    assert bfs.kernels()[0].startswith("tree_")
    rng = np.random.default_rng(4)
    check_rows(bfs, 37, F.WRENCH, rng)
    Q, V, A, dq, dqd = check_rows(bfs, 37, 0, rng)
    back = np.argsort(order)                     # depth-first index -> breadth-first index
    for k in (0, 20):
        want = dfs.inverse_dynamics_derivatives(Q[k][back], V[k][back], A[k][back])
        for got, w in zip((dq[k], dqd[k]), want):
            np.testing.assert_allclose(got[np.ix_(back, back)], w, rtol=1e-12,
                                       atol=1e-12 * np.max(np.abs(w)))


@pytest.mark.parametrize("n_each, L", [(12, 16), (18, 8), (19, 0)])
def test_big_trees_fewer_lanes_or_one_state_at_a_time(n_each, L):
    """tree_derivative_lanes: two arms of 12 joints run 16 lanes a block, of 18 joints 8,
    of 19 one state at a time (fewer than 8 lanes would be slower); every row still the
    single call's bits, and the numbers right (central differences of inverse dynamics)."""
    robot = sd.load_urdf(two_arm_urdf(n_each))
    assert lanes(robot) == L
    rng = np.random.default_rng(n_each)
    N = 7
    Q, V, A, dq, dqd = check_rows(robot, N, 0, rng, rows=(0, N - 1))
    e, j = 1e-6, n_each + 2
    fdiff = (robot.inverse_dynamics(Q[0], V[0] + e * np.eye(robot.dof)[j], A[0])
             - robot.inverse_dynamics(Q[0], V[0] - e * np.eye(robot.dof)[j], A[0])) / (2 * e)
    assert np.max(np.abs(fdiff - dqd[0][:, j])) <= 1e-6 * max(1.0, np.max(np.abs(dqd[0])))


@pytest.mark.parametrize("rel, L", [(TREES[0], 16), (TREES[1], 8), (12, 0)])
def test_a_floating_tree_is_the_single_state_bitwise(rel, L):
    """floating_tree_*_derivatives_batch: the instantaneous tree's inputs per state, its
    derivatives (and qdd, M's factor) in lanes, the base's columns, the tip wrench turned
    with the base and the solves per state: each row its single call's bits (Solo12 in
    blocks of 16, Talos' 38 coordinates in blocks of 8, two arms of 12 joints on a
    floating base one state at a time)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(erd(rel) if isinstance(rel, str) else two_arm_urdf(rel, base_mass=3.0),
                             floating_base=True)
    k, P = robot._k, robot._chain
    nv = P.shape[0] - 1
    assert tree_derivative_lanes.py_func(P, *tree_walk.py_func(P, np.empty((5, 2 * nv + 5)))) == L
    rng = np.random.default_rng(3)
    N = 2 * max(L, 8) + 5
    q, v = robot.random_state(rng, batch=N)
    q = np.ascontiguousarray(q)
    q[N // 2, 9] = 3.0e5                         # a huge joint angle in one lane
    a, tau = rng.normal(size=(N, nv)), rng.normal(size=(N, nv)) * 5
    check_floating_rows(k, P, q, v, a, tau, rng)
