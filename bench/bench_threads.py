"""Thread scaling of the batch calls (issue 29, item 3): a 65,536-state batch of inverse
dynamics, mass matrix and forward dynamics on the UR5e split over 1, 2, ... threads up to
the cores this process may run on (``robot/batches.py``: one thread per core of the
affinity mask, no fixed cap), each the best of 5 calls, with the speed-up against one
thread and the efficiency (speed-up / threads). The rows of every split are the bits of one
call (test/robot/test_batch_split.py).

    python bench/bench_threads.py [--states 65536]

Writes the "threads" section of bench/BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from _report import stamp, write_section                                        # noqa: E402

import serial_dynamics as sd                                                     # noqa: E402
from serial_dynamics.robot import batches                                        # noqa: E402


def best(fn, repeat=5):
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--states", type=int, default=65536)
    args = ap.parse_args(argv)
    robot = sd.default_robot()
    robot.warmup(batch=True)
    q, qd = robot.random_state(0, batch=args.states)
    qdd = np.random.default_rng(1).uniform(-2.0, 2.0, q.shape)
    calls = {"inverse dynamics": lambda: robot.inverse_dynamics(q, qd, qdd),
             "mass matrix": lambda: robot.mass_matrix(q),
             "forward dynamics": lambda: robot.forward_dynamics(q, qd, qdd)}
    cores = batches.cores()
    load0 = os.getloadavg()[0]
    ns = {}
    for workers in range(1, cores + 1):
        batches.WORKERS, batches._pool = workers, None
        for name, fn in calls.items():
            ns[name, workers] = 1e9 * best(fn) / args.states
            print(f"{name}, {workers} thread(s): {ns[name, workers]:.0f} ns/state", flush=True)
    batches.WORKERS, batches._pool = cores, None
    lines = ["## Batch calls over the cores (`bench/bench_threads.py`)", "", stamp(),
             f"UR5e, {args.states:,} states a call, best of 5; this process may run on {cores} "
             f"cores (its affinity mask), and a split batch uses one thread per core. Load "
             f"average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end.", "",
             "| call | threads | ns per state | speed-up | efficiency |", "|---|---:|---:|---:|---:|"]
    for name in calls:
        for workers in range(1, cores + 1):
            x = ns[name, 1] / ns[name, workers]
            lines.append(f"| {name} | {workers} | {ns[name, workers]:.0f} | {x:.2f} | "
                         f"{x / workers:.2f} |")
    write_section("threads", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
