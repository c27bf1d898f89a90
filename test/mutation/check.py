"""Mutation check: plant known bugs, one at a time, and make sure the tests catch each.

Each mutation is one exact text replacement in one source file of ``serial_dynamics``
(the bugs of issue 13 and a few more). For each, the package is copied to a temporary
directory, the bug is planted in the copy, and the mutation's test files run with that
copy first on ``sys.path`` (PYTHONPATH, and the working directory: the node processes of
the ROS tests start with ``python -m`` there) and a numba cache of its own (NUMBA_CACHE_DIR
in the temporary directory: the compiled kernels are built from the mutated source, not
loaded from the repository's cache). A mutation is *caught* when pytest fails (exit 1).

    .venv/bin/python test/mutation/check.py            # every mutation (several minutes)
    .venv/bin/python test/mutation/check.py --list     # what each one plants
    .venv/bin/python test/mutation/check.py stribeck_breakaway_ignores_eps ...

Exit status 0 when every mutation was caught, 1 when one was missed (or its run did not
work: a patch that no longer applies, pytest errors other than failing tests), 2 when the
unmutated baseline fails. Not collected by pytest (see conftest.py here): it is slow.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]          # the repository
PACKAGE = "serial_dynamics"


@dataclass(frozen=True)
class Mutation:
    name: str
    what: str
    path: str          # source file, relative to the package
    old: str           # exact text, found once
    new: str
    tests: tuple       # test files or node ids, relative to the repository
    pytest_args: tuple = ()


MUTATIONS = (
    Mutation(
        "stribeck_breakaway_ignores_eps",
        "stick-slip: a joint at rest breaks away once its holding torque exceeds the Coulomb "
        "friction tau_c, ignoring the Stribeck part eps of the static friction tau_c + eps",
        "sim/equations.py",
        "np.abs(delta) / np.where(self.coulomb, self.tau_s, 1.0)",
        "np.abs(delta) / np.where(self.coulomb, self.diss.coulomb, 1.0)",
        ("test/sim/test_simulate.py",)),
    Mutation(
        "fast_path_skips_stops",
        "FixedStepIntegrator.step: the real-time fast path (semi-implicit Euler without "
        "Coulomb friction) skips the joint stops after the step",
        "sim/fixed_step.py",
        "            if self.stops:\n"
        "                q_new, qd_new, _ = self.stops.impact(q_new, qd_new, False)\n",
        "",
        ("test/sim/test_stops.py", "test/ros/test_simulator.py")),
    Mutation(
        "coriolis_sign_flip",
        "compiled Newton-Euler (single state; the Cholesky forward route uses it): the sign "
        "of the omega x (qd e_z) term of the angular acceleration flipped",
        "core/rnea.py",
        "ax, ay, az = ax + wy * dq, ay - wx * dq, az + ddq",
        "ax, ay, az = ax - wy * dq, ay + wx * dq, az + ddq",
        ("test/oracles/test_identities.py", "test/algorithms/test_aba.py", "test/core/test_kernels.py")),
    Mutation(
        "armature_dropped",
        "compiled composite-rigid-body mass matrix: the armature left off the diagonal of "
        "the revolute joints",
        "core/crba.py",
        "M[i, i] = nz + P[i, ARM]",
        "M[i, i] = nz",
        ("test/robot/test_armature.py",)),
    Mutation(
        "tip_wrench_sign",
        "compiled Newton-Euler (single state): the tip wrench read with the wrong sign",
        "core/rnea.py",
        "ex, ey, ez, mx, my, mz = w[0], w[1], w[2], w[3], w[4], w[5]",
        "ex, ey, ez, mx, my, mz = -w[0], -w[1], -w[2], -w[3], -w[4], -w[5]",
        ("test/oracles/test_identities.py", "test/sim/test_simulate.py")),
    Mutation(
        "impact_without_coupling",
        "joint stops: the plastic impact stops the joint but passes no impulse to the other "
        "joints (qd+_F = qd-_F instead of qd-_F + M_FF^-1 M_FS qd-_S)",
        "sim/stops.py",
        "                if free.any():\n"
        "                    v[free] += np.linalg.solve(M[np.ix_(free, free)],\n"
        "                                               M[np.ix_(free, stopped)] @ qd[stopped])\n",
        "",
        ("test/sim/test_stops.py",)),
    Mutation(
        "node_clock_without_integration",
        "simulator node: simulated time (/clock, the stamps) advances but the state is not "
        "integrated",
        "sim/session.py",
        "self.q, self.qd, self.k = q, qd, self.k + 1",
        "self.k = self.k + 1",
        ("test/ros/test_simulator.py",), ("-x",)),    # -x: the other tests would wait 90 s
)


def copy_package(dest: Path) -> Path:
    """The package copied into ``dest`` (no bytecode, no numba cache)."""
    target = dest / PACKAGE
    shutil.copytree(ROOT / PACKAGE, target,
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc"))
    return target


def plant(package: Path, m: Mutation):
    path = package / m.path
    text = path.read_text()
    found = text.count(m.old)
    if found != 1:
        raise RuntimeError(f"mutation {m.name}: the text to replace occurs {found} times in "
                           f"{PACKAGE}/{m.path} (expected once); update check.py")
    path.write_text(text.replace(m.old, m.new))


def environment(tmp: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(tmp)] + ([env["PYTHONPATH"]]
                                                      if env.get("PYTHONPATH") else []))
    env["NUMBA_CACHE_DIR"] = str(tmp / "numba_cache")
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    env.pop("SERIAL_DYNAMICS_BACKEND", None)
    return env


def run_tests(tests, mutation: Mutation | None, timeout: float, pytest_args=()):
    """(exit status, failed test ids, seconds, log) of pytest on ``tests`` against a copy
    of the package with ``mutation`` planted (None: unmutated)."""
    with tempfile.TemporaryDirectory(prefix="sd-mutation-") as name:
        tmp = Path(name)
        package = copy_package(tmp)
        if mutation is not None:
            plant(package, mutation)
        env = environment(tmp)
        probe = f"import {PACKAGE}; print({PACKAGE}.__file__)"
        where = subprocess.run([sys.executable, "-c", probe], cwd=tmp, env=env,
                               capture_output=True, text=True)
        if not where.stdout.strip().startswith(str(package)):
            raise RuntimeError("the copy is not the package imported: "
                               + where.stdout + where.stderr)
        cmd = [sys.executable, "-m", "pytest", "-q", "-rf", "-p", "no:cacheprovider",
               "--rootdir", str(ROOT), "-c", str(ROOT / "setup.cfg"), *pytest_args,
               *[str(ROOT / t) for t in tests]]
        t = time.monotonic()
        try:
            out = subprocess.run(cmd, cwd=tmp, env=env, capture_output=True, text=True,
                                 timeout=timeout)
            rc, log = out.returncode, out.stdout + out.stderr
        except subprocess.TimeoutExpired as exc:
            rc, log = -1, f"timed out after {timeout} s\n{exc.stdout or ''}"
        failed = [os.path.relpath(os.path.normpath(tmp / f.split("::")[0]), ROOT) + "::"
                  + f.split("::", 1)[1] for f in re.findall(r"^FAILED (\S+::\S+)", log, flags=re.M)]
        return rc, failed, time.monotonic() - t, log


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("names", nargs="*", help="mutations to run (default: all)")
    p.add_argument("--list", action="store_true", help="list the mutations and exit")
    p.add_argument("--no-baseline", action="store_true",
                   help="skip the run of the unmutated copy (it must pass)")
    p.add_argument("--timeout", type=float, default=1800.0, help="s per pytest run")
    p.add_argument("-v", "--verbose", action="store_true", help="print pytest's output")
    args = p.parse_args(argv)
    if args.list:
        for m in MUTATIONS:
            print(f"{m.name}\n    {m.what}\n    {PACKAGE}/{m.path}; tests: {', '.join(m.tests)}")
        return 0
    known = {m.name: m for m in MUTATIONS}
    unknown = [n for n in args.names if n not in known]
    if unknown:
        p.error(f"unknown mutation(s) {unknown}; see --list")
    chosen = [known[n] for n in args.names] if args.names else list(MUTATIONS)

    if not args.no_baseline:
        tests = tuple(dict.fromkeys(t for m in chosen for t in m.tests))
        rc, failed, secs, log = run_tests(tests, None, args.timeout)
        print(f"baseline (unmutated copy): pytest exit {rc} in {secs:.0f} s", flush=True)
        if rc != 0:
            print(log)
            print("the unmutated copy must pass its tests first", file=sys.stderr)
            return 2

    results = []
    for m in chosen:
        rc, failed, secs, log = run_tests(m.tests, m, args.timeout, m.pytest_args)
        if rc == 1:
            verdict = f"CAUGHT  ({len(failed)} failed)"
        elif rc == 0:
            verdict = "MISSED"
        else:
            verdict = f"ERROR   (pytest exit {rc})"
        results.append((m, rc))
        print(f"{m.name:<34} {verdict}  [{secs:.0f} s]", flush=True)
        for test in failed[:8]:
            print(f"    {test}")
        if len(failed) > 8:
            print(f"    ... and {len(failed) - 8} more")
        if args.verbose or rc not in (0, 1):
            print(log)
    missed = [m.name for m, rc in results if rc != 1]
    print(f"\n{len(results) - len(missed)} of {len(results)} mutations caught"
          + (f"; not caught: {', '.join(missed)}" if missed else ""))
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
