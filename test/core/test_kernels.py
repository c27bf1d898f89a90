"""Compiled kernels (backend "numba") against the NumPy reference (backend "numpy").

Agreement is asserted to 1e-12 relative (max |ours - ref| / max |ref|) for inverse dynamics,
bias and gravity torques and the mass matrix on every robot, and for forward dynamics on
the arms. On the 100-joint chains the mass matrix has cond ~1e7, so two correct
forward-dynamics solvers (the reference's own Cholesky and ABA included) differ by up to
cond * eps: there the test asserts the backward error |ID(q, qd, qdd) - tau| /
(|M qdd| + |b| + |tau|) to 1e-12 and the forward error to 10 cond eps.
"""
import re
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import Robot
from serial_dynamics import core
from serial_dynamics.core import flags as F
from serial_dynamics.core.spatial import sincos
from serial_dynamics.robot.facade import PLANAR_KERNELS, ROBOT_KERNELS
from serial_dynamics.sim.compiled_euler import _loop, simulate_fixed_step
from serial_dynamics.algorithms import aba, forward, rnea
from serial_dynamics.builtin.synthetic import chain_urdf

TOL = 1e-12


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def _panda():
    from pin_reference import erd, load
    return load(erd("panda_description/urdf/panda.urdf"), None, "panda_link8")


ROBOTS = {
    "ur5e": lambda: sd.default_robot(),
    "panda": _panda,
    "planar_3r": lambda: sd.builtin_robot("planar_3r"),          # wall-mounted: tilted gravity
    "prismatic_chain": lambda: sd.load_urdf(chain_urdf(9, kinds=["revolute", "prismatic", "revolute"] * 3)),
    "chain_100": lambda: sd.load_urdf(chain_urdf(100)),
    "prismatic_chain_100": lambda: sd.load_urdf(chain_urdf(100, kinds=(["revolute"] * 4 + ["prismatic"]) * 20)),
}
LONG = ("chain_100", "prismatic_chain_100")


@pytest.fixture(scope="module", params=list(ROBOTS))
def pair(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = ROBOTS[request.param]()
    assert robot.backend == "numba"
    return request.param, robot, Robot(robot.model, backend="numpy")


def states(robot, seed=0, batch=None):
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, batch=batch, speed=2.0)
    shape = q.shape
    return q, qd, rng.normal(size=shape) * 3, rng.normal(size=shape) * 20, rng.normal(size=6) * 5


@pytest.mark.parametrize("batch", [None, 37])
def test_rigid_body_terms_match_reference(pair, batch):
    _, robot, ref = pair
    q, qd, qdd, _, w = states(robot, batch=batch)
    assert rel(robot.inverse_dynamics(q, qd, qdd), ref.inverse_dynamics(q, qd, qdd)) <= TOL
    assert rel(robot.inverse_dynamics(q, qd, qdd, w), ref.inverse_dynamics(q, qd, qdd, w)) <= TOL
    assert rel(robot.bias_torques(q, qd), ref.bias_torques(q, qd)) <= TOL
    assert rel(robot.bias_torques(q, qd, w), ref.bias_torques(q, qd, w)) <= TOL
    assert rel(robot.gravity_torques(q), ref.gravity_torques(q)) <= TOL
    assert rel(robot.mass_matrix(q), ref.mass_matrix(q)) <= TOL
    if batch:
        W = np.random.default_rng(1).normal(size=(batch, 6))
        assert rel(robot.inverse_dynamics(q, qd, qdd, W), ref.inverse_dynamics(q, qd, qdd, W)) <= TOL


