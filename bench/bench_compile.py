"""What each kernel costs to compile from an empty numba cache (issue 50: every kernel in
60 CPU-seconds or less; `python -m serial_dynamics.precompile` takes over 1,000 today).

    python bench/bench_compile.py [--jobs 2] [--only NAME ...] [--no-write]

Each kernel of ``precompile.ORDER`` is compiled in a process of its own with an empty
``NUMBA_CACHE_DIR``; the CPU time counted is the process's own (``time.process_time``)
around ``precompile.load([name])``, after the package is imported. A kernel alone compiles
every function it calls, which precompile's two processes compile once for all the
kernels that share them: the sum of the column is therefore more than precompile's total,
and the difference is what sharing saves. ``--jobs`` processes run side by side (2 on the
two cores: then each kernel's time includes some waiting for the other's memory traffic).
Writes the section "compile" of bench/BENCHMARKS.md.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from _report import stamp, write_section    # noqa: E402

CHILD = """
import sys, time
import serial_dynamics.precompile as p
t = time.process_time()
p.load([sys.argv[1]])
print(time.process_time() - t)
"""


def family(name):
    """The kernel's kind of robot or of computation, for the summary."""
    for prefix, f in (("constrained_", "contacts: constrained"), ("ground_", "contacts: ground step"),
                      ("planar_", "planar chain"), ("floating_tree_", "floating tree"),
                      ("floating_", "floating chain"), ("tree_", "tree"), ("mimic_", "mimic chain"),
                      ("frame_", "kinematics"), ("centroidal", "kinematics"),
                      ("mass_moment", "kinematics"), ("compiled_euler", "simulation loop"),
                      ("symplectic_euler", "simulation loop")):
        if name.startswith(prefix):
            return f
    return "chain"


def cost(name):
    """CPU seconds to compile ``name`` alone from an empty cache."""
    with tempfile.TemporaryDirectory(prefix="bench_compile_") as cache:
        out = subprocess.run([sys.executable, "-c", CHILD, name], capture_output=True,
                             text=True, env={**os.environ, "NUMBA_CACHE_DIR": cache})
    if out.returncode != 0:
        raise RuntimeError(f"compiling {name} failed:\n{out.stderr[-2000:]}")
    return float(out.stdout.strip().splitlines()[-1])


def main():
    from serial_dynamics.precompile import ORDER
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", nargs="*", help="these kernels (precompile.ORDER's names)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    names = [n for n in ORDER if not args.only or n in args.only]
    t0, seconds = time.monotonic(), {}
    with ThreadPoolExecutor(args.jobs) as pool:
        for name, s in zip(names, pool.map(cost, names)):
            seconds[name] = s
            print(f"{name:32s} {s:7.1f} CPU-s  ({len(seconds)}/{len(names)}, "
                  f"{time.monotonic() - t0:.0f} s)", flush=True)
    total = sum(seconds.values())
    rows = sorted(seconds.items(), key=lambda x: -x[1])
    fam = {}
    for name, s in rows:
        f = fam.setdefault(family(name), [0, 0.0])
        f[0], f[1] = f[0] + 1, f[1] + s
    load = os.getloadavg()[0]
    lines = [stamp(), "",
             f"`python bench/bench_compile.py --jobs {args.jobs}`: each of {len(names)} kernels "
             f"compiled alone in a process with an empty `NUMBA_CACHE_DIR` (CPU seconds of "
             f"that process around `precompile.load`; {args.jobs} processes side by side; "
             f"1-minute load average {load:.1f} at the end; {time.monotonic() - t0:.0f} s of "
             f"wall time). Alone, a kernel compiles every function it calls; "
             f"`python -m serial_dynamics.precompile` compiles a shared one once, so its "
             f"total is less than this sum ({total:.0f} CPU-s). Issue 50's target for the "
             f"whole cache: 60 CPU-s.", "",
             "| kernels | count | CPU-s | share |", "|---|---|---|---|"]
    for f, (count, s) in sorted(fam.items(), key=lambda x: -x[1][1]):
        lines.append(f"| {f} | {count} | {s:.0f} | {100 * s / total:.0f} % |")
    lines += [f"| all | {len(names)} | {total:.0f} | 100 % |", "",
              "The costliest twenty:", "", "| kernel | CPU-s |", "|---|---|"]
    lines += [f"| `{n}` | {s:.1f} |" for n, s in rows[:20]]
    lines += ["", f"The cheapest: `{rows[-1][0]}` {rows[-1][1]:.1f} CPU-s; the median "
              f"{rows[len(rows) // 2][1]:.1f} CPU-s."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write and not args.only:
        write_section("compile", "## Compile cost of each kernel\n\n" + text)


if __name__ == "__main__":
    main()
