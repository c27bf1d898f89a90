"""Speed and accuracy of the dynamics derivatives, side by side with Pinocchio's
computeRNEADerivatives and computeABADerivatives, in one process on the same robots and
states.

    python bench/bench_derivatives.py           # writes the "derivatives" section of bench/BENCHMARKS.md
    python bench/bench_derivatives.py --quick   # fewer rounds

Robots: the default UR5e (``sd.default_robot()``; Pinocchio reads the same URDF), the
Panda of example-robot-data, and two fixed-base trees of it (Solo12, Baxter). Each peer's answer is checked against ours before it is timed
(relative difference <= 1e-9; the largest over 200 states is reported). Times: minimum over
interleaved rounds (ours, peer, ours, ...) of the mean over a round, wall clock; one call
from Python for a single state; for a batch, our one call (split over the cores) against
Pinocchio called in a Python loop (per state). Ratio = ours / peer (lower is better).
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_speed import PinModel, erd_path, pair             # noqa: E402
from _report import stamp, write_section                     # noqa: E402

import pinocchio as pin                                      # noqa: E402
import serial_dynamics as sd                                 # noqa: E402
from serial_dynamics.robot import derivatives as derivatives_module  # noqa: E402  (PARALLEL_MIN)
from serial_dynamics.builtin import HERE as ROBOTS_DIR       # noqa: E402

N_BATCH = 10_000
N_CHECK = 200
TOL = 1e-9


def robots():
    """Two chains and two fixed-base trees (core/tree_derivatives.py): Solo12's four legs
    on a fixed trunk, Baxter's two arms and head (grippers held)."""
    import warnings
    out = [("UR5e", sd.default_robot(), os.path.join(ROBOTS_DIR, "ur5e.urdf"))]
    for name, rel, tip, tips in [
            ("Panda", "panda_description/urdf/panda.urdf", "panda_link8", None),
            ("Solo12 (tree, fixed trunk)", "solo_description/robots/solo12.urdf", None, None),
            ("Baxter (tree, 15 joints)", "baxter_description/urdf/baxter.urdf", None,
             ["left_wrist", "right_wrist", "head"])]:
        path = erd_path(rel)
        if os.path.isfile(path):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sd.HeldJointsWarning)
                out.append((name, sd.load_urdf(path, None, tip, tip_links=tips), path))
    return out


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def accuracy(robot, pm, Q, QD, QDD, T):
    """The largest relative difference to Pinocchio over the states, per output."""
    m, d, ix = pm.model, pm.data, np.ix_(pm.iv, pm.iv)
    Pq, Pv, Pa, Pt = pm.q(Q), pm.v(QD), pm.v(QDD), pm.v(T)
    err_id = err_fd = 0.0
    for k in range(Q.shape[0]):
        dq, dv, _ = pin.computeRNEADerivatives(m, d, Pq[k], Pv[k], Pa[k])
        ours = robot.inverse_dynamics_derivatives(Q[k], QD[k], QDD[k])
        err_id = max(err_id, rel(ours[0], dq[ix]), rel(ours[1], dv[ix]))
        aq, av, at = pin.computeABADerivatives(m, d, Pq[k], Pv[k], Pt[k])
        at = np.triu(at) + np.triu(at, 1).T
        ours = robot.forward_dynamics_derivatives(Q[k], QD[k], T[k])
        err_fd = max(err_fd, rel(ours[0], aq[ix]), rel(ours[1], av[ix]), rel(ours[2], at[ix]))
    assert err_id <= TOL and err_fd <= TOL, (err_id, err_fd)
    return err_id, err_fd