@pytest.mark.parametrize("batch", [None, 9])
@pytest.mark.parametrize("method", ["cholesky", "aba"])
def test_forward_dynamics_matches_reference(pair, method, batch):
    name, robot, ref = pair
    q, qd, _, tau, w = states(robot, seed=2, batch=batch)
    for wrench in (None, w):
        qdd = robot.forward_dynamics(q, qd, tau, wrench, method=method)
        qdd_ref = ref.forward_dynamics(q, qd, tau, wrench, method="cholesky")
        residual = ref.inverse_dynamics(q, qd, qdd, wrench) - tau
        scale = (np.max(np.abs(ref.inverse_dynamics(q, 0 * qd, qdd) - ref.gravity_torques(q)))
                 + np.max(np.abs(ref.bias_torques(q, qd, wrench))) + np.max(np.abs(tau)))
        assert np.max(np.abs(residual)) <= TOL * scale
        if name in LONG:
            kappa = np.linalg.cond(ref.mass_matrix(q if batch is None else q[0]))
            assert rel(qdd, qdd_ref) <= 10 * kappa * np.finfo(float).eps
        else:
            assert rel(qdd, qdd_ref) <= TOL


def test_auto_method_follows_the_crossover(pair):
    _, robot, _ = pair
    q, qd, _, tau, _ = states(robot, seed=3)
    method = "aba" if robot.dof >= aba.CROSSOVER else "cholesky"
    np.testing.assert_array_equal(robot.forward_dynamics(q, qd, tau),
                                  robot.forward_dynamics(q, qd, tau, method=method))


def test_batch_equals_single_states(pair):
    _, robot, _ = pair
    q, qd, qdd, tau, w = states(robot, seed=4, batch=70)     # 70: two full blocks and a partial one
    tb = robot.inverse_dynamics(q, qd, qdd)
    Mb = robot.mass_matrix(q)
    fb = robot.forward_dynamics(q, qd, tau, w)
    for k in (0, 33, 69):
        assert rel(tb[k], robot.inverse_dynamics(q[k], qd[k], qdd[k])) <= TOL
        assert rel(Mb[k], robot.mass_matrix(q[k])) <= TOL
        assert rel(fb[k], robot.forward_dynamics(q[k], qd[k], tau[k], w)) <= TOL
    # a single row broadcast over the batch
    assert rel(robot.inverse_dynamics(q, qd[0], qdd), robot.inverse_dynamics(q, np.tile(qd[0], (70, 1)), qdd)) <= TOL
    assert rel(robot.gravity_torques(q[:1]), robot.gravity_torques(q[0])[None]) <= TOL


@pytest.mark.parametrize("n", [45, 46])
def test_a_chain_past_the_lanes_stack_gives_each_state_its_bits(n):
    """data.square_lanes_fit: a 45-joint chain's mass matrices and Cholesky forward dynamics
    run in lanes (45^2 x 32 doubles of M fit 512 KiB of stack), a 46-joint one's one state at
    a time; either way a batch row is bitwise its single call and agrees with the reference."""
    robot = sd.load_urdf(chain_urdf(n))
    ref = Robot(robot.model, backend="numpy")
    q, qd, _, tau, _ = states(robot, seed=11, batch=35)
    M, a = robot.mass_matrix(q), robot.forward_dynamics(q, qd, tau, method="cholesky")
    for k in range(35):
        assert M[k].tobytes() == robot.mass_matrix(q[k]).tobytes()
        assert a[k].tobytes() == robot.forward_dynamics(q[k], qd[k], tau[k], method="cholesky").tobytes()
    for k in (0, 34):
        assert rel(M[k], ref.mass_matrix(q[k])) <= TOL
        assert rel(a[k], ref.forward_dynamics(q[k], qd[k], tau[k], method="cholesky")) <= 1e-9


@pytest.mark.parametrize("n", [56, 57])
def test_articulated_bodies_past_the_lanes_stack_give_each_state_its_bits(n):
    """aba_lanes.aba_lanes_fit: a 56-joint chain's batch of forward dynamics by articulated
    bodies runs in lanes (36 x 56 x 32 doubles of articulated inertias fit 512 KiB of stack),
    a 57-joint one's one state at a time; either way, with a tip wrench per row or none, a
    row is bitwise its single call and agrees with the reference."""
    robot = sd.load_urdf(chain_urdf(n, kinds=(["revolute"] * 6 + ["prismatic"]) * 8 + ["revolute"] * (n - 56)))
    ref = Robot(robot.model, backend="numpy")
    q, qd, _, tau, _ = states(robot, seed=12, batch=35)
    for wrench in (None, np.random.default_rng(13).normal(size=(35, 6)) * 5):
        a = robot.forward_dynamics(q, qd, tau, wrench, method="aba")
        for k in range(35):
            one = None if wrench is None else wrench[k]
            assert a[k].tobytes() == robot.forward_dynamics(q[k], qd[k], tau[k], one, method="aba").tobytes()
        for k in (0, 34):
            one = None if wrench is None else wrench[k]
            assert rel(a[k], ref.forward_dynamics(q[k], qd[k], tau[k], one, method="aba")) <= 1e-9


