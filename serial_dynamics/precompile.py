"""Fill the numba cache with every compiled kernel, on two cores.

    python -m serial_dynamics.precompile        # or: python -m serial_dynamics.core

Every entry point of the compiled core (``core.K``), the simulator's whole-run loop
(``sim.compiled_euler``), constrained forward dynamics (``contacts.compiled``) and the step
with a ground and its run (``contacts.compiled_step``) are compiled once per machine and
source version, then loaded from the cache (``core/cache.py``: a folder per version of the
sources) in milliseconds. Numba compiles one function at a time in a process, so
``precompile(jobs=2)`` starts a second process; the two walk one list of the kernels (``ORDER``) from its two ends, each claiming a
kernel before compiling it (an empty file made with O_EXCL in a shared folder: one process
gets it), until they meet, so that they finish together whatever each kernel costs on this
machine; this process then loads the other's from the cache it filled.
Run it after installing (a container build, a CI cache step); the nodes' ``warmup()``
then only loads. It first removes the cache folders of other source versions
(``core.cache.prune``: each version of the sources has its own folder; importing the
package never deletes one). ``precompile(names=...)`` compiles some of them the same way (the demo:
the single-state kernels its nodes run, ``Robot.kernels()``).
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager

from .core import ENTRY_POINTS, K
from .core.cache import prune
from .sim.compiled_euler import _loop

# the other process walks ORDER from the front (the forward-dynamics kernels first), this one
# from the back (inverse dynamics and the mass matrix first); the rest alternate between the
# ends, so that the costly kernels of each kind are spread over both processes
_FRONT = ("fd", "fd_batch", "compiled_euler", "planar_rnea_batch", "planar_crba",
          "planar_crba_batch")
_BACK = ("rnea", "rnea_wrench", "crba", "rnea_batch", "crba_batch", "planar_rnea",
         "planar_rnea_wrench")
# contacts/compiled.py's constrained forward dynamics, one kernel per kind of robot, and
# compiled_step.py's step with a ground and its whole run ("ground_<kind>": both, the run
# calling the step, so one process compiles them)
CONTACTS = ("constrained_chain", "constrained_tree", "constrained_floating",
            "constrained_floating_tree", "ground_chain", "ground_tree", "ground_floating",
            "ground_floating_tree")
_REST = sorted(set(ENTRY_POINTS) - set(_FRONT + _BACK)) + list(CONTACTS)
ORDER = _FRONT + tuple(_REST[0::2]) + tuple(reversed(_REST[1::2])) + tuple(reversed(_BACK))


def load(names):
    """Compile, or load from the cache, the kernels ``names`` ("compiled_euler": the
    simulator's whole-run loop; CONTACTS: constrained forward dynamics, the step with a
    ground and its run)."""
    for name in names:
        if name == "compiled_euler":
            _loop()
        elif name.startswith("ground_"):
            from .contacts.compiled_step import kernel
            kind = name.removeprefix("ground_")
            kernel(f"ground_step_{kind}")
            kernel(f"ground_run_{kind}")
        elif name in CONTACTS:
            from .contacts.compiled import kernel
            kernel(name.removeprefix("constrained_"))
        else:
            getattr(K, name)


def claim_and_load(names, claims):
    """``load`` each of ``names`` that no other process has claimed in the folder ``claims``
    (claimed by making the file ``claims/<name>``; O_EXCL: exactly one process succeeds)."""
    mine = []
    for name in names:
        try:
            os.close(os.open(os.path.join(claims, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            continue
        load([name])
        mine.append(name)
    return mine


def precompile(jobs=2, names=None):
    """Every kernel (or those ``names``), compiled by ``jobs`` (1 or 2) processes into the
    cache and loaded here. Returns the seconds it took."""
    t0 = time.perf_counter()
    order = ORDER if names is None else tuple(k for k in ORDER if k in set(names))
    if jobs > 1 and len(order) > 1:
        with tempfile.TemporaryDirectory(prefix="serial_dynamics-precompile-") as claims:
            helper = subprocess.Popen([sys.executable, "-m", "serial_dynamics.precompile",
                                       "--claim", claims, ",".join(order)])
            claim_and_load(order[::-1], claims)
            if helper.wait() != 0:
                raise RuntimeError(f"the process compiling the kernels {order} from the front "
                                   f"failed (exit {helper.returncode})")
    load(order)                          # the other process's, from the cache it filled
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
    if argv[:1] == ["--claim"]:            # the second process of precompile(jobs=2)
        claim_and_load(argv[2].split(","), argv[1])
        return
    jobs = 1 if argv[:1] == ["--serial"] else 2
    for gone in prune():
        print(f"removed {gone} (the cache of other sources)")
    seconds = precompile(jobs)
    print(f"compiled or loaded {len(ORDER)} kernels in {seconds:.1f} s")


if __name__ == "__main__":
    main()
