"""The compiled tree kernels (core/tree.py) against the NumPy reference on trees, to 1e-12;
a batch row is bitwise the single-state answer; bad input names the culprit."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import erd
from serial_dynamics.builtin.synthetic import two_arm_urdf

ROBOTS = ["solo_description/robots/solo12.urdf", "talos_data/robots/talos_reduced.urdf",
          "baxter_description/urdf/baxter.urdf"]


def pair(rel):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        fast = sd.load_urdf(erd(rel), gravity=(0.5, -1.0, -9.7))
    return fast, sd.Robot(fast.model, backend="numpy")


def close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(b))))


@pytest.mark.parametrize("rel", ROBOTS)
def test_compiled_trees_match_the_reference(rel):
    fast, ref = pair(rel)
    assert fast.kernels() and fast.kernels()[0].startswith("tree_")
    rng = np.random.default_rng(5)
    q, qd = fast.random_state(rng, batch=5)
    qdd, tau = rng.uniform(-2, 2, (2, 5, fast.dof))
    w = rng.uniform(-5, 5, 6)
    bm = sd.BaseMotion((0.1, -0.2, 0.3), (0.5, 0.1, -0.4), (0.2, 0.3, -1.0))
    for k in range(2):                        # single states
        close(fast.inverse_dynamics(q[k], qd[k], qdd[k]), ref.inverse_dynamics(q[k], qd[k], qdd[k]))
        close(fast.inverse_dynamics(q[k], qd[k], qdd[k], wrench=w),
              ref.inverse_dynamics(q[k], qd[k], qdd[k], wrench=w))
        close(fast.bias_torques(q[k], qd[k], base_motion=bm),
              ref.bias_torques(q[k], qd[k], base_motion=bm))
        close(fast.gravity_torques(q[k]), ref.gravity_torques(q[k]))
        close(fast.mass_matrix(q[k]), ref.mass_matrix(q[k]))
        for method in ("cholesky", "aba"):   # the sparse factor; articulated bodies (aba.py)
            close(fast.forward_dynamics(q[k], qd[k], tau[k], wrench=w, method=method),
                  ref.forward_dynamics(q[k], qd[k], tau[k], wrench=w))
            close(fast.forward_dynamics(q[k], qd[k], tau[k], base_motion=bm, method=method),
                  ref.forward_dynamics(q[k], qd[k], tau[k], base_motion=bm))
        close(fast.kinetic_energy_gradient(q[k], qd[k]), ref.kinetic_energy_gradient(q[k], qd[k]))
    for name, args, kw in (("inverse_dynamics", (q, qd, qdd), {}), ("mass_matrix", (q,), {}),
                           ("forward_dynamics", (q, qd, tau), {}),
                           ("forward_dynamics", (q, qd, tau), {"method": "aba"})):
        batch = getattr(fast, name)(*args, **kw)
        close(batch, getattr(ref, name)(*args))
        for k in range(5):                    # a batch row is the single call's bits
            assert batch[k].tobytes() == getattr(fast, name)(*(a[k] for a in args), **kw).tobytes()


@pytest.mark.parametrize("rel", ROBOTS)
def test_tree_batches_in_lanes_are_the_single_calls_bits(rel):
    """tree_lanes.py and aba_lanes.py: 70 states (two blocks of 32 lanes and a short one), a
    block mixing tiny and huge angles, a tip wrench per row, a base motion: each row of
    inverse dynamics, mass matrix and forward dynamics (the sparse factor and articulated
    bodies) is bitwise its single call."""
    fast, _ = pair(rel)
    rng = np.random.default_rng(8)
    q, qd = fast.random_state(rng, batch=70)
    q[3] *= 1e-9
    q[40] += 2 * np.pi * 3e5
    qdd, tau = rng.uniform(-2, 2, (2, 70, fast.dof))
    w = rng.uniform(-5, 5, (70, 6))
    bm = sd.BaseMotion((0.1, -0.2, 0.3), (0.5, 0.1, -0.4), (0.2, 0.3, -1.0))
    for kw in ({}, {"wrench": w}, {"base_motion": bm}):
        one = lambda k: {a: (v[k] if a == "wrench" else v) for a, v in kw.items()}   # noqa: E731
        t = fast.inverse_dynamics(q, qd, qdd, **kw)
        for k in range(70):
            assert t[k].tobytes() == fast.inverse_dynamics(q[k], qd[k], qdd[k], **one(k)).tobytes()
        for method in ("cholesky", "aba"):
            a = fast.forward_dynamics(q, qd, tau, **kw, method=method)
            for k in range(70):
                assert a[k].tobytes() == fast.forward_dynamics(q[k], qd[k], tau[k], **one(k),
                                                               method=method).tobytes()
    M = fast.mass_matrix(q)
    for k in range(70):
        assert M[k].tobytes() == fast.mass_matrix(q[k]).tobytes()


@pytest.mark.parametrize("n_each", [22, 23, 28, 29])
def test_a_tree_past_the_lanes_stack_gives_each_state_its_bits(n_each):
    """data.square_lanes_fit: a fixed-base tree of 44 joints runs its batches of M and
    forward dynamics (the sparse factor) in lanes, one of 46 one state at a time;
    aba_lanes.aba_lanes_fit: articulated bodies run in lanes up to 56 joints, one state at a
    time from 58; either way a row is bitwise its single call and agrees with the reference."""
    fast = sd.load_urdf(two_arm_urdf(n_each))
    ref = sd.Robot(fast.model, backend="numpy")
    assert fast.dof == 2 * n_each and fast.kernels()[0].startswith("tree_")
    rng = np.random.default_rng(9)
    q, qd = fast.random_state(rng, batch=35)
    tau = rng.uniform(-20, 20, (35, fast.dof))
    M = fast.mass_matrix(q)
    a, b = (fast.forward_dynamics(q, qd, tau, method=m) for m in ("cholesky", "aba"))
    for k in range(35):
        assert M[k].tobytes() == fast.mass_matrix(q[k]).tobytes()
        assert a[k].tobytes() == fast.forward_dynamics(q[k], qd[k], tau[k], method="cholesky").tobytes()
        assert b[k].tobytes() == fast.forward_dynamics(q[k], qd[k], tau[k], method="aba").tobytes()
    for k in (0, 34):
        close(M[k], ref.mass_matrix(q[k]))
        for x in (a[k], b[k]):
            np.testing.assert_allclose(x, ref.forward_dynamics(q[k], qd[k], tau[k]), rtol=1e-9,
                                       atol=1e-9 * np.max(np.abs(x)))


@pytest.mark.parametrize("rel", ROBOTS)
def test_the_derivatives_of_a_tree_match_the_reference(rel):
    """core/tree_derivatives.py against algorithms/derivatives.py on the parent array, with
    the tip wrench (carried along the tip's path only) and a base motion; a batch row is
    the single call's bits."""
    fast, ref = pair(rel)
    rng = np.random.default_rng(6)
    q, qd = fast.random_state(rng, batch=4)
    qdd, tau = rng.uniform(-2, 2, (2, 4, fast.dof))
    w = rng.uniform(-5, 5, 6)
    bm = sd.BaseMotion((0.1, -0.2, 0.3), (0.5, 0.1, -0.4), (0.2, 0.3, -1.0))
    for kw in ({}, {"wrench": w}, {"base_motion": bm}):
        for name, args in (("inverse_dynamics_derivatives", (q, qd, qdd)),
                           ("forward_dynamics_derivatives", (q, qd, tau))):
            batch = getattr(fast, name)(*args, **kw)
            for got, want in zip(getattr(fast, name)(*(a[0] for a in args), **kw),
                                 getattr(ref, name)(*(a[0] for a in args), **kw)):
                np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10 * np.max(np.abs(want)))
            for k in range(4):
                single = getattr(fast, name)(*(a[k] for a in args), **kw)
                if fast.model.has_mimic_joints and name.startswith("forward"):
                    # Baxter's grippers: the reduced M^-1 by LAPACK, whose batched and single
                    # calls may differ in the last bits (docs/derivatives.md)
                    for b, s in zip(batch, single):
                        close(b[k], s)
                else:
                    assert all(b[k].tobytes() == s.tobytes() for b, s in zip(batch, single)), (name, kw)


