"""Fill the numba cache with every compiled kernel, on two cores.

    python -m serial_dynamics.precompile        # or: python -m serial_dynamics.core

Every entry point of the compiled core (``core.K``) and the simulator's whole-run loop
(``sim.compiled_euler``) is compiled once per machine and source version, then loaded from the
cache (``core/cache.py``: a folder per version of the sources) in milliseconds. Numba
compiles one function at a time in a process, so ``precompile(jobs=2)`` starts a second process that compiles one half of them
while this one compiles the other half, then loads that half from the cache it filled.
Run it after installing (a container build, a CI cache step); the nodes' ``warmup()``
then only loads. It first removes the cache folders of other source versions
(``core.cache.prune``: each version of the sources has its own folder; importing the
package never deletes one). ``precompile(names=...)`` compiles some of them the same way (the demo:
the single-state kernels its nodes run, ``Robot.kernels()``).
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from contextlib import contextmanager

from .core import ENTRY_POINTS, K
from .core.cache import prune
from .sim.compiled_euler import _loop

# two halves of about equal cold-compile time (bench/BENCHMARKS.md, *First call*): the
# dynamics kernels as listed, then the others alternating between the halves
# (measured 2026-11-23, each half alone on an empty cache: 19.9 s and 20.4 s)
HALVES = (("fd", "fd_batch", "compiled_euler", "planar_rnea_batch", "planar_crba",
           "planar_crba_batch"),
          ("rnea", "rnea_wrench", "crba", "rnea_batch", "crba_batch", "planar_rnea",
           "planar_rnea_wrench"))
_REST = sorted(set(ENTRY_POINTS) - set(HALVES[0] + HALVES[1]))
HALVES = (HALVES[0] + tuple(_REST[0::2]), HALVES[1] + tuple(_REST[1::2]))


def load(names):
    """Compile, or load from the cache, the kernels ``names`` ("compiled_euler": the simulator's whole-run loop)."""
    for name in names:
        _loop() if name == "compiled_euler" else getattr(K, name)


def precompile(jobs=2, names=None):
    """Every kernel (or those ``names``), compiled by ``jobs`` (1 or 2) processes into the
    cache and loaded here. Returns the seconds it took."""
    t0 = time.perf_counter()
    other, mine = HALVES if names is None else (tuple(k for k in half if k in set(names))
                                                 for half in HALVES)
    helper = (subprocess.Popen([sys.executable, "-m", "serial_dynamics.precompile", "--only",
                                ",".join(other)]) if jobs > 1 and other and mine else None)
    load(mine)
    if helper is not None and helper.wait() != 0:
        raise RuntimeError(f"the process compiling {other} failed (exit {helper.returncode})")
    load(other)                          # from the cache the helper filled (jobs=2)
    return time.perf_counter() - t0


@contextmanager
def ticking(log, what, first=1.0, every=3.0):
    """While the block runs, ``log`` ``what`` with the seconds spent, after ``first``
    seconds and then every ``every`` (nothing when the block is quick: a warm cache)."""
    done, t0 = threading.Event(), time.monotonic()

    def tick():
        wait = first
        while not done.wait(wait):
            log(f"{what}: {time.monotonic() - t0:.0f} s ...")
            wait = every

    thread = threading.Thread(target=tick, name="ticking", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--only"]:
        load(argv[1].split(","))
        return
    jobs = 1 if argv[:1] == ["--serial"] else 2
    for gone in prune():
        print(f"removed {gone} (the cache of other sources)")
    seconds = precompile(jobs)
    print(f"compiled or loaded {len(ENTRY_POINTS) + 1} kernels in {seconds:.1f} s")


if __name__ == "__main__":
    main()