def measure(name, robot, path, rounds):
    pm = PinModel(robot, path)
    m, d = pm.model, pm.data
    rng = np.random.default_rng(0)
    Q, QD = robot.random_state(rng, batch=N_BATCH, speed=2.0)
    QDD = rng.normal(size=Q.shape)
    T = rng.normal(size=Q.shape) * 5
    err_id, err_fd = accuracy(robot, pm, Q[:N_CHECK], QD[:N_CHECK], QDD[:N_CHECK], T[:N_CHECK])
    Pq, Pv, Pa, Pt = pm.q(Q), pm.v(QD), pm.v(QDD), pm.v(T)
    q, qd, qdd, tau = Q[0].copy(), QD[0].copy(), QDD[0].copy(), T[0].copy()
    pq, pv, pa, pt = Pq[0], Pv[0], Pa[0], Pt[0]
    robot.inverse_dynamics_derivatives(Q, QD, QDD)               # compile / load first
    robot.forward_dynamics_derivatives(Q, QD, T)

    def rnea_loop():
        for k in range(N_BATCH):
            pin.computeRNEADerivatives(m, d, Pq[k], Pv[k], Pa[k])

    def aba_loop():
        for k in range(N_BATCH):
            pin.computeABADerivatives(m, d, Pq[k], Pv[k], Pt[k])

    rows = []
    for label, ours, peer, peer_name, per, number, target, err in [
        ("d tau/d (q, qd), one state", lambda: robot.inverse_dynamics_derivatives(q, qd, qdd),
         lambda: pin.computeRNEADerivatives(m, d, pq, pv, pa), "computeRNEADerivatives", 1,
         2000, 1.0, err_id),
        ("d qdd/d (q, qd, tau), one state", lambda: robot.forward_dynamics_derivatives(q, qd, tau),
         lambda: pin.computeABADerivatives(m, d, pq, pv, pt), "computeABADerivatives", 1,
         2000, 1.0, err_fd),
        (f"d tau/d (q, qd), {N_BATCH:,} states (per state)",
         lambda: robot.inverse_dynamics_derivatives(Q, QD, QDD), rnea_loop,
         "computeRNEADerivatives in a Python loop", N_BATCH, 1, 0.2, err_id),
        (f"d qdd/d (q, qd, tau), {N_BATCH:,} states (per state)",
         lambda: robot.forward_dynamics_derivatives(Q, QD, T), aba_loop,
         "computeABADerivatives in a Python loop", N_BATCH, 1, 0.2, err_fd),
    ]:
        a, b = pair(ours, peer, number, rounds)
        rows.append((name, label, a / per, b / per, peer_name, target, err))
    # for information: the batches on one thread (no split over the cores)
    default = derivatives_module.PARALLEL_MIN
    derivatives_module.PARALLEL_MIN = 10 ** 12
    try:
        for label, ours, peer, peer_name, err in [
                ("d tau/d (q, qd), one thread", lambda: robot.inverse_dynamics_derivatives(Q, QD, QDD),
                 rnea_loop, "computeRNEADerivatives in a Python loop", err_id),
                ("d qdd/d (q, qd, tau), one thread", lambda: robot.forward_dynamics_derivatives(Q, QD, T),
                 aba_loop, "computeABADerivatives in a Python loop", err_fd)]:
            a, b = pair(ours, peer, 1, rounds)
            rows.append((name, f"{label}, {N_BATCH:,} states (per state)", a / N_BATCH,
                         b / N_BATCH, peer_name, None, err))
    finally:
        derivatives_module.PARALLEL_MIN = default
    return rows


def table(rows):
    out = ["| robot | what | ours (us) | Pinocchio (us) | ratio | target | max rel. difference | peer |",
           "|---|---|---:|---:|---:|---:|---:|---|"]
    for name, label, a, b, peer, target, err in rows:
        out.append(f"| {name} | {label} | {a * 1e6:.2f} | {b * 1e6:.2f} | {a / b:.2f} | "
                   f"{'' if target is None else f'<= {target}'} | {err:.1e} | pinocchio.{peer} |")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    rounds = 5 if args.quick else 15
    rows = []
    for name, robot, path in robots():
        rows += measure(name, robot, path, rounds)
    body = "\n".join([
        "## Derivatives of the dynamics",
        "",
        "`python bench/bench_derivatives.py` (`--quick`: fewer rounds). "
        "`Robot.inverse_dynamics_derivatives` and `forward_dynamics_derivatives` against "
        "Pinocchio " + pin.__version__ + "'s `computeRNEADerivatives` and "
        "`computeABADerivatives` (d qdd/d tau = M^-1, mirrored to a full matrix), on the "
        "same states; the difference column is the largest relative difference of any "
        f"output over {N_CHECK} states. Single calls: one state from Python (ours allocates "
        "its results; Pinocchio's live in its `data`). Batches: our one call, split over the "
        "cores, against Pinocchio called in a Python loop (and, for information, on one "
        "thread); each core runs blocks of states in SIMD lanes, bitwise the single-state "
        "results: 32 on a chain (core/derivatives_lanes.py), 16-32 on these trees "
        "(core/tree_derivatives_lanes.py). docs/derivatives.md.",
        "",
        stamp(),
        table(rows),
    ])
    print(body)
    write_section("derivatives", body)


if __name__ == "__main__":
    main()