def test_inputs_of_any_kind(pair):
    _, robot, ref = pair
    q, qd, qdd, tau, _ = states(robot, seed=5)
    expect = ref.inverse_dynamics(q, qd, qdd)
    ro = q.copy()
    ro.setflags(write=False)
    strided = np.repeat(qd, 2)[::2]
    assert not strided.flags.c_contiguous
    assert rel(robot.inverse_dynamics(list(q), tuple(qd), list(qdd)), expect) <= TOL
    qdd32 = qdd.astype(np.float32)                                # -> the general path
    assert rel(robot.inverse_dynamics(ro, strided, qdd32),
               ref.inverse_dynamics(q, qd, qdd32.astype(float))) <= TOL
    assert rel(robot.forward_dynamics(list(q), qd, list(tau)), ref.forward_dynamics(q, qd, tau)) <= 1e-9
    assert robot.inverse_dynamics(q, qd, qdd).shape == (robot.dof,)
    assert robot.inverse_dynamics(q[None], qd, qdd).shape == (1, robot.dof)
    zeros = np.zeros(robot.dof, dtype=int)
    assert rel(robot.gravity_torques(zeros), ref.gravity_torques(zeros.astype(float))) <= TOL


@pytest.mark.parametrize("backend", ["numba", "numpy"])
@pytest.mark.parametrize("batch", [None, 5])
def test_out_receives_the_result(backend, batch):
    robot = Robot(sd.default_robot().model, backend=backend)
    q, qd, qdd, tau, w = states(robot, seed=8, batch=batch)
    shape = q.shape
    calls = {
        "inverse_dynamics": (lambda **o: robot.inverse_dynamics(q, qd, qdd, w, **o), shape),
        "mass_matrix": (lambda **o: robot.mass_matrix(q, **o), shape + (6,)),
        "bias_torques": (lambda **o: robot.bias_torques(q, qd, **o), shape),
        "gravity_torques": (lambda **o: robot.gravity_torques(q, **o), shape),
        "forward_dynamics": (lambda **o: robot.forward_dynamics(q, qd, tau, **o), shape),
        "forward_dynamics qr": (lambda **o: robot.forward_dynamics(q, qd, tau, method="qr", **o),
                                shape),
    }
    for name, (call, shape_out) in calls.items():
        expect = call()
        out = np.full(shape_out, np.nan)
        assert call(out=out) is out, name
        np.testing.assert_array_equal(out, expect, err_msg=name)
        fortran = np.full(shape_out, np.nan, order="F")                # -> the general path
        np.testing.assert_array_equal(call(out=fortran), expect, err_msg=name)
    read_only = np.zeros(shape)
    read_only.setflags(write=False)
    short = shape[:-1] + (5,)
    for bad, why in ((np.zeros(short), f"float64 array of shape {short}"),
                     (np.zeros(shape, dtype=np.float32), f"float32 array of shape {shape}"),
                     (read_only, f"float64 array of shape {shape} that is read-only"),
                     ([0.0] * 6, "list")):
        with pytest.raises(ValueError, match=re.escape(
                f"out must be a writable float64 array of shape {shape} (the result's); "
                f"got a {why}") + "$"):
            robot.inverse_dynamics(q, qd, qdd, out=bad)


