"""What the real-arm terms cost (issue: rotor inertia, payload, mimic joints, moving base).

    python bench/bench_modelling.py            # writes the "modelling" section of BENCHMARKS.md

Rows, single calls on the UR5e (one state, C-contiguous float64 arrays) unless said:

- terms that are off: the plain calls of this code against the same calls of the code
  before these terms existed (commit BEFORE_REV, run from a ``git archive`` in a
  subprocess), each timed interleaved with Pinocchio's call as a yardstick, so that the
  ratio ours / Pinocchio compares the two versions on this machine;
- armature on, a moving base on (single state and a 1,000-state batch);
- a payload change: ``with_payload`` (a new Robot, nothing recompiled) and the first call
  on the new robot;
- mimic joints: a 4-joint chain with 2 mimic joints (the reduced system of 2 coordinates)
  against the same chain with all 4 joints free, and against Pinocchio's mimic joints.
Timing: min over rounds of the mean of ``number`` calls (``bench_speed.pair``).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
BEFORE_REV = "5b94d96"   # the last commit before armature, payload, mimic and base motion


def plain_rows(rounds):
    """(name, ours s, Pinocchio s) of the plain single calls, for any version of the package."""
    import pinocchio as pin
    import serial_dynamics as sd
    from bench_speed import pair
    robot = sd.default_robot()
    path = sd.builtin_path()
    pm = pin.buildModelFromUrdf(path)
    pm.gravity.linear[:] = robot.gravity
    pd = pm.createData()
    rng = np.random.default_rng(0)
    q, qd = robot.random_state(rng)
    qdd, tau = rng.normal(size=6), rng.normal(size=6)
    calls = [("inverse dynamics", lambda: robot.inverse_dynamics(q, qd, qdd),
              lambda: pin.rnea(pm, pd, q, qd, qdd)),
             ("mass matrix", lambda: robot.mass_matrix(q), lambda: pin.crba(pm, pd, q)),
             ("forward dynamics", lambda: robot.forward_dynamics(q, qd, tau),
              lambda: pin.aba(pm, pd, q, qd, tau))]
    return [(name, *pair(a, b, 20000, rounds)) for name, a, b in calls]


def before_rows(rounds):
    """plain_rows of the package at BEFORE_REV (git archive, subprocess), or None."""
    from bench_speed import earlier_code
    with tempfile.TemporaryDirectory() as tmp:
        if earlier_code(tmp, BEFORE_REV) is None:
            return None
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([tmp, HERE]),
                   NUMBA_CACHE_DIR=os.path.join(tmp, "numba"))
        subprocess.run([sys.executable, "-c", "import serial_dynamics as sd; sd.default_robot().warmup()"],
                       env=env, check=True, cwd=tmp)
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--plain-only",
                              "--rounds", str(rounds)], env=env, cwd=tmp, check=True,
                             capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def term_rows(rounds):
    import serial_dynamics as sd
    from bench_speed import pair
    robot = sd.default_robot()
    armed = sd.load_urdf(sd.builtin_path(), armature={n: 0.05 for n in robot.joint_names})
    rng = np.random.default_rng(1)
    q, qd = robot.random_state(rng)
    qdd, tau = rng.normal(size=6), rng.normal(size=6)
    Q, V = robot.random_state(rng, batch=1000)
    bm = sd.BaseMotion([0.2, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.3, 0.0])
    rows = []
    for name, plain, term in [
            ("inverse dynamics, armature", lambda: robot.inverse_dynamics(q, qd, qdd),
             lambda: armed.inverse_dynamics(q, qd, qdd)),
            ("forward dynamics, armature", lambda: robot.forward_dynamics(q, qd, tau),
             lambda: armed.forward_dynamics(q, qd, tau)),
            ("inverse dynamics, moving base", lambda: robot.inverse_dynamics(q, qd, qdd),
             lambda: robot.inverse_dynamics(q, qd, qdd, base_motion=bm)),
            ("forward dynamics, moving base", lambda: robot.forward_dynamics(q, qd, tau),
             lambda: robot.forward_dynamics(q, qd, tau, base_motion=bm)),
            ("inverse dynamics, moving base, 1,000 states", lambda: robot.inverse_dynamics(Q, V, V),
             lambda: robot.inverse_dynamics(Q, V, V, base_motion=bm))]:
        number = 200 if "1,000" in name else 20000
        rows.append((name, *pair(plain, term, number, rounds)))
    return rows


def payload_rows(rounds):
    import serial_dynamics as sd
    from bench_speed import pair
    robot = sd.default_robot().warmup()
    q, qd = robot.random_state(2)
    args = (2.0, (0.0, 0.0, 0.05), (0.01, 0.01, 0.01, 0.0, 0.0, 0.0))
    t_change, t_call = pair(lambda: robot.with_payload(*args),
                            lambda: robot.inverse_dynamics(q, qd, qd), 2000, rounds)
    first = []
    for k in range(rounds):           # the first call on each new robot: nothing to compile
        r2 = robot.with_payload(2.0 + k, *args[1:])
        t0 = time.perf_counter()
        r2.inverse_dynamics(q, qd, qd)
        first.append(time.perf_counter() - t0)
    return t_change, t_call, min(first)


def mimic_rows(rounds):
    import dataclasses
    import pinocchio as pin
    import serial_dynamics as sd
    from bench_speed import pair
    sys.path.insert(0, os.path.join(os.path.dirname(HERE), "test"))
    from test_mimic import mimic_chain
    xml = mimic_chain("revolute")
    robot = sd.load_urdf(xml)
    free = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(4, -1)))
    pm = pin.buildModelFromXML(xml, mimic=True)
    pm.gravity.linear[:] = robot.gravity
    pd = pm.createData()
    rng = np.random.default_rng(3)
    q, qd = robot.random_state(rng)
    qa, qda = robot.all_joint_positions(q), robot.all_joint_velocities(qd)
    rows = []
    for name, ours, other, pin_call in [
            ("inverse dynamics", lambda: robot.inverse_dynamics(q, qd, qd),
             lambda: free.inverse_dynamics(qa, qda, qda), lambda: pin.rnea(pm, pd, q, qd, qd)),
            ("mass matrix", lambda: robot.mass_matrix(q), lambda: free.mass_matrix(qa),
             lambda: pin.crba(pm, pd, q)),
            ("forward dynamics", lambda: robot.forward_dynamics(q, qd, qd),
             lambda: free.forward_dynamics(qa, qda, qda), None)]:
        t_ours, t_free = pair(ours, other, 20000, rounds)
        t_pin = pair(pin_call, ours, 20000, rounds)[0] if pin_call else float("nan")
        rows.append((name, t_ours, t_free, t_pin))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--plain-only", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    sys.path.insert(0, HERE)
    warnings.simplefilter("ignore")
    if a.plain_only:                    # run inside the earlier package (before_rows)
        print(json.dumps(plain_rows(a.rounds)))
        return
    from _report import stamp, write_section
    from bench_speed import fmt_t
    print("plain calls, this code ...", flush=True)
    now = plain_rows(a.rounds)
    print(f"plain calls, commit {BEFORE_REV} ...", flush=True)
    before = before_rows(a.rounds)
    print("terms, payload, mimic ...", flush=True)
    terms, (t_change, t_call, t_first), mimic = term_rows(a.rounds), payload_rows(a.rounds), mimic_rows(a.rounds)
    L = ["## Real-arm terms: what armature, a payload, a moving base and mimic joints cost", "",
         stamp(), "`python bench/bench_modelling.py`. Single calls on the UR5e (C-contiguous "
         "float64 arrays); min over rounds of the mean of 20,000 calls.", "",
         "### Terms that are off cost nothing", "",
         f"The plain calls of this code and of commit `{BEFORE_REV}` (before these terms), each "
         "interleaved with Pinocchio's call in its own process:", "",
         "| call | this code | / Pinocchio | before | / Pinocchio |", "|---|---|---|---|---|"]
    for k, (name, ours, pin_t) in enumerate(now):
        if before:
            _, b_ours, b_pin = before[k]
            L.append(f"| {name} | {fmt_t(ours)} | {ours / pin_t:.3f} | {fmt_t(b_ours)} | "
                     f"{b_ours / b_pin:.3f} |")
        else:
            L.append(f"| {name} | {fmt_t(ours)} | {ours / pin_t:.3f} | (no git history) | |")
    L += ["", "### Armature and a moving base switched on", "",
          "| call | off | on | on / off |", "|---|---|---|---|"]
    L += [f"| {name} | {fmt_t(off)} | {fmt_t(on)} | {on / off:.2f} |" for name, off, on in terms]
    L += ["", "Armature is a column of the compiled model: on or off, the same code runs. A "
          "moving base passes its motion with the wrench vector (`core/layout.py` `W_*`) and "
          "goes through the entry point that takes one.", "",
          "### Payload change", "",
          "| what | time |", "|---|---|",
          f"| `robot.with_payload(2 kg, com, inertia)`: a new Robot | {fmt_t(t_change)} |",
          f"| first inverse-dynamics call on the new Robot (nothing recompiled) | {fmt_t(t_first)} |",
          f"| an inverse-dynamics call, for scale | {fmt_t(t_call)} |", "",
          "### Mimic joints", "",
          "A 4-joint chain whose joints 3 and 4 mimic joints 2 and 1 (`test/robot/test_mimic.py`, 2 "
          "coordinates), against the same chain with all 4 joints free, and against "
          "Pinocchio's mimic joints (`buildModel(..., mimic=True)`; its ABA has no mimic "
          "joints).", "",
          "| call | reduced (2) | all free (4) | Pinocchio, mimic | reduced / free |", "|---|---|---|---|---|"]
    L += [f"| {name} | {fmt_t(r)} | {fmt_t(f)} | {fmt_t(p) if p == p else '—'} | {r / f:.2f} |"
          for name, r, f, p in mimic]
    L += ["", "The reduction (q_all = G q + o, tau = G^T tau_all, M = G^T M_all G) runs around "
          "the compiled calls of the whole chain, in small compiled loops (`robot/mimic.py`) for one "
          "state; what it adds is the difference of the first two columns."]
    write_section("modelling", "\n".join(L))
    print("\n".join(L))


if __name__ == "__main__":
    main()