def test_a_tree_takes_the_general_paths_of_sim():
    fast, _ = pair(ROBOTS[0])
    assert fast.compiled_chain is None        # sim/'s whole-step kernels are the chain's
    q, qd = fast.random_state(0)
    # dT/dq = C^T qd (the symplectic Euler step's gradient) on the tree
    close(fast.kinetic_energy_gradient(q, qd), fast.coriolis_matrix(q, qd).T @ qd)


def test_bad_states_on_a_tree_name_the_joint():
    fast, _ = pair(ROBOTS[0])
    q = np.zeros(fast.dof)
    q[3] = np.nan
    with pytest.raises(ValueError, match=fast.joint_names[3]):
        fast.inverse_dynamics(q, q * 0, q * 0)
    with pytest.raises(ValueError, match=r"expected \(12,\)"):
        fast.mass_matrix(np.zeros(11))


def test_a_floating_tree_compiled_matches_the_reference():
    """The floating kernels on the instantaneous tree (core/tree.py floating_tree_*) and the
    batches through it, against the reference's 6-DoF root (algorithms/floating.py)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        fast = sd.load_urdf(erd(ROBOTS[0]), floating_base=True)
    ref = sd.Robot(fast.model, backend="numpy")
    rng = np.random.default_rng(9)
    quat = rng.normal(size=(4, 4))
    q = np.hstack([rng.uniform(-1, 1, (4, 3)), quat / np.linalg.norm(quat, axis=1, keepdims=True),
                   rng.uniform(-1, 1, (4, fast.dof))])
    v, a = rng.uniform(-1, 1, (2, 4, fast.nv))
    w = rng.uniform(-5, 5, 6)
    for k in range(2):
        close(fast.inverse_dynamics(q[k], v[k], a[k]), ref.inverse_dynamics(q[k], v[k], a[k]))
        close(fast.inverse_dynamics(q[k], v[k], a[k], wrench=w),
              ref.inverse_dynamics(q[k], v[k], a[k], wrench=w))
        close(fast.mass_matrix(q[k]), ref.mass_matrix(q[k]))
        tau = fast.inverse_dynamics(q[k], v[k], a[k])
        close(fast.forward_dynamics(q[k], v[k], tau), a[k])
        close(fast.forward_dynamics(q[k], v[k], tau, method="aba"), a[k])
        close(fast.forward_dynamics(q[k], v[k], tau, wrench=w, method="aba"),
              ref.forward_dynamics(q[k], v[k], tau, wrench=w))
    for name, args, kw in (("inverse_dynamics", (q, v, a), {}), ("mass_matrix", (q,), {}),
                           ("forward_dynamics", (q, v, a[:, 6:]), {}),
                           ("forward_dynamics", (q, v, a[:, 6:]), {"method": "aba"})):
        batch = getattr(fast, name)(*args, **kw)
        close(batch, getattr(ref, name)(*args))
        for k in range(4):
            assert batch[k].tobytes() == getattr(fast, name)(*(x[k] for x in args), **kw).tobytes()


@pytest.mark.parametrize("rel", ROBOTS[:2])
def test_a_floating_trees_batches_in_lanes_are_the_single_calls_bits(rel):
    """tree_lanes.floating_tree_rnea_block and floating_tree_fd_block (the free-flyer root in
    lanes): 70 floating states (blocks of 32 lanes and a short one), a state of tiny joint
    angles, one of a huge angle, a world wrench per row: each row of inverse dynamics, bias
    and gravity torques, and forward dynamics by the sparse factor (and by articulated
    bodies, aba_lanes) is bitwise its single call (tree_rnea_core, tree_fd_core with
    P[n, ROOT] = 6), rows given or broadcast."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        fast = sd.load_urdf(erd(rel), floating_base=True)
    rng = np.random.default_rng(11)
    q, v = fast.random_state(rng, batch=70)
    a = rng.uniform(-2, 2, (70, fast.nv))
    q[3, 7:] *= 1e-9
    q[40, 9] += 2 * np.pi * 3e5
    w = rng.uniform(-5, 5, (70, 6))
    calls = (("inverse_dynamics", lambda q, v, a, **k: fast.inverse_dynamics(q, v, a, **k)),
             ("bias_torques", lambda q, v, a, **k: fast.bias_torques(q, v, **k)),
             ("gravity_torques", lambda q, v, a: fast.gravity_torques(q)),
             ("forward_dynamics", lambda q, v, a, **k: fast.forward_dynamics(
                 q, v, a, method="cholesky", **k)),
             ("forward_dynamics_aba", lambda q, v, a, **k: fast.forward_dynamics(
                 q, v, a, method="aba", **k)))
    for name, f in calls:
        for kw in ({}, {"wrench": w}) if name != "gravity_torques" else ({},):
            batch = f(q, v, a, **kw)
            for k in range(70):
                one = {"wrench": w[k]} if kw else {}
                assert batch[k].tobytes() == f(q[k], v[k], a[k], **one).tobytes(), (name, k)
        batch = f(q, v[5], a[5])                          # one row broadcast
        for k in range(0, 70, 9):
            assert batch[k].tobytes() == f(q[k], v[5], a[5]).tobytes(), (name, k)