def test_an_out_used_before_is_still_checked_for_another_shape_or_once_read_only():
    """An ``out`` that one method accepted is refused by another that needs another shape,
    and a read-only one is refused (the compiled entry points' signatures only take
    writable arrays of their dimensions; everything else goes to the checked path)."""
    robot = sd.default_robot()
    q, qd, qdd, tau, _ = states(robot, seed=9)
    v = np.empty(6)
    robot.inverse_dynamics(q, qd, qdd, out=v)
    with pytest.raises(ValueError, match=r"out must be a writable float64 array of shape \(6, 6\)"):
        robot.mass_matrix(q, out=v)
    M = np.empty((6, 6))
    robot.mass_matrix(q, out=M)
    with pytest.raises(ValueError, match=r"out must be a writable float64 array of shape \(6,\)"):
        robot.gravity_torques(q, out=M)
    frozen = np.empty(6)
    frozen.setflags(write=False)
    with pytest.raises(ValueError, match="read-only"):
        robot.forward_dynamics(q, qd, tau, out=frozen)
    np.testing.assert_array_equal(robot.inverse_dynamics(q, qd, qdd, out=v),
                                  robot.inverse_dynamics(q, qd, qdd))


def test_huge_angles_take_exact_argument_reduction(pair):
    _, robot, ref = pair
    q, qd, qdd, _, _ = states(robot, seed=6)
    q = q + 2 * np.pi * 3e5                                       # |q| > 1e5: libm sin/cos
    assert rel(robot.inverse_dynamics(q, qd, qdd), ref.inverse_dynamics(q, qd, qdd)) <= TOL
    Q = np.vstack([q, q - 2 * np.pi * 3e5])
    assert rel(robot.inverse_dynamics(Q, qd, qdd), ref.inverse_dynamics(Q, qd, qdd)) <= 1e-9
    # a block of lanes mixing huge and ordinary angles: each row as its single call, bitwise
    Q = np.vstack([Q, robot.random_state(1, batch=40)[0]])[np.random.default_rng(2).permutation(42)]
    batch = robot.inverse_dynamics(Q, qd, qdd)
    for k in range(len(Q)):
        np.testing.assert_array_equal(batch[k], robot.inverse_dynamics(Q[k], qd, qdd))


def test_nan_and_inf_raise_naming_argument_and_joint():
    robot = sd.default_robot()
    n = robot.dof
    z = np.zeros(n)
    for bad in (np.nan, np.inf, -np.inf):
        for arg in range(3):
            x = [z.copy(), z.copy(), z.copy()]
            x[arg][2] = bad
            name = ("q", "qd", "qdd")[arg]
            with pytest.raises(ValueError, match=rf"^{name} has a NaN or Inf entry \(joint 'elbow_joint'\)"):
                robot.inverse_dynamics(*x)
            X = [np.zeros((40, n)) for _ in range(3)]
            X[arg][35, 4] = bad
            with pytest.raises(ValueError, match=rf"^{name} has a NaN or Inf entry \(joint 'wrist_2_joint'\)"):
                robot.inverse_dynamics(*X)
        t = z.copy()
        t[0] = bad
        with pytest.raises(ValueError, match=r"^tau has a NaN or Inf entry \(joint 'shoulder_pan_joint'\)"):
            robot.forward_dynamics(z, z, t)
        with pytest.raises(ValueError, match=r"^q has a NaN"):
            robot.mass_matrix(np.where(np.arange(n) == 1, bad, 0.0))
        with pytest.raises(ValueError, match=r"^qd has a NaN"):
            robot.bias_torques(z, t)
        with pytest.raises(ValueError, match=r"^wrench has a NaN or Inf entry"):
            robot.inverse_dynamics(z, z, z, wrench=[0, 0, bad, 0, 0, 0])
        with pytest.raises(ValueError, match=r"^wrench has a NaN or Inf entry"):
            robot.forward_dynamics(np.zeros((3, n)), z, z, wrench=[0, 0, bad, 0, 0, 0])


