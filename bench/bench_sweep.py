"""Scale-out on Dask: cases per second against worker processes, the scheduler's overhead,
what a Robot costs to send, and a paper plan for 100 machines from these numbers.

    python bench/bench_sweep.py            # writes the 'sweep' section of BENCHMARKS.md
    python bench/bench_sweep.py --quick    # fewer cases

Workload: ``sweep.monte_carlo``'s case (the UR5e under computed torque along the built-in
pick-and-place, 5.3 s simulated at 2 ms: ~2650 steps with a Python controller in the loop),
the same ``CASES`` cases for every row:

- in this process (``client="serial"``): the reference, no Dask;
- on a ``LocalCluster`` of 1 and of 2 worker processes (one thread each), started and
  warmed (kernels loaded, one sweep run) before the clock starts; ``sweep.run``'s default
  tasks. ``ROUNDS`` rounds, the three interleaved in each (a change of load hits all
  three), the median wall time of each. Speed-up = rate(2) / rate(1).

Scheduler overhead: a function that does nothing, ``TRIVIAL`` cases, one case per task
(``chunk_size=1``) on the 2-worker cluster: wall time per task is what Dask costs a task
(submit, schedule, run, return, gather). The overhead of a real sweep is that times its
number of tasks, over its wall time.

Robots: pickle size and unpickle time (median of 200) for each kind.
"""
from __future__ import annotations

import argparse
import os
import pickle
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import serial_dynamics as sd                                        # noqa: E402
from serial_dynamics import sweep                                   # noqa: E402
from serial_dynamics.sweep.robustness import Study                  # noqa: E402
from serial_dynamics.sweep.run import chunks                        # noqa: E402
from _report import stamp, write_section                           # noqa: E402

CASES = 120
ROUNDS = 3
TRIVIAL = 2000


def nothing(case):
    return {}