@pytest.mark.parametrize("n_each, floating, method", [(6, False, "cholesky"), (20, False, "aba"),
                                                      (6, True, "cholesky"), (12, True, "aba")])
def test_auto_forward_dynamics_on_a_tree_follows_its_depths(n_each, floating, method):
    """method="auto" on a tree (robot/common.aba_by_default): the sparse factor while the
    mean squared depth of its joints (six more on a floating base) is below TREE_CROSSOVER,
    articulated bodies from there; both give the reference's answer."""
    from serial_dynamics.robot.common import TREE_CROSSOVER
    fast = sd.load_urdf(two_arm_urdf(n_each, base_mass=5.0), floating_base=floating)
    d = np.r_[np.arange(1, n_each + 1), np.arange(1, n_each + 1)] + (6 if floating else 0)
    assert np.array_equal(fast.model.depths + (6 if floating else 0), d)
    assert (np.mean(d ** 2.0) >= TREE_CROSSOVER) == (method == "aba")
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, fast.nq)
    if floating:
        q[3:7] = (0.1, -0.2, 0.3, 0.9) / np.linalg.norm((0.1, -0.2, 0.3, 0.9))
    qd, tau = rng.uniform(-1, 1, (2, fast.nv))
    auto = fast.forward_dynamics(q, qd, tau)
    np.testing.assert_array_equal(auto, fast.forward_dynamics(q, qd, tau, method=method))
    other = "cholesky" if method == "aba" else "aba"
    assert auto.tobytes() != fast.forward_dynamics(q, qd, tau, method=other).tobytes()
    ref = sd.Robot(fast.model, backend="numpy").forward_dynamics(q, qd, tau)
    np.testing.assert_allclose(auto, ref, rtol=1e-9, atol=1e-9 * np.max(np.abs(ref)))
