"""The torque regressor Y(q, qd, qdd) against Pinocchio's, in one run.

    python bench/bench_regressor.py            # writes section "regressor" of BENCHMARKS.md
    python bench/bench_regressor.py --quick    # fewer rounds

Robots: the built-in UR5e and the Franka Panda (example-robot-data, base to panda_link8).
Timed, same states:

    single state   robot.regressor(q, qd, qdd)               (the compiled single-state path)
                   pin.computeJointTorqueRegressor(model, data, q, v, a)
    N states       robot.regressor(Q, QD, QDD), one call     (the batch kernel; N = 1, 100, 10,000)
                   pin.computeJointTorqueRegressor in a Python loop over the N states
    reference      (n + 1) x robot.inverse_dynamics(q, qd, qdd): what a regressor built from
                   n + 1 inverse-dynamics calls would cost at least

Every answer is checked against Pinocchio's before it is timed (the agreement column:
max |Y - Y_pin| / max |Y_pin| over the states). Timing: rounds of ``number`` calls, the
two sides interleaved and alternating in order; the median over rounds of the mean time
per state; wall clock. A batch of 10,000 states is split over the cores by
``robot.regressor``; the row "one thread" calls the batch kernel directly, unsplit, as
Pinocchio's loop runs. ratio = ours / pin.
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import pinocchio as pin                                             # noqa: E402

import serial_dynamics as sd                                        # noqa: E402
from serial_dynamics.core import K                                  # noqa: E402
from serial_dynamics.robot.regressor import _info                         # noqa: E402
from _report import stamp, write_section                           # noqa: E402
from bench_planar import interleaved                                # noqa: E402
from bench_speed import erd_path                                    # noqa: E402


def robots():
    """name: (robot, path of its URDF for Pinocchio)."""
    out = {"UR5e": (sd.default_robot(), sd.builtin_path("ur5e"))}
    panda = erd_path("panda_description/urdf/panda.urdf")
    if os.path.isfile(panda):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sd.HeldJointsWarning)
            out["Panda"] = (sd.load_urdf(panda, None, "panda_link8"), panda)
    return out


class Pin:
    """Pinocchio's model of the chain (held joints locked) and its regressor on our joints."""

    def __init__(self, robot, path):
        full = pin.buildModelFromUrdf(path)
        lock = [full.getJointId(n) for n in full.names[1:] if n not in set(robot.joint_names)]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()
        jid = [self.model.getJointId(n) for n in robot.joint_names]
        assert jid == list(range(1, robot.dof + 1)) and self.model.nq == self.model.nv == robot.dof
        self.cols = np.arange(10 * robot.dof)

    def regressor(self, q, qd, qdd):
        return pin.computeJointTorqueRegressor(self.model, self.data, q, qd, qdd)


def us(t):
    return f"{t * 1e6:.2f}"


def run(quick=False):
    rounds = 5 if quick else 15
    lines = []
    for name, (robot, path) in robots().items():
        ref = Pin(robot, path)
        n = robot.dof
        rng = np.random.default_rng(0)
        N_max = 10_000
        Q, QD = robot.random_state(rng, batch=N_max, speed=2.0)
        QDD = rng.normal(size=Q.shape) * 3
        # agreement, on every state of the largest batch
        Y = robot.regressor(Q, QD, QDD)
        Yp = np.array([ref.regressor(*x) for x in zip(Q, QD, QDD)])
        err = np.max(np.abs(Y - Yp)) / np.max(np.abs(Yp))
        assert err <= 1e-9, f"{name}: regressor differs from Pinocchio's by {err:.2e}"
        q, qd, qdd = Q[0].copy(), QD[0].copy(), QDD[0].copy()
        single = interleaved(lambda: robot.regressor(q, qd, qdd),
                             lambda: ref.regressor(q, qd, qdd), 2000 if not quick else 500, rounds)
        t_id = interleaved(lambda: robot.inverse_dynamics(q, qd, qdd), lambda: None,
                           5000 if not quick else 1000, rounds)[0]
        rows = [("1 (single-state path)", single)]
        for N in (1, 100, N_max):
            Qn, QDn, QDDn = Q[:N].copy(), QD[:N].copy(), QDD[:N].copy()
            states = list(zip(Qn, QDn, QDDn))

            def pin_loop():
                for x in states:
                    ref.regressor(*x)
            number = max(1, 2000 // N) if not quick else max(1, 300 // N)
            t_ours, t_pin = interleaved(lambda: robot.regressor(Qn, QDn, QDDn), pin_loop,
                                        number, rounds if N < N_max else max(3, rounds // 3))
            rows.append((f"{N:,} (batch call)", (t_ours / N, t_pin / N)))
        # the largest batch on one thread: the batch kernel called directly, no split
        L = _info(robot)[0]
        Yk = np.empty((N_max, n, 10 * n))
        t_one = interleaved(lambda: K.regressor_batch(L, Q, QD, QDD, 0, Yk), lambda: None,
                            1, max(3, rounds // 3))[0]
        assert np.array_equal(Yk, Y)
        rows.append((f"{N_max:,} (batch kernel, one thread)", (t_one / N_max, rows[-1][1][1])))
        lines.append(f"**{name}** (n = {n}, p = {10 * n} columns; agreement with Pinocchio over "
                     f"{N_max:,} states: {err:.1e}; (n + 1) single inverse-dynamics calls: "
                     f"{us((n + 1) * t_id)} us, so one single-state regressor costs "
                     f"{single[0] / t_id:.1f} inverse-dynamics calls)\n")
        lines.append("| states per call | ours, us/state | Pinocchio, us/state | ratio ours/pin |")
        lines.append("|---|---:|---:|---:|")
        for label, (a, b) in rows:
            lines.append(f"| {label} | {us(a)} | {us(b)} | {a / b:.2f} |")
        lines.append("")
    body = ("## Torque regressor\n\n" + stamp() + "\n"
            "`python bench/bench_regressor.py`. `robot.regressor(q, qd, qdd)` (compiled: "
            "`core/regressor.py`) against `pinocchio.computeJointTorqueRegressor` (Pinocchio "
            f"{pin.__version__}, called from Python, in a Python loop for a batch) on the "
            "same states; Pinocchio's columns are the same parameters (`toDynamicParameters`). "
            "Median over rounds of the mean time per state; a batch of 10,000 states is "
            "split over the cores by `robot.regressor`, Pinocchio's loop runs on one (the "
            "row *one thread*: our batch kernel unsplit).\n\n"
            + "\n".join(lines))
    print(body)
    write_section("regressor", body)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    run(ap.parse_args().quick)
