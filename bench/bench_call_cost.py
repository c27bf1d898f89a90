"""Where a single call's time goes: numba's dispatcher per array argument, the entry point
called past it (core/_fastcall.c calling its numba.cfunc wrapper, core/cabi.py), the returned array and the facade, beside Pinocchio's
call of the same quantity (one process, interleaved rounds, the minimum of each).

Why it is measured: a single call of the mass matrix or of inverse dynamics takes 0.6-1 µs,
and most of it is not arithmetic. These rows say how much each part takes, so that a design
of the facade (issue 25: one ``Robot`` with one kernel signature for every kind of robot)
can be priced before it is built: an array argument more on every entry point costs what
the first table's increments say, on every single call made through numba's dispatcher.
The single-state entry points are called past the dispatcher (core/cabi.py); the rows
"through numba's dispatcher" (the njit kernel called from Python) say what that saves.

    python bench/bench_call_cost.py            # writes the "call_cost" section of bench/BENCHMARKS.md
    python bench/bench_call_cost.py --no-write
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_speed import erd_path, pin                                   # noqa: E402
from _report import stamp, write_section                                # noqa: E402

import serial_dynamics as sd                                            # noqa: E402
from serial_dynamics.core import K, cabi                                # noqa: E402

UR5 = "ur_description/urdf/ur5_robot.urdf"


# the smallest compiled entry points: k float64 arrays in, an int64 out (what every entry
# point of core/ returns), nothing computed; one explicit signature each, as core's
@njit(cache=True)
def _args0():
    return 0


@njit("i8(f8[:, ::1])", cache=True)
def _args1(a):
    return 0


@njit("i8(f8[:, ::1], f8[::1])", cache=True)
def _args2(a, b):
    return 0


@njit("i8(f8[:, ::1], f8[::1], f8[:, ::1])", cache=True)
def _args3(a, b, c):
    return 0


@njit("i8(f8[:, ::1], f8[::1], f8[::1], f8[::1], f8[:, ::1])", cache=True)
def _args5(a, b, c, d, e):
    return 0


@njit("i8(f8[:, ::1], f8[::1], f8[::1], f8[::1], f8[::1], f8[::1], f8[:, ::1])",
      cache=True)
def _args7(a, b, c, d, e, f, g):
    return 0


@njit("i8(f8[:, ::1], f8[::1], f8[::1], f8[::1], i8, f8[::1])", cache=True)
def _args5_int(a, b, c, d, k, e):      # floating_rnea's arguments: 5 arrays and the flags
    return 0


def best(calls, number, rounds):
    """{label: seconds per call}: each callable timed ``number`` times a round, the rounds
    interleaved, the minimum kept."""
    out = {label: float("inf") for label in calls}
    clock = time.perf_counter
    for _ in range(rounds):
        for label, f in calls.items():
            t0 = clock()
            for _ in range(number):
                f()
            out[label] = min(out[label], (clock() - t0) / number)
    return out


def dispatch_rows(number, rounds):
    """{k arrays: (through numba's dispatcher, past it), "nothing": the empty loop}."""
    P, q, o = np.zeros((7, 40)), np.zeros(6), np.zeros((6, 6))
    args = {1: (P,), 2: (P, q), 3: (P, q, o), 5: (P, q, q, q, o), 7: (P, q, q, q, q, q, o)}
    kernels = {1: _args1, 2: _args2, 3: _args3, 5: _args5, 7: _args7}
    calls = {(0, "numba"): lambda: _args0(), "nothing": lambda: None}
    for k, f in kernels.items():
        # not cached: a wrapper's cache entry is keyed on cabi.py, not on this file
        fast = cabi.entry(f"args{k}", f.py_func, f.nopython_signatures[0], cache=False)
        assert isinstance(fast, cabi._fastcall.Entry)
        calls[k, "numba"] = lambda f=f, a=args[k]: f(*a)
        calls[k, "past"] = lambda f=fast, a=args[k]: f(*a)
    _args0()
    t = best(calls, number, rounds)
    rows = {k: (t[k, "numba"], t.get((k, "past"), float("nan"))) for k in [0, *kernels]}
    rows["nothing"] = t["nothing"]
    return rows


def load(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd_path(UR5), tip_links=["tool0"], **kw)


def mass_matrix_rows(number, rounds):
    """The UR5 on a fixed base: M(q) through the facade, with ``out=``, the kernel alone (the
    dispatcher included), and the parts."""
    robot = load()
    m = pin.buildModelFromUrdf(erd_path(UR5))
    d = m.createData()
    q = np.random.default_rng(0).uniform(-1, 1, robot.dof)
    Mp = pin.crba(m, d, q)
    np.testing.assert_allclose(robot.mass_matrix(q), np.triu(Mp) + np.triu(Mp, 1).T,
                               rtol=1e-10, atol=1e-12)
    P, o, shape, empty, crba = robot._P, np.empty((robot.dof, robot.dof)), (6, 6), np.empty, K.crba
    calls = {"pinocchio.crba(model, data, q)": lambda: pin.crba(m, d, q),
             "robot.mass_matrix(q)": lambda: robot.mass_matrix(q),
             "robot.mass_matrix(q, out=M)": lambda: robot.mass_matrix(q, out=o),
             "K.crba(P, q, M): the entry point": lambda: crba(P, q, o),
             "K.crba.kernel(P, q, M): through numba's dispatcher":
                 lambda: crba.kernel(P, q, o),
             "K.crba(P, q, np.empty((6, 6)))": lambda: crba(P, q, empty(shape)),
             "an empty entry point of 3 arrays": lambda: _args3(P, q, o),
             "np.empty((6, 6))": lambda: empty(shape), "nothing": lambda: None}
    return best(calls, number, rounds)


def floating_rows(number, rounds):
    """The UR5 on a free-floating base: inverse dynamics (the entry point takes 6 arguments:
    the instantaneous chain with the world's gravity, q, v, a, the flags, tau)."""
    robot = load(floating_base=True)
    m = pin.buildModelFromUrdf(erd_path(UR5), pin.JointModelFreeFlyer())
    m.gravity.linear[:] = robot.gravity
    d = m.createData()
    rng = np.random.default_rng(0)
    quat = rng.normal(size=4)
    q = np.concatenate([[0.1, -0.2, 0.3], quat / np.linalg.norm(quat), rng.uniform(-1, 1, 6)])
    v, a = rng.uniform(-1, 1, (2, robot.nv))
    np.testing.assert_allclose(robot.inverse_dynamics(q, v, a), pin.rnea(m, d, q, v, a),
                               rtol=1e-9, atol=1e-9)
    o, chain, rnea = np.empty(robot.nv), robot._chain, K.floating_rnea
    P = np.zeros((7, 40))
    calls = {"pinocchio.rnea(model, data, q, v, a)": lambda: pin.rnea(m, d, q, v, a),
             "robot.inverse_dynamics(q, v, a)": lambda: robot.inverse_dynamics(q, v, a),
             "robot.inverse_dynamics(q, v, a, out=tau)":
                 lambda: robot.inverse_dynamics(q, v, a, out=o),
             "K.floating_rnea(chain, q, v, a, flags, tau): the entry point":
                 lambda: rnea(chain, q, v, a, 3, o),
             "K.floating_rnea.kernel(...): through numba's dispatcher":
                 lambda: rnea.kernel(chain, q, v, a, 3, o),
             "an empty entry point of 5 arrays and an int": lambda: _args5_int(P, q, v, a, 3, o),
             "nothing": lambda: None}
    return best(calls, number, rounds)


def table(rows, base):
    lines = ["| call | ns a call | less the empty loop |", "|---|---|---|"]
    for label, t in rows.items():
        if label != "nothing":
            lines.append(f"| {label} | {t * 1e9:.0f} | {(t - base) * 1e9:.0f} |")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-write", action="store_true", help="print, do not write BENCHMARKS.md")
    ap.add_argument("--rounds", type=int, default=30)
    args = ap.parse_args()
    number, rounds = 20_000, args.rounds
    disp = dispatch_rows(number, rounds)
    mm = mass_matrix_rows(number, rounds)
    fl = floating_rows(number, rounds)
    nothing = disp.pop("nothing")
    lines = ["## Where a single call's time goes (`bench/bench_call_cost.py`)", "", stamp(),
             "One process, one core as the scheduler gives it; each call timed 20,000 times "
             f"a round, {rounds} interleaved rounds, the minimum. \"Less the empty loop\" "
             "takes off the time of calling a Python function that does nothing.", "",
             "### An entry point that computes nothing, by its number of array arguments: "
             "through numba's dispatcher, and past it (core/_fastcall.c)", "",
             "ns a call, less the empty loop; in brackets, more than the row above.", "",
             "| arrays | numba's dispatcher | past it (`_fastcall.Entry`) |",
             "|---|---|---|"]
    prev = None
    for k, ts in disp.items():
        cells = [f"{(t - nothing) * 1e9:.0f}" + ("" if prev is None or t != t or p != p else
                                                 f" (+{(t - p) * 1e9:.0f})")
                 for t, p in zip(ts, prev or ts)]
        lines.append(f"| {k} | " + " | ".join(c if c != "nan" else "" for c in cells) + " |")
        prev = ts
    lines += ["", "### The UR5's mass matrix, fixed base", ""]
    lines += table(mm, mm["nothing"])
    lines += ["", "### The UR5's inverse dynamics, floating base", ""]
    lines += table(fl, fl["nothing"])
    lines += ["", "Read (computed from the rows above):", ""]
    for what, rows, plain, out, entry, disp_row, empty in [
            ("the UR5's mass matrix", mm, "robot.mass_matrix(q)", "robot.mass_matrix(q, out=M)",
             "K.crba(P, q, M): the entry point",
             "K.crba.kernel(P, q, M): through numba's dispatcher",
             "an empty entry point of 3 arrays"),
            ("the floating UR5's inverse dynamics", fl, "robot.inverse_dynamics(q, v, a)",
             "robot.inverse_dynamics(q, v, a, out=tau)",
             "K.floating_rnea(chain, q, v, a, flags, tau): the entry point",
             "K.floating_rnea.kernel(...): through numba's dispatcher",
             "an empty entry point of 5 arrays and an int")]:
        peer = next(t for k, t in rows.items() if k.startswith("pinocchio"))
        part = {"the entry point past the dispatcher (checks, call, arithmetic)":
                    rows[entry] - rows["nothing"],
                "the facade (checks, lookups, the call)": rows[out] - rows[entry],
                "the returned array (allocated, freed)": rows[plain] - rows[out]}
        lines.append(f"- {what}: {(rows[plain] - rows['nothing']) * 1e9:.0f} ns = "
                     + " + ".join(f"{t * 1e9:.0f} ({k})" for k, t in part.items())
                     + f"; Pinocchio's call {(peer - rows['nothing']) * 1e9:.0f} ns, ratio "
                     f"{(rows[plain] - rows['nothing']) / (peer - rows['nothing']):.2f} "
                     f"({(rows[out] - rows['nothing']) / (peer - rows['nothing']):.2f} with out=). "
                     f"Through numba's dispatcher the entry point takes "
                     f"{(rows[disp_row] - rows['nothing']) * 1e9:.0f} ns, "
                     f"{(rows[disp_row] - rows[entry]) * 1e9:.0f} more; its arguments alone "
                     f"{(rows[empty] - rows['nothing']) * 1e9:.0f} ns in an empty entry point.")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        write_section("call_cost", text)


if __name__ == "__main__":
    main()
