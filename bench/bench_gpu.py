"""Batches on a GPU (``serial_dynamics.gpu``) against the CPU batch of the same machine, in
one run: nanoseconds per state.

    python bench/bench_gpu.py            # writes the 'gpu' section of BENCHMARKS.md
    python bench/bench_gpu.py --quick    # smaller batches, nothing written

Rows, for the default robot (UR5e, 6 joints), float64, N random states:

- CPU: ``robot.inverse_dynamics`` / ``mass_matrix`` / ``forward_dynamics`` on an (N, 6)
  batch (the facade's default split over the cores), the median of ``ROUNDS``;
- GPU, device arrays in and out (no host transfer; synchronized after the call), and
  NumPy in, NumPy out (one transfer each way), the median of ``ROUNDS`` after a warm-up
  call (kernel compiled); the ratio CPU / GPU;
- the memory bound of each call: the bytes it must read and write a state over the
  card's copy bandwidth, measured here by a device-to-device copy;
- float32: no float32 kernel is offered yet (the issue asks for one only with its
  measured error beside its speed), so no line.

Without a card (or in numba's simulator, NUMBA_ENABLE_CUDASIM=1) it says so, times the
CPU rows only and writes them with "GPU: not measured".
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import serial_dynamics as sd                                        # noqa: E402
from _report import stamp, write_section                           # noqa: E402

ROUNDS = 5


def median_ns(fn, n_states, rounds=ROUNDS):
    fn()                                        # warm: compile, allocate
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1e9 * float(np.median(times)) / n_states


def card():
    """(gpu module, the card's name) or (None, why not)."""
    try:
        from serial_dynamics import gpu
        from serial_dynamics.gpu.runtime import cuda
    except ImportError as exc:
        return None, f"no numba-cuda ({exc})"
    if gpu.SIMULATOR:
        return None, "numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1), not a card"
    if not cuda.is_available():
        return None, "no CUDA card visible"
    return gpu, cuda.get_current_device().name.decode() if isinstance(
        cuda.get_current_device().name, bytes) else str(cuda.get_current_device().name)


def copy_bandwidth(cuda, nbytes=1 << 30):
    """Bytes per second of a device-to-device copy (read + write counted)."""
    a = cuda.device_array(nbytes // 8)
    b = cuda.device_array(nbytes // 8)
    b.copy_to_device(a)
    cuda.synchronize()
    t = time.perf_counter()
    for _ in range(5):
        b.copy_to_device(a)
    cuda.synchronize()
    return 2 * 5 * nbytes / (time.perf_counter() - t)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    robot = sd.default_robot()
    n = robot.dof
    N_cpu = 1 << (14 if args.quick else 17)
    rng = np.random.default_rng(0)
    gpu, where = card()
    print(f"GPU: {where if gpu else 'none: ' + where}")

    calls = {   # name: (CPU call of a batch, GPU call, numbers read and written a state)
        "inverse_dynamics": (lambda q, qd, x: robot.inverse_dynamics(q, qd, x),
                             lambda g, q, qd, x: g.inverse_dynamics(robot, q, qd, x), 4 * n),
        "mass_matrix": (lambda q, qd, x: robot.mass_matrix(q),
                        lambda g, q, qd, x: g.mass_matrix(robot, q), n + n * n),
        "forward_dynamics": (lambda q, qd, x: robot.forward_dynamics(q, qd, x),
                             lambda g, q, qd, x: g.forward_dynamics(robot, q, qd, x), 4 * n),
        "inverse_dynamics_derivatives": (
            lambda q, qd, x: robot.inverse_dynamics_derivatives(q, qd, x),
            lambda g, q, qd, x: g.inverse_dynamics_derivatives(robot, q, qd, x), 3 * n + 2 * n * n),
    }
    q, qd = robot.random_state(rng, batch=N_cpu)
    x = rng.uniform(-1, 1, q.shape)
    cpu = {name: median_ns(lambda c=c: c(q, qd, x), N_cpu) for name, (c, _, _) in calls.items()}

    rows = []
    if gpu is None:
        for name in calls:
            rows.append(f"| {name} | {cpu[name]:.0f} | not measured | not measured | – | – |")
        note = (f"**GPU: not measured** ({where}). The CPU rows are this machine's batch "
                f"({N_cpu} states); the GPU rows need a CUDA card.")
    else:
        from serial_dynamics.gpu.runtime import cuda
        N = 1 << (18 if args.quick else 22)
        qg, qdg = robot.random_state(rng, batch=N)
        xg = rng.uniform(-1, 1, qg.shape)
        dq, dqd, dx = cuda.to_device(qg), cuda.to_device(qdg), cuda.to_device(xg)
        bw = copy_bandwidth(cuda)
        for name, (_, g, numbers) in calls.items():
            def on_card(g=g):
                g(gpu, dq, dqd, dx)
                cuda.synchronize()
            dev = median_ns(on_card, N)
            host = median_ns(lambda g=g: g(gpu, qg, qdg, xg), N)
            bound = 8 * numbers / bw * 1e9
            rows.append(f"| {name} | {cpu[name]:.0f} | {dev:.2f} | {host:.2f} | "
                        f"{cpu[name] / dev:.0f}x | {bound:.3f} ({dev / bound:.0f}x) |")
        note = (f"GPU: {where}, {N} states a call (CPU: {N_cpu}); copy bandwidth measured "
                f"{bw / 1e12:.2f} TB/s. float32: no kernel offered yet, no line.")
    table = ("| call (UR5e, float64) | CPU batch ns/state | GPU, device arrays ns/state | "
             "GPU, NumPy in/out ns/state | CPU / GPU (device) | memory bound ns/state (GPU / bound) |\n"
             "|---|---:|---:|---:|---:|---:|\n" + "\n".join(rows))
    body = f"## Batches on a GPU (`bench/bench_gpu.py`)\n\n{stamp()}\n{note}\n\n{table}\n"
    print(body)
    if not args.quick:
        write_section("gpu", body)


if __name__ == "__main__":
    main()
