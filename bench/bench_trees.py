"""Trees (issue 25): single calls and 10,000-state batches against Pinocchio from Python, in
one process, on whole robots from example-robot-data: Talos (arms, legs, head; its
grippers' mimic fingers held), Solo12, Baxter (two arms and the head; grippers held) and
bench_speed.py's chains (Panda, UR5) on a fixed base, and the chains, Solo12 and Talos on a
free-floating base (Pinocchio's free-flyer root), Talos also whole (its grippers' mimic
joints: our 32 independent joints against Pinocchio's 44).
(The Pinocchio adapter, the rows and their timing are bench_speed.py's.)

    python bench/bench_trees.py            # writes the "trees" section of bench/BENCHMARKS.md
    python bench/bench_trees.py --quick    # fewer rounds

The rows and their timing are bench_speed.py's (each answer checked against Pinocchio
before it is timed; min over interleaved rounds; ratio = ours / Pinocchio's, lower is
better; targets from the issue: single calls <= 1.0, 10,000-state batches <= 0.3 of a
Python loop over pinocchio.rnea).
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_speed import PinModel, agree, batch_calls, erd_path, fmt_t, pair, pin, single_calls  # noqa: E402
from _report import stamp, write_section                                        # noqa: E402

import serial_dynamics as sd                                                     # noqa: E402

TALOS_TIPS = ["arm_left_7_link", "arm_right_7_link", "leg_left_6_link", "leg_right_6_link",
              "head_2_link"]
FIXED = {"Talos (30 joints)": ("talos_data/robots/talos_full_v2.urdf", TALOS_TIPS),
         "Solo12": ("solo_description/robots/solo12.urdf", None),
         "Baxter (15 joints)": ("baxter_description/urdf/baxter.urdf",
                                ["left_wrist", "right_wrist", "head"]),
         # the chains of bench_speed.py, in the same run
         "Panda (chain, 7 joints)": ("panda_description/urdf/panda.urdf", ["panda_link8"]),
         "UR5 (chain)": ("ur_description/urdf/ur5_robot.urdf", ["tool0"])}
FLOATING = {"Panda (chain), floating": ("panda_description/urdf/panda.urdf", ["panda_link8"]),
            "UR5 (chain), floating": ("ur_description/urdf/ur5_robot.urdf", ["tool0"]),
            "Solo12, floating": ("solo_description/robots/solo12.urdf", None),
            "Talos (30 joints), floating": ("talos_data/robots/talos_full_v2.urdf", TALOS_TIPS),
            "Talos (full: 32 joints, grippers' mimic joints), floating":
                ("talos_data/robots/talos_full_v2.urdf", None)}


def load(rel, tips, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd_path(rel), tip_links=tips, **kw)


def floating_rows(name, robot, path, rounds):
    """Single calls on a free-floating base against Pinocchio's free-flyer root. With mimic
    joints Pinocchio moves every joint (a follower is a joint of its own there) and ours the
    independent ones: q_all = G q + o, v_all = G v."""
    full = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    names = robot.all_joint_names
    keep = set(names) | {"root_joint"}
    lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
    m = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    m.gravity.linear[:] = robot.gravity
    d = m.createData()
    jid = [m.getJointId(n) for n in names]
    idx = list(range(6)) + [m.idx_vs[j] for j in jid]
    G, o = robot.model.mimic_matrix
    Gv = np.zeros((6 + len(names), robot.nv))
    Gv[:6, :6], Gv[6:, 6:] = np.eye(6), G
    rng = np.random.default_rng(0)
    quat = rng.normal(size=4)
    q = np.concatenate([[0.1, -0.2, 0.3], quat / np.linalg.norm(quat),
                        rng.uniform(-1, 1, robot.dof)])
    v, a = rng.uniform(-1, 1, (2, robot.nv))
    pq = pin.neutral(m)
    pq[:7], pq[[m.idx_qs[j] for j in jid]] = q[:7], G @ q[7:] + o
    pv, pa = np.zeros(m.nv), np.zeros(m.nv)
    pv[idx], pa[idx] = Gv @ v, Gv @ a
    tau = robot.inverse_dynamics(q, v, a)
    agree(tau, Gv.T @ pin.rnea(m, d, pq, pv, pa)[idx], "rnea")
    agree(robot.forward_dynamics(q, v, tau), a, "forward o inverse", 1e-8)
    pt = pin.rnea(m, d, pq, pv, pa)
    agree(pin.aba(m, d, pq, pv, pt)[idx], Gv @ a, "aba", 1e-8)
    rows = []
    for label, ours, peer, peer_name in [
            ("inverse dynamics, one state", lambda: robot.inverse_dynamics(q, v, a),
             lambda: pin.rnea(m, d, pq, pv, pa), "pinocchio.rnea"),
            ("mass matrix, one state", lambda: robot.mass_matrix(q),
             lambda: pin.crba(m, d, pq), "pinocchio.crba (upper triangle only)"),
            ("forward dynamics, one state", lambda: robot.forward_dynamics(q, v, tau),
             lambda: pin.aba(m, d, pq, pv, pt), "pinocchio.aba")]:
        ta, tb = pair(ours, peer, 50, rounds)
        rows.append((name, label, ta, tb, peer_name, 1.0))
    if not robot.model.has_mimic_joints:     # the derivatives and the regressor (no target)
        ix = np.ix_(idx, idx)
        for x, y, what in zip(robot.inverse_dynamics_derivatives(q, v, a),
                              pin.computeRNEADerivatives(m, d, pq, pv, pa), ("dq", "dv")):
            agree(x, y[ix], f"inverse dynamics derivatives {what}")
        for x, y, what in zip(robot.forward_dynamics_derivatives(q, v, tau),
                              pin.computeABADerivatives(m, d, pq, pv, pt), ("dq", "dv", "M^-1")):
            agree(x, y[ix], f"forward dynamics derivatives {what}", 1e-7)
        cols = np.concatenate([np.arange(10)] + [10 * (j - 1) + np.arange(10) for j in jid])
        agree(robot.regressor(q, v, a),
              pin.computeJointTorqueRegressor(m, d, pq, pv, pa)[np.ix_(idx, cols)], "regressor")
        for label, ours, peer, peer_name in [
                ("derivatives of inverse dynamics, one state",
                 lambda: robot.inverse_dynamics_derivatives(q, v, a),
                 lambda: pin.computeRNEADerivatives(m, d, pq, pv, pa),
                 "pinocchio.computeRNEADerivatives"),
                ("derivatives of forward dynamics, one state",
                 lambda: robot.forward_dynamics_derivatives(q, v, tau),
                 lambda: pin.computeABADerivatives(m, d, pq, pv, pt),
                 "pinocchio.computeABADerivatives"),
                ("regressor, one state", lambda: robot.regressor(q, v, a),
                 lambda: pin.computeJointTorqueRegressor(m, d, pq, pv, pa),
                 "pinocchio.computeJointTorqueRegressor")]:
            ta, tb = pair(ours, peer, 50, rounds)
            rows.append((name, label, ta, tb, peer_name, None))
    # 10,000 states in one call against pinocchio.rnea in a Python loop over them
    N = 10_000
    Q, V = robot.random_state(rng, batch=N)
    A = rng.uniform(-1, 1, (N, robot.nv))
    PQ = np.tile(pin.neutral(m), (N, 1))
    PQ[:, :7], PQ[:, [m.idx_qs[j] for j in jid]] = Q[:, :7], Q[:, 7:] @ G.T + o
    PV, PA = np.zeros((N, m.nv)), np.zeros((N, m.nv))
    PV[:, idx], PA[:, idx] = V @ Gv.T, A @ Gv.T
    T = robot.inverse_dynamics(Q, V, A)
    agree(T[:20], np.array([Gv.T @ pin.rnea(m, d, PQ[k], PV[k], PA[k])[idx] for k in range(20)]),
          "rnea loop")

    def loop():
        for k in range(N):
            pin.rnea(m, d, PQ[k], PV[k], PA[k])

    ta, tb = pair(lambda: robot.inverse_dynamics(Q, V, A), loop, 1, rounds)
    rows.append((name, f"inverse dynamics, {N:,} states, one call (per state)", ta / N, tb / N,
                 "pinocchio.rnea in a Python loop", 0.3))
    if robot.model.has_mimic_joints:
        return rows
    PT = np.zeros((N, m.nv))                 # the derivatives' batches (no target)
    PT[:, idx] = T
    ours = robot.forward_dynamics_derivatives(Q[:3], V[:3], T[:3])
    for x, y, what in zip(ours, pin.computeABADerivatives(m, d, PQ[2], PV[2], PT[2]), ("dq", "dv")):
        agree(x[2], y[np.ix_(idx, idx)], f"forward dynamics derivatives {what}, a batch's row", 1e-7)

    def rnea_derivatives_loop():
        for k in range(N):
            pin.computeRNEADerivatives(m, d, PQ[k], PV[k], PA[k])

    def aba_derivatives_loop():
        for k in range(N):
            pin.computeABADerivatives(m, d, PQ[k], PV[k], PT[k])

    for label, ours, loop, peer in [
            ("derivatives of inverse dynamics", lambda: robot.inverse_dynamics_derivatives(Q, V, A),
             rnea_derivatives_loop, "pinocchio.computeRNEADerivatives in a Python loop"),
            ("derivatives of forward dynamics", lambda: robot.forward_dynamics_derivatives(Q, V, T),
             aba_derivatives_loop, "pinocchio.computeABADerivatives in a Python loop")]:
        ta, tb = pair(ours, loop, 1, rounds)
        rows.append((name, f"{label}, {N:,} states, one call (per state)", ta / N, tb / N, peer,
                     None))
    return rows


def method_rows(rounds):
    """forward_dynamics by articulated bodies against the sparse factor, single compiled
    calls, on trees of growing depth (robot/common.aba_by_default's TREE_CROSSOVER)."""
    from serial_dynamics.robot.common import TREE_CROSSOVER
    from serial_dynamics.builtin.synthetic import two_arm_urdf
    cases = [(f"two {n}-joint arms{', floating' if fl else ''}",
              lambda n=n, fl=fl: sd.load_urdf(two_arm_urdf(n, base_mass=5.0), floating_base=fl))
             for fl in (False, True) for n in (6, 12, 20, 30)]
    cases += [(name + (", floating" if fl else ""),
               lambda rel=rel, tips=tips, fl=fl: load(rel, tips, floating_base=fl))
              for name, (rel, tips) in FIXED.items() for fl in (False, True)]
    lines = ["", "### Forward dynamics on a tree: articulated bodies or the sparse factor", "",
             "Single compiled calls, `method=\"aba\"` against `method=\"cholesky\"` (the sparse "
             "factor M = LᵀDL); mean d² is the mean over the joints of the squared number of "
             "joints from the base (six more on a floating base). `method=\"auto\"` takes "
             f"articulated bodies from a mean d² of {TREE_CROSSOVER:g} on "
             "(`robot/common.aba_by_default`).", "",
             "| tree | joints | mean d² | ABA | sparse factor | ABA / factor | auto |",
             "|---|---:|---:|---:|---:|---:|---|"]
    for name, make in cases:
        robot = make()
        d = robot.model.depths + (6 if robot.is_floating else 0)
        rng = np.random.default_rng(1)
        q = rng.uniform(-1, 1, robot.nq)
        if robot.is_floating:
            q[3:7] = (0.1, -0.2, 0.3, 0.9) / np.linalg.norm((0.1, -0.2, 0.3, 0.9))
        v, tau = rng.uniform(-1, 1, (2, robot.nv))
        ta, tb = pair(lambda: robot.forward_dynamics(q, v, tau, method="aba"),
                      lambda: robot.forward_dynamics(q, v, tau, method="cholesky"), 200, rounds)
        auto = robot.forward_dynamics(q, v, tau)
        pick = "ABA" if np.array_equal(auto, robot.forward_dynamics(q, v, tau, method="aba")) \
            else "factor"
        lines.append(f"| {name} | {robot.dof} | {np.mean(d ** 2.0):.0f} | {fmt_t(ta)} | "
                     f"{fmt_t(tb)} | {ta / tb:.2f} | {pick} |")
        print(lines[-1], flush=True)
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rounds = 3 if args.quick else 7
    load_at_start = os.getloadavg()
    rows = []
    for name, (rel, tips) in FIXED.items():
        robot = load(rel, tips)
        robot.warmup(batch=True)
        pm = PinModel(robot, erd_path(rel))
        print(f"{name}: {robot.dof} joints", flush=True)
        rows += [r for r in single_calls(name, robot, pm, rounds) if "`out=`" not in r[1]]
        rows += [r[:5] + (0.3 if r[5] == 0.2 else r[5],)       # the batch target
                 for r in batch_calls(name, robot, pm, rounds)]
    for name, (rel, tips) in FLOATING.items():
        robot = load(rel, tips, floating_base=True)
        print(f"{name}: {robot.dof} joints", flush=True)
        rows += floating_rows(name, robot, erd_path(rel), rounds)
    lines = ["## Trees against Pinocchio", "", stamp(),
             "`python bench/bench_trees.py`. Ours: the compiled tree kernels (`core/tree.py`: "
             "forward dynamics by `method=\"auto\"`, here the sparse factor M = LᵀDL; a "
             "floating base through the instantaneous tree of six virtual joints, whose block "
             "and columns of M the CRBA computes as one free-flyer root, whose derivatives and "
             "regressor are the fixed-base kernels' on that tree plus the base's columns "
             "(`core/floating_derivatives.py`, `core/regressor.py`); mimic joints: "
             "`core/mimic.py`, the reduced system in one call). "
             "Ratio = ours / Pinocchio's; target: the issue's. "
             f"Load average (1 min) of the 2 cores: {load_at_start[0]:.1f} at the start, "
             f"{os.getloadavg()[0]:.1f} at the end (above ~1, other work shared the machine).",
             "", "| robot | call | ours | Pinocchio | ratio | peer | target | verdict |",
             "|---|---|---:|---:|---:|---|---:|---|"]
    for name, label, a, b, peer, target in rows:
        ratio = a / b
        verdict = "" if target is None else ("met" if ratio <= target else
                                             f"missed by {100 * (ratio / target - 1):.0f} %")
        lines.append(f"| {name} | {label} | {fmt_t(a)} | {fmt_t(b)} | {ratio:.2f} | {peer} | "
                     f"{'' if target is None else target} | {verdict} |")
        print(lines[-1], flush=True)
    lines += method_rows(rounds)
    if not args.no_write:
        write_section("trees", "\n".join(lines))


if __name__ == "__main__":
    main()