def robots():
    ur5e = sd.default_robot()
    mimic = ('<robot name="m"><link name="b"/>' + "".join(
        f'<joint name="j{i}" type="revolute"><parent link="{"b" if i == 0 else f"l{i - 1}"}"/>'
        f'<child link="l{i}"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>'
        f'<limit lower="-3" upper="3" effort="50" velocity="3"/>'
        + ('<mimic joint="j1" multiplier="0.5"/>' if i == 2 else "") + '</joint>'
        f'<link name="l{i}"><inertial><mass value="1"/><origin xyz="0.1 0 0.1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        for i in range(4)) + "</robot>")
    return {"UR5e": ur5e, "UR5e + payload": ur5e.with_payload(2.0, (0.0, 0.0, 0.05)),
            "UR5e + armature": sd.default_robot(armature={j: 0.1 for j in ur5e.joint_names}),
            "mimic (4 joints, 3 coordinates)": sd.load_urdf(mimic),
            "planar 3R": sd.builtin_robot("planar_3r")}


def pickling():
    rows = []
    for name, robot in robots().items():
        data = pickle.dumps(robot)
        times = []
        for _ in range(200):
            t = time.perf_counter()
            pickle.loads(data)
            times.append(time.perf_counter() - t)
        rows.append((name, type(robot).__name__, len(data), float(np.median(times))))
    return rows


def cpu_seconds(client):
    """CPU time (user + system) of the processes that run the cases."""
    if isinstance(client, str):
        return time.process_time()
    return sum(client.run(time.process_time).values())


def timed(fn, cases, client, cpu=None):
    c0, t = cpu_seconds(client), time.perf_counter()
    table = sweep.run(fn, cases, client=client, progress=False)
    wall = time.perf_counter() - t
    if cpu is not None:
        cpu.append(cpu_seconds(client) - c0)
    return wall, table


def main():
    from distributed import Client, LocalCluster
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    n_cases, n_trivial, rounds = (40, 400, 1) if args.quick else (CASES, TRIVIAL, ROUNDS)
    load = os.getloadavg()[0]
    study = Study(None, None, "computed_torque", 400.0, 40.0, True, (0.0, 0.0, 0.05), 0.5,
                  0.002, 1.0)
    cases = sweep.draw(study.nominal, n_cases, 0, (0.0, 3.0), (0.9, 1.1), (0.5, 2.0), 0.05)
    study(cases.iloc[0].to_dict())                                   # kernels loaded here
    clusters = {w: LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                                host="127.0.0.1", dashboard_address=":0") for w in (1, 2)}
    clients = {w: Client(c) for w, c in clusters.items()}
    try:
        for w, client in clients.items():
            timed(study, cases.iloc[:4 * w], client)                 # warm the workers
        walls, cpus = {"serial": [], 1: [], 2: []}, {"serial": [], 1: [], 2: []}
        same, reference = True, None
        for r in range(rounds):          # interleaved, so that a change of load hits all
            for where in ("serial", 1, 2):
                wall, table = timed(study, cases, clients.get(where, where), cpus[where])
                walls[where].append(wall)
                reference = table if reference is None else reference
                same &= table.equals(reference) and all(
                    table[c].to_numpy().tobytes() == reference[c].to_numpy().tobytes()
                    for c in table.columns if table[c].dtype == float)
                print(f"round {r}, {where}: {n_cases / wall:.2f} cases/s", flush=True)
        client = clients[2]
        timed(nothing, [{"k": k} for k in range(50)], client)
        t = time.perf_counter()
        sweep.run(nothing, [{"k": k} for k in range(n_trivial)], client=client,
                  progress=False, chunk_size=1)
        overhead = (time.perf_counter() - t) / n_trivial
        print(f"per task: {overhead * 1e3:.2f} ms", flush=True)
    finally:
        for w in clients:
            clients[w].close()
            clusters[w].close()
    t_serial = float(np.median(walls["serial"]))
    rates = {w: (float(np.median(walls[w])), n_cases / float(np.median(walls[w])),
                 len(chunks(n_cases, w))) for w in (1, 2)}
    rows = pickling()
    row_bytes = reference.memory_usage(deep=True).sum() / n_cases
    spread = {w: [n_cases / x for x in walls[w]] for w in walls}
    spread["cpu"] = {w: (float(np.median(cpus[w])) / n_cases,
                         float(np.median([c / x for c, x in zip(cpus[w], walls[w])])))
                     for w in cpus}
    report(n_cases, t_serial, rates, overhead, same, rows, load, n_trivial, row_bytes, rounds,
           spread)


def report(n, t_serial, rates, overhead, same, rows, load, n_trivial, row_bytes, rounds,
           spread):
    per_case = t_serial / n
    cpu = spread["cpu"]
    w1, w2 = rates[1], rates[2]
    speedup = w2[1] / w1[1]
    lines = [
        "## Scale-out on Dask: cases per second, scheduler overhead, a plan for 100 machines",
        "", stamp(), f"Load average of the machine when the run started: {load:.1f} (the 2 "
        "cores are shared with other work: the rates below are what was left of them).", "",
        "`python bench/bench_sweep.py` (`sweep.run` on `dask.distributed` LocalClusters of "
        "worker processes, one thread each, started and warmed before timing). Workload: "
        f"{n} cases of `sweep.monte_carlo` (UR5e, computed torque on the nominal model, the "
        "pick-and-place, 5.3 s at 2 ms: 2650 steps of a Python controller and the simulator "
        f"each), the same cases on every row; {rounds} rounds, the three rows interleaved "
        "in each, the median wall time.", "",
        "| where | wall time | cases / s | tasks | speed-up vs 1 worker | CPU s per case | "
        "cores used (CPU / wall) | same table, bit for bit |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
        f"| in this process (no Dask) | {t_serial:.1f} s | {n / t_serial:.2f} | - | - | "
        f"{cpu['serial'][0] * 1e3:.0f} ms | {cpu['serial'][1]:.2f} | reference |",
        f"| 1 worker process | {w1[0]:.1f} s | {w1[1]:.2f} | {w1[2]} | 1.00 | "
        f"{cpu[1][0] * 1e3:.0f} ms | {cpu[1][1]:.2f} | {same} |",
        f"| 2 worker processes | {w2[0]:.1f} s | {w2[1]:.2f} | {w2[2]} | {speedup:.2f} | "
        f"{cpu[2][0] * 1e3:.0f} ms | {cpu[2][1]:.2f} | {same} |",
        "", "CPU s per case: the CPU time of the processes that ran the cases (the workers' "
        "includes Dask's own work in them), over the cases. Cores used: that CPU time over "
        "the wall time, i.e. how much of the machine the run got; the speed-up is bounded "
        "by its ratio between the two rows.",
        "",
        f"**Speed-up with 2 workers: {speedup:.2f}x** (target >= 1.8x"
        + ("; met)." if speedup >= 1.8 else f"; missed by {1.8 - speedup:.2f}).")
        + f" One case costs {per_case * 1e3:.0f} ms in this process. The rounds, cases/s "
        "(in this process; 1 worker; 2 workers): "
        + "; ".join(", ".join(f"{x:.2f}" for x in spread[w]) for w in ("serial", 1, 2))
        + ". On this shared machine a round's rate moves with the other load, so the "
        "speed-up is known to that precision only; the CPU columns say what the run got: "
        f"{cpu[2][1]:.2f} cores with 2 workers against {cpu[1][1]:.2f} with one "
        f"(speed-up bound {cpu[2][1] / cpu[1][1]:.2f}x). Per case a worker spends "
        f"{100 * (cpu[1][0] / cpu['serial'][0] - 1):.0f} % more CPU than this process "
        "(Dask's own work in the worker process).", "",
        f"**Scheduler overhead**: {n_trivial} cases of a function that does nothing, one case "
        f"a task, on the 2 workers: **{overhead * 1e3:.2f} ms per task** (submit, schedule, "
        "run, return, gather). A sweep's overhead is its tasks times that: the 2-worker run "
        f"above ({w2[2]} tasks of ~{n / w2[2]:.1f} cases) spent ~{w2[2] * overhead:.2f} s of "
        f"its {w2[0]:.1f} s on it ({100 * w2[2] * overhead / w2[0]:.2f} %), "
        f"{overhead / (n / w2[2]) * 1e3:.3f} ms per case against {per_case * 1e3:.0f} ms of "
        "work.", "",
        "**A Robot on the wire** (pickled as its model data, `Robot.__reduce__`; the kernels "
        "load from the receiving machine's numba cache):", "",
        "| robot | kind | pickle size | unpickle time |", "| --- | --- | ---: | ---: |"]
    lines += [f"| {name} | {kind} | {size / 1024:.1f} kB | {t * 1e6:.0f} us |"
              for name, kind, size, t in rows]
    machines, cores = 100, 32
    slots = machines * cores
    sched_rate = 1.0 / overhead                  # tasks/s, taking the whole cost as its own
    task_s = 4 * slots * overhead                # tasks that keep the scheduler <= 25 % busy
    per_task = max(1, int(round(task_s / per_case)))
    lines += [
        "", f"**Paper plan: {machines} machines** (assumed {cores} cores each, one worker "
        f"process per core: {slots} workers; cores as fast as these). From the numbers above:",
        "",
        f"- The scheduler is one process: at {overhead * 1e3:.2f} ms a task (taken as all "
        f"its own, a bound) it serves ~{sched_rate:,.0f} tasks/s. {slots} workers on tasks "
        f"of T seconds ask {slots}/T tasks/s, so T must be well above "
        f"{slots * overhead:.1f} s: **tasks of ~{task_s:.0f} s** ({per_task} of these cases, "
        f"`chunk_size={per_task}`) keep it at most 25 % busy. `sweep.run`'s default (4 tasks "
        "per worker) gives such tasks only for a large enough sweep: pass `chunk_size`.",
    ]
    lines += ["", "| cases | work | per worker | tasks | wall time (work + a task's tail + 10 s start-up) "
              "| throughput |", "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for total in (1_000_000, 10_000_000, 100_000_000):
        w = total * per_case / slots
        tasks = -(-total // per_task)
        wall = w + task_s + 10.0                 # + the last task's tail, + start-up
        lines.append(f"| {total:,} | {total * per_case / 3600:,.0f} core-h | {w:,.0f} s | "
                     f"{tasks:,} | {wall / 60:,.1f} min | {total / wall:,.0f} cases/s |")
    lines += [
        "",
        f"- Expected throughput: {slots} / {per_case * 1e3:.0f} ms = {slots / per_case:,.0f} "
        "cases/s at best; a sweep shorter than a few tasks per worker (a million cases here: "
        f"{1e6 * per_case / slots:.0f} s per worker) is dominated by the tail and the start-up "
        "(each worker loads the numba cache once, a few seconds: ship the cache with the "
        "image, or let the first task fill it). 100 machines pay off from ~10 million cases.",
        "- What limits it: the cores (the work is compute-bound, the cases independent); then "
        "the scheduler if tasks are short (above); the results flowing back to the client "
        f"({row_bytes:.0f} bytes a case in memory: {1e7 * row_bytes / 1e9:.1f} GB for 10 "
        "million, so write them per block, e.g. one `sweep.run` per million cases, each to "
        "its Parquet file); a lost worker costs at most one task of rework.",
    ]
    write_section("sweep", "\n".join(lines))


if __name__ == "__main__":
    main()