def test_wrong_shapes_raise_like_the_reference():
    robot = sd.default_robot()
    z = np.zeros(6)
    with pytest.raises(ValueError, match=r"^q has shape \(5,\); expected \(6,\) or \(N, 6\)"):
        robot.inverse_dynamics(np.zeros(5), z, z)
    with pytest.raises(ValueError, match=r"^qdd has shape \(7,\)"):
        robot.inverse_dynamics(z, z, np.zeros(7))
    with pytest.raises(ValueError, match=r"^batch sizes differ"):
        robot.inverse_dynamics(np.zeros((3, 6)), np.zeros((4, 6)), z)
    with pytest.raises(ValueError, match=r"^wrench has shape \(5,\)"):
        robot.inverse_dynamics(z, z, z, wrench=np.zeros(5))
    with pytest.raises(ValueError, match="forward-dynamics method 'lu' unknown"):
        robot.forward_dynamics(z, z, z, method="lu")


def test_backends_and_the_environment_switch(monkeypatch):
    robot = sd.default_robot()
    q, qd, qdd, _, _ = states(robot, seed=7)
    ref = Robot(robot.model, backend="numpy")
    np.testing.assert_array_equal(ref.inverse_dynamics(q, qd, qdd),
                                  rnea.inverse_dynamics(robot.model, q, qd, qdd))
    np.testing.assert_array_equal(ref.forward_dynamics(q, qd, qdd, method="cholesky"),
                                  forward.forward_dynamics(robot.model, q, qd, qdd))
    monkeypatch.setenv("SERIAL_DYNAMICS_BACKEND", "numpy")
    assert Robot(robot.model).backend == "numpy"
    with pytest.raises(ValueError, match="backend 'cuda' unknown"):
        Robot(robot.model, backend="cuda")


def test_warmup_loads_every_kernel_of_the_robot_methods():
    robot = sd.default_robot().warmup(batch=True)
    # the kernels of the dynamics methods warmup() calls; the regressor, derivatives and
    # energy kernels are loaded on their first use (a node does not need them to start)
    # (those of a floating base's virtual chain, floating_*, its own warmup loads)
    dynamics = {name for name, (func, *_) in core.ENTRY_POINTS.items()
                if func.__module__.rsplit(".", 1)[1] in ("rnea", "rnea_lanes", "crba", "crba_lanes",
                                                       "forward") and not name.startswith("floating_")}
    assert set(ROBOT_KERNELS) == dynamics
    assert set(PLANAR_KERNELS) == {k for k in core.ENTRY_POINTS if k.startswith("planar")}
    for name in ROBOT_KERNELS:
        assert name in vars(core.K), name             # compiled (or loaded) entry point
    assert robot.backend == "numba" and not robot.is_planar
    planar = sd.builtin_robot("planar_3r").warmup(batch=True)   # a planar chain: its kernels too
    assert planar.is_planar
    for name in PLANAR_KERNELS:
        assert name in vars(core.K), name


def test_sincos_to_one_ulp():
    from numba import njit

    @njit
    def both(x, s, c):
        for i in range(x.shape[0]):
            s[i], c[i] = sincos(x[i])

    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(-4, 4, 20000), rng.uniform(-9e4, 9e4, 20000),
                        np.arange(-64, 65) * (np.pi / 4), [0.0, -0.0, 1e-300, 5e-8]])
    s, c = np.empty_like(x), np.empty_like(x)
    both(x, s, c)
    assert np.max(np.abs(s - np.sin(x))) <= 2.3e-16 and np.max(np.abs(c - np.cos(x))) <= 2.3e-16
    assert s[-2] == 1e-300 and c[-2] == 1.0


