"""A Robot may be called from several threads at once, and gives the serial answers.

Threads share ONE Robot and call it concurrently, thousands of times each, on different
seeded states, mixing single-state inverse dynamics with and without a tip wrench (the
old kernels kept a wrench in scratch memory shared by every call on a robot), bias and
gravity torques, the mass matrix, forward dynamics by both methods, and batch calls. Every
answer is compared bitwise with the answer of the same call made serially beforehand on
the same robot. A ``threading.Barrier`` starts the threads together, and the interpreter's
switch interval is made tiny so that the threads really interleave between (and, where a
call releases the GIL, within) calls.

``test_first_calls_concurrently``: the same on a Robot that has never been called, so
that the threads race through its first calls (which compile or load the kernels).
"""
import os
import sys
import sysconfig
import threading
import time
import warnings

import numpy as np
import pytest

import serial_dynamics as sd

ERD_ROOT = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share",
                        "example-robot-data", "robots")
XARM7 = os.path.join(ERD_ROOT, "xarm_description", "urdf", "xarm7.urdf")

CALLS_PER_THREAD = 20000
N_STATES = 64           # single states per thread
N_BATCH = 37            # a batch: one block of the batch kernels and a short tail


def _robot(name):
    if name == "ur5e":
        return sd.default_robot()
    if not os.path.isfile(XARM7):
        pytest.skip(f"example-robot-data is not installed (no {XARM7})")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.load_urdf(XARM7, "link_base", "link7")


def _ops(robot, seed):
    """[(label, thunk)]: the calls one thread makes, on its own seeded states."""
    rng = np.random.default_rng(seed)
    n = robot.dof
    q, qd = robot.random_state(rng, batch=N_STATES, speed=2.0)
    qdd = rng.uniform(-5, 5, (N_STATES, n))
    tau = rng.uniform(-20, 20, (N_STATES, n))
    w = rng.uniform(-10, 10, (N_STATES, 6))
    Q, QD = robot.random_state(rng, batch=N_BATCH, speed=2.0)
    QDD, TAU = rng.uniform(-5, 5, (N_BATCH, n)), rng.uniform(-20, 20, (N_BATCH, n))
    W = rng.uniform(-10, 10, (N_BATCH, 6))
    r = robot
    ops = []
    for k in range(N_STATES):
        a, b, c, t, f = q[k], qd[k], qdd[k], tau[k], w[k]
        ops += [
            (f"inverse_dynamics(state {k})", lambda a=a, b=b, c=c: r.inverse_dynamics(a, b, c)),
            (f"inverse_dynamics(state {k}, wrench)",
             lambda a=a, b=b, c=c, f=f: r.inverse_dynamics(a, b, c, wrench=f)),
            (f"bias_torques(state {k})", lambda a=a, b=b: r.bias_torques(a, b)),
            (f"gravity_torques(state {k})", lambda a=a: r.gravity_torques(a)),
            (f"mass_matrix(state {k})", lambda a=a: r.mass_matrix(a)),
            (f"forward_dynamics(state {k}, cholesky)",
             lambda a=a, b=b, t=t: r.forward_dynamics(a, b, t, method="cholesky")),
            (f"forward_dynamics(state {k}, aba, wrench)",
             lambda a=a, b=b, t=t, f=f: r.forward_dynamics(a, b, t, wrench=f, method="aba")),
        ]
    ops += [
        ("inverse_dynamics(batch)", lambda: r.inverse_dynamics(Q, QD, QDD)),
        ("inverse_dynamics(batch, wrenches)", lambda: r.inverse_dynamics(Q, QD, QDD, wrench=W)),
        ("inverse_dynamics(batch, one wrench)", lambda: r.inverse_dynamics(Q, QD, QDD, wrench=W[0])),
        ("mass_matrix(batch)", lambda: r.mass_matrix(Q)),
        ("forward_dynamics(batch, aba)", lambda: r.forward_dynamics(Q, QD, TAU, method="aba")),
        ("forward_dynamics(batch, cholesky, wrenches)",
         lambda: r.forward_dynamics(Q, QD, TAU, wrench=W, method="cholesky")),
    ]
    return ops


def _schedule(ops, seed):
    """CALLS_PER_THREAD indices into ops in a seeded random order (singles mostly)."""
    rng = np.random.default_rng(seed)
    return rng.integers(0, len(ops), CALLS_PER_THREAD)


def _run(robot_for_threads, serial_robot, n_threads):
    per_thread = [_ops(robot_for_threads, 100 + i) for i in range(n_threads)]
    schedules = [_schedule(ops, 200 + i) for i, ops in enumerate(per_thread)]
    # the serial answers, beforehand, on a robot with the same model
    serial = [[f() for _, f in _ops(serial_robot, 100 + i)] for i in range(n_threads)]
    serial = [[np.array(x, copy=True) for x in answers] for answers in serial]
    barrier = threading.Barrier(n_threads)
    mismatches, errors, counts = [], [], [0] * n_threads
    trace = []          # thread ids in call order (list.append is atomic)

    def worker(i):
        ops, expected = per_thread[i], serial[i]
        try:
            barrier.wait(timeout=60)
            for j in schedules[i]:
                label, f = ops[j]
                got = f()
                ref = expected[j]
                if got.shape != ref.shape or got.tobytes() != ref.tobytes():
                    d = np.max(np.abs(got - ref)) if got.shape == ref.shape else np.nan
                    mismatches.append(f"thread {i}: {label}: differs from the serial answer by "
                                      f"up to {d:.3g} (shape {got.shape} vs {ref.shape})")
                counts[i] += 1
                trace.append(i)
        except Exception as exc:                    # noqa: BLE001 - reported below
            errors.append(f"thread {i}: {type(exc).__name__}: {exc}")
            barrier.abort()

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=worker, args=(i,)) for i in range(n_threads)]
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=120)
        elapsed = time.perf_counter() - t0
    finally:
        sys.setswitchinterval(old)
    assert not any(t.is_alive() for t in threads), "a thread did not finish within 120 s"
    assert not errors, "calls raised in threads:\n  " + "\n  ".join(errors)
    assert not mismatches, (f"{len(mismatches)} of {sum(counts)} concurrent answers differ from "
                            "the serial ones:\n  " + "\n  ".join(mismatches[:30]))
    assert counts == [CALLS_PER_THREAD] * n_threads, counts
    # the threads did run at the same time: consecutive calls came from different threads
    switches = int(np.count_nonzero(np.diff(trace)))
    print(f"{n_threads} threads x {CALLS_PER_THREAD} calls in {elapsed:.2f} s, "
          f"{switches} switches between threads")
    return switches


def _interleaved(robot_for_threads, serial_robot, n_threads, rounds=10):
    """_run until the threads have interleaved at least 100 times in all: on a loaded
    machine the OS may run them one after the other for a time slice (a few ms), and each
    round then checks fewer concurrent calls."""
    switches = 0
    for _ in range(rounds):
        switches += _run(robot_for_threads, serial_robot, n_threads)
        if switches >= 100:
            return
    pytest.fail(f"the threads hardly interleaved ({switches} switches in {rounds} rounds): "
                "not a test")


@pytest.mark.parametrize("robot_name", ["ur5e", "xarm7"])
@pytest.mark.parametrize("n_threads", [2, 4])
def test_threads_share_a_robot(robot_name, n_threads):
    robot = _robot(robot_name)
    _interleaved(robot, robot, n_threads)


def test_first_calls_concurrently():
    serial_robot = _robot("xarm7")
    fresh = _robot("xarm7")           # never called before the threads start
    _interleaved(fresh, serial_robot, 4)
