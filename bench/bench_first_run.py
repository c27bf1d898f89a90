"""A newcomer's first run (issue 22, item 7): the README's demo on an empty numba cache.

    python bench/bench_first_run.py            # writes the "first_run" section of BENCHMARKS.md
    python bench/bench_first_run.py --no-demo  # only the compile step, without ROS

Rows: (1) the demo's compile step alone, in a fresh process on an empty cache
(``NUMBA_CACHE_DIR`` a new temporary directory): ``precompile(jobs=2, names=robot.kernels())``,
the single-state kernels its nodes run, against ``precompile(jobs=2)``, every kernel, which
is what the demo compiled before; (2) the whole ``serial-dynamics demo`` on an empty cache
and again on the cache it filled: the compile time it prints, the seconds until the
nodes are up, the whole run, and the CPU seconds of the process and its children. Wall
times depend on what else runs on the machine: the load average is given with each row.
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from _report import stamp, write_section                       # noqa: E402

COMPILE = """
import resource, sys, time
import serial_dynamics as sd
from serial_dynamics.precompile import precompile
names = sd.default_robot().kernels() if sys.argv[1] == "demo" else None
t = time.perf_counter()
precompile(jobs=2, names=names)
wall = time.perf_counter() - t
cpu = sum(getattr(resource.getrusage(who), f) for who in
          (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN) for f in ("ru_utime", "ru_stime"))
print(wall, cpu)
"""


def compile_step(which):
    """(wall s, CPU s of the process and its helper, load average) of the compile step."""
    with tempfile.TemporaryDirectory() as cache:
        load = os.getloadavg()[0]
        out = subprocess.run([sys.executable, "-c", COMPILE, which], check=True, text=True,
                             capture_output=True, env={**os.environ, "NUMBA_CACHE_DIR": cache})
    wall, cpu = map(float, out.stdout.split())
    return wall, cpu, load


def demo_run(cache):
    """The README's demo with ``cache`` as numba's cache: (compile s it prints or 0, s until
    the nodes are up, whole run s, CPU s of it and its children, load average)."""
    exe = os.path.join(os.path.dirname(sys.executable), "serial-dynamics")
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen([exe, "demo"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, env={**os.environ, "NUMBA_CACHE_DIR": cache,
                                            "PYTHONUNBUFFERED": "1"})
    compiled, up = 0.0, None
    for line in proc.stdout:
        print("   ", line.rstrip(), flush=True)
        m = re.search(r"compiled the numerical kernels in (\d+) s", line)
        if m:
            compiled = float(m.group(1))
        if up is None and "nodes up" in line:
            up = time.perf_counter() - t0
    if proc.wait() != 0:
        raise RuntimeError(f"the demo failed (exit {proc.returncode})")
    whole = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = sum(getattr(after, f) - getattr(before, f) for f in ("ru_utime", "ru_stime"))
    return compiled, up, whole, cpu, load


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-demo", action="store_true", help="only the compile step")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    L = ["## Cold first run of the demo", "", stamp(),
         "Regenerate with `python bench/bench_first_run.py` (a few minutes). An empty numba "
         "cache: `NUMBA_CACHE_DIR` set to a new temporary directory. CPU: user + system "
         "seconds of the process and its children (the second compiling process; the "
         "nodes). Wall times grow with the machine's load (1-minute load average given; 2 "
         "cores).", "",
         "| what | wall | CPU | load average |", "|---|---:|---:|---:|"]
    for which, label in (("demo", "compile step of the demo: the single-state kernels its "
                                  "nodes run (`robot.kernels()`), two processes"),
                         ("all", "compile step of the demo before: every kernel "
                                 "(`precompile(jobs=2)`), two processes")):
        wall, cpu, load = compile_step(which)
        print(f"{label}: {wall:.1f} s wall, {cpu:.1f} s CPU (load {load:.1f})", flush=True)
        L.append(f"| {label} | {wall:.1f} s | {cpu:.1f} s | {load:.1f} |")
    if not args.no_demo:
        with tempfile.TemporaryDirectory() as cache:
            for label in ("cold", "warm"):
                compiled, up, whole, cpu, load = demo_run(cache)
                L.append(f"| `serial-dynamics demo`, {label} cache: compiling {compiled:.0f} s "
                         f"(as it prints), nodes up after {up:.1f} s, whole run | {whole:.1f} s "
                         f"| {cpu:.1f} s | {load:.1f} |")
                print(L[-1], flush=True)
    L += ["", "The demo compiles what its nodes run (inverse dynamics with and without a "
          "wrench, the mass matrix, forward dynamics: single states), on two cores, with a "
          "progress line every 3 s while it waits; the nodes then load them from the cache. "
          "Batch, derivative, regressor, planar and energy kernels compile on first use "
          "(`Robot.warmup(batch=True)` or `python -m serial_dynamics.precompile` for all)."]
    text = "\n".join(L)
    print(text)
    if not args.no_write:
        write_section("first_run", text)


if __name__ == "__main__":
    main()