def test_fixed_step_loop_matches_a_python_loop():
    robot = sd.load_urdf(chain_urdf(5, damping=[0.1, 0.2, 0.0, 0.3, 0.05]))
    ref = Robot(robot.model, backend="numpy")
    n, dt, steps = robot.dof, 1e-3, 50
    q0, qd0 = robot.random_state(0)
    rng = np.random.default_rng(1)
    tau = rng.normal(size=(steps, n))
    w = rng.normal(size=6)
    beta = robot.model.damping
    for flags, method in ((0, "cholesky"), (F.ABA, "aba")):      # explicit damping
        Q, QD = _loop()(robot._P, q0, qd0, tau, dt, steps, beta, w[None], flags)
        q, qd = q0.copy(), qd0.copy()
        for k in range(steps):
            qdd = ref.forward_dynamics(q, qd, tau[k] - beta * qd, w, method=method)
            qd = qd + dt * qdd
            q = q + dt * qd
        assert Q.shape == QD.shape == (steps + 1, n)
        assert rel(Q[-1], q) <= TOL and rel(QD[-1], qd) <= 1e-11
    # implicit damping: (M + dt diag(beta)) qdd = tau - beta qd - b
    for flags in (F.DAMPING, F.DAMPING | F.ABA):
        Q, QD = _loop()(robot._P, q0, qd0, tau, dt, steps, beta * 50, w[None], flags)
        q, qd = q0.copy(), qd0.copy()
        for k in range(steps):
            M = ref.mass_matrix(q) + dt * np.diag(beta * 50)
            qdd = np.linalg.solve(M, tau[k] - beta * 50 * qd - ref.bias_torques(q, qd, w))
            qd = qd + dt * qdd
            q = q + dt * qd
        assert rel(Q[-1], q) <= TOL and rel(QD[-1], qd) <= 1e-11
    # a diverging run stops, and the rows from there on are NaN
    Q, QD = _loop()(robot._P, q0, qd0, np.full((1, n), 1e200), dt, steps, beta, np.zeros((0, 6)), 0)
    assert np.all(np.isnan(Q[2:])) and np.all(np.isfinite(Q[0]))


def test_simulate_fixed_step_wrapper():
    robot = sd.default_robot()
    ref = Robot(robot.model, backend="numpy")          # the wrapper packs its model on the fly
    n = robot.dof
    q0 = np.array([0.1, -1.2, 1.0, -0.5, 0.3, 0.0])
    tau = ref.gravity_torques(q0)                      # the reference's gravity torques
    q, qd = simulate_fixed_step(robot, q0, np.zeros(n), tau, 1e-3, 200)
    assert q.shape == (201, n) and np.max(np.abs(q - q0)) < 1e-9      # hold the arm
    # both routes of the compiled loop against a Python loop on the NumPy reference
    # (implicit damping, the default: (M + dt diag(beta)) qdd = tau - beta qd - b)
    beta, dt, steps = np.full(n, 0.7), 1e-3, 50
    a, ad = simulate_fixed_step(robot, q0, np.ones(n), list(tau * 0.5), dt, steps, beta)
    b, bd = simulate_fixed_step(ref, q0, np.ones(n), np.tile(tau * 0.5, (steps, 1)), dt, steps,
                                beta, wrench=np.zeros(6), method="aba")
    Q, QD = [q0], [np.ones(n)]
    for _ in range(steps):
        x, v = Q[-1], QD[-1]
        A = ref.mass_matrix(x) + dt * np.diag(beta)
        v = v + dt * np.linalg.solve(A, 0.5 * tau - beta * v - ref.bias_torques(x, v))
        Q.append(x + dt * v)
        QD.append(v)
    Q, QD = np.array(Q), np.array(QD)
    assert np.max(np.abs(Q[-1] - q0)) > 0.05                          # it moved
    for x, v in ((a, ad), (b, bd)):
        assert rel(x, Q) <= TOL and rel(v, QD) <= 1e-11
    with pytest.raises(ValueError, match="tau has shape"):
        simulate_fixed_step(robot, q0, q0, np.zeros((3, n)), 1e-3, 50)
    with pytest.raises(ValueError, match="q0 has a NaN"):
        simulate_fixed_step(robot, q0 * np.nan, q0, tau, 1e-3, 50)
    with pytest.raises(ValueError, match="method 'rk4' unknown"):
        simulate_fixed_step(robot, q0, q0, tau, 1e-3, 50, method="rk4")


