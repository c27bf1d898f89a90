"""Kinematics, momentum and the Coriolis matrix against Pinocchio from Python, one process:
the pose, Jacobian and (classical) acceleration of a leaf link, the center of mass, the centroidal momentum and the
Coriolis matrix, one state a call, on the Panda (fixed and floating), Solo12 and Talos
(30 joints; floating). Each answer is checked against Pinocchio's before it is timed
(the Coriolis matrix through C v, which every valid C shares; the center of mass and
momentum on floating bases, where both count every body).

    python bench/bench_kinematics.py            # writes the "kinematics" section of bench/BENCHMARKS.md
    python bench/bench_kinematics.py --quick    # fewer rounds

Ours: core/kinematics.py (compiled; one kernel per quantity for every kind of robot); also
timed, the NumPy reference that ran these methods before (``backend="numpy"``). Timing:
bench_speed.py's ``pair`` (min over interleaved rounds); ratio = ours / Pinocchio's.
"""
from __future__ import annotations

import argparse
import os
import sys
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import serial_dynamics as sd                                                     # noqa: E402
from bench_speed import agree, erd_path, fmt_t, pair, pin                        # noqa: E402
from bench_trees import TALOS_TIPS                                               # noqa: E402
from _report import stamp, write_section                                        # noqa: E402

ROBOTS = [("Panda (chain, 7 joints)", "panda_description/urdf/panda.urdf", ["panda_link8"], False),
          ("Panda, floating", "panda_description/urdf/panda.urdf", ["panda_link8"], True),
          ("Solo12, floating", "solo_description/robots/solo12.urdf", None, True),
          ("Talos (30 joints), floating", "talos_data/robots/talos_full_v2.urdf", TALOS_TIPS, True)]


def pin_model(robot, path, floating):
    """Pinocchio's model of our joints (the rest locked at zero) and the maps of our q, v."""
    full = (pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer()) if floating
            else pin.buildModelFromUrdf(path))
    keep = set(robot.joint_names) | {"root_joint"}
    lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
    m = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    m.gravity.linear[:] = robot.gravity
    jid = [m.getJointId(n) for n in robot.joint_names]
    iq = (list(range(7)) if floating else []) + [m.idx_qs[j] for j in jid]
    iv = (list(range(6)) if floating else []) + [m.idx_vs[j] for j in jid]
    return m, m.createData(), iq, iv


def rows_of(name, robot, path, floating, rounds):
    m, d, iq, iv = pin_model(robot, path, floating)
    ref = sd.Robot(robot.model, backend="numpy")
    q, v = robot.random_state(0)
    pq, pv = pin.neutral(m), np.zeros(m.nv)
    pq[iq], pv[iv] = q, v
    leaf = robot.link_names[-1]
    fid = m.getFrameId(leaf)
    world = pin.LOCAL_WORLD_ALIGNED
    pin.forwardKinematics(m, d, pq)
    agree(robot.forward_kinematics(q, leaf), pin.updateFramePlacement(m, d, fid).homogeneous, "pose")
    agree(robot.jacobian(q, leaf), pin.computeFrameJacobian(m, d, pq, fid, world)[:, iv], "jacobian")
    a = np.random.default_rng(1).uniform(-1, 1, robot.nv)
    pa = np.zeros(m.nv)
    pa[iv] = a
    pin.forwardKinematics(m, d, pq, pv, pa)
    agree(robot.frame_acceleration(q, v, a, leaf),
          pin.getFrameClassicalAcceleration(m, d, fid, world).vector, "frame acceleration")
    Cv = pin.computeCoriolisMatrix(m, d, pq, pv) @ pv
    agree(robot.coriolis_matrix(q, v) @ v, Cv[iv], "C v")
    calls = [("pose of a leaf link", lambda r: r.forward_kinematics(q, leaf),
              lambda: (pin.forwardKinematics(m, d, pq), pin.updateFramePlacement(m, d, fid)),
              "forwardKinematics + updateFramePlacement"),
             ("Jacobian of a leaf link", lambda r: r.jacobian(q, leaf),
              lambda: pin.computeFrameJacobian(m, d, pq, fid, world), "computeFrameJacobian"),
             ("acceleration of a leaf link", lambda r: r.frame_acceleration(q, v, a, leaf),
              lambda: (pin.forwardKinematics(m, d, pq, pv, pa),
                       pin.getFrameClassicalAcceleration(m, d, fid, world)),
              "forwardKinematics(q, v, a) + getFrameClassicalAcceleration")]
    if floating:       # both count every body (a fixed base's own link: only Pinocchio)
        agree(robot.center_of_mass(q), pin.centerOfMass(m, d, pq), "center of mass")
        h = pin.computeCentroidalMomentum(m, d, pq, pv)
        agree(robot.centroidal_momentum(q, v), np.r_[h.linear, h.angular], "centroidal momentum")
        calls += [("center of mass", lambda r: r.center_of_mass(q),
                   lambda: pin.centerOfMass(m, d, pq), "centerOfMass"),
                  ("centroidal momentum", lambda r: r.centroidal_momentum(q, v),
                   lambda: pin.computeCentroidalMomentum(m, d, pq, pv), "computeCentroidalMomentum")]
    calls.append(("Coriolis matrix", lambda r: r.coriolis_matrix(q, v),
                  lambda: pin.computeCoriolisMatrix(m, d, pq, pv), "computeCoriolisMatrix"))
    rows = []
    for label, ours, peer, peer_name in calls:
        ta, tb = pair(lambda: ours(robot), peer, 200, rounds)
        tr, _ = pair(lambda: ours(ref), peer, 5, max(2, rounds // 3))
        rows.append((name, label, ta, tb, tr, peer_name))
        print(rows[-1], flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rounds = 3 if args.quick else 7
    load_at_start = os.getloadavg()
    rows = []
    for name, rel, tips, floating in ROBOTS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sd.HeldJointsWarning)
            robot = sd.load_urdf(erd_path(rel), tip_links=tips, floating_base=floating)
        rows += rows_of(name, robot, erd_path(rel), floating, rounds)
    lines = ["## Kinematics, momentum and the Coriolis matrix against Pinocchio", "", stamp(),
             "`python bench/bench_kinematics.py`. One state a call from Python. Ours: "
             "`core/kinematics.py` (compiled); *reference*: the NumPy code these methods ran "
             "before (`backend=\"numpy\"`). Ratio = ours / Pinocchio's. "
             f"Load average (1 min) of the 2 cores: {load_at_start[0]:.1f} at the start, "
             f"{os.getloadavg()[0]:.1f} at the end.",
             "", "| robot | call | ours | Pinocchio | ratio | NumPy reference | peer |",
             "|---|---|---:|---:|---:|---:|---|"]
    for name, label, a, b, r, peer in rows:
        lines.append(f"| {name} | {label} | {fmt_t(a)} | {fmt_t(b)} | {a / b:.2f} | {fmt_t(r)} | "
                     f"pinocchio.{peer} |")
    print("\n".join(lines))
    if not args.no_write:
        write_section("kinematics", "\n".join(lines))


if __name__ == "__main__":
    main()