def test_wrench_calls_from_two_threads_do_not_mix():
    import sys
    import threading
    robot = sd.default_robot()
    q, qd, qdd, _, _ = states(robot, seed=8)
    wrenches = [np.r_[50.0, 0, 0, 0, 0, 0], np.r_[0, 0, -80.0, 0, 5.0, 0]]
    expect = [robot.inverse_dynamics(q, qd, qdd, w).copy() for w in wrenches]
    bad = []

    def worker(k):
        for _ in range(3000):
            if not np.array_equal(robot.inverse_dynamics(q, qd, qdd, wrenches[k]), expect[k]):
                bad.append(k)
            robot.inverse_dynamics(q, qd, qdd)                 # no wrench in between

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=worker, args=(k,)) for k in (0, 1)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    assert not bad


def test_other_argument_types_get_a_status_not_an_exception():
    """A single-state entry point has one exact signature; any other argument types (a
    list, a batch, another dtype, a read-only or strided array) make it return
    OTHER_TYPES -- the Robot's general path then takes over -- rather than compile a new
    version or raise (core.dispatch._Kernels)."""
    from serial_dynamics.core import K, OTHER_TYPES
    robot = sd.default_robot()
    q, qd, qdd, tau, _ = states(robot, seed=10)
    P, o, M = robot._P, np.empty(6), np.empty((6, 6))
    read_only = q.copy()
    read_only.setflags(write=False)
    for bad in ([0.0] * 6, np.zeros((2, 6)), np.arange(6), np.zeros(6, np.float32), read_only,
                np.zeros(12)[::2]):
        assert K.rnea(P, bad, qd, qdd, F.QD | F.QDD, o) == OTHER_TYPES
        assert K.rnea_wrench(P, q, qd, qdd, bad, F.QD | F.QDD, o) == OTHER_TYPES
        assert K.crba(P, bad, M) == OTHER_TYPES
        assert K.fd(P, q, bad, tau, np.zeros(6), F.QD, o) == OTHER_TYPES
    assert K.rnea(P, q, qd, qdd, F.QD | F.QDD, o) == 0                    # the exact types
    np.testing.assert_array_equal(o, robot.inverse_dynamics(q, qd, qdd))
    # and each such input still gets the right answer through the Robot (general path)
    np.testing.assert_array_equal(robot.inverse_dynamics(list(q), read_only, np.asarray(qdd)),
                                  robot.inverse_dynamics(q, q, qdd))


@pytest.mark.parametrize("rel, tips", [("ur_description/urdf/ur5_robot.urdf", ["tool0"]),
                                       ("solo_description/robots/solo12.urdf", None)])
def test_floating_inverse_dynamics_reads_the_gravity_gw_would_give(rel, tips):
    """``floating_rnea`` (no gw argument: the world's gravity from the packed model) is
    ``floating_rnea_wrench`` with gw = [0, g] bit for bit, on a chain and a tree (the table
    each robot holds), with a tilted gravity so that each component is read from P; a bad
    length is refused as by the others."""
    from pin_reference import erd
    g = np.array([0.8, -1.3, -9.7])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robot = sd.load_urdf(erd(rel), tip_links=tips, floating_base=True, gravity=g)
    rng = np.random.default_rng(3)
    gw = np.concatenate([np.zeros(6), g])
    k, P = robot._k, robot._chain
    for _ in range(3):
        q, v = robot.random_state(rng, speed=2.0)
        a = rng.normal(size=robot.nv)
        for flags in (0, F.QD, F.QDD, F.QD | F.QDD):
            x, y = np.empty(robot.nv), np.empty(robot.nv)
            assert k.floating_rnea(P, q, v, a, flags, x) == core.OK
            assert k.floating_rnea_wrench(P, q, v, a, gw, flags, y) == core.OK
            assert np.array_equal(x, y)
            if flags == 0:                        # gravity alone: the weight on the base
                assert np.linalg.norm(x[:3]) > 1.0
        assert np.array_equal(robot.inverse_dynamics(q, v, a), x)    # the facade's route
    assert k.floating_rnea(P, q[:-1], v, a, 0, x) == 2      # BAD_LENGTH
