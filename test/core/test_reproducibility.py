"""Identical inputs give bitwise identical outputs: in every process, whatever the numba
cache holds, and whatever was called before.

- ``test_identical_across_processes``: a helper script (``HELPER``) evaluates every public
  dynamics quantity on fixed seeded states of two robots (the embedded UR5e and
  example-robot-data's xarm7) and saves the raw arrays. It runs in (a) a process with a
  fresh, empty ``NUMBA_CACHE_DIR`` (everything compiled), (b) a second process on the same,
  now warm, cache (everything loaded), (c) a process with another fresh cache that makes
  the calls in the reverse order (batch before single, forward dynamics before inverse,
  the simulations first, xarm7 first), (d) a process in the forward order on the cache
  (c) wrote. All four outputs must be equal byte for byte;
  a mismatch names each quantity that differs, where, and by how much (absolute and ulps).
  (a) and (c) compile at the same time, started by test/conftest.py as soon as the suite
  is collected, beside the single-threaded tests at its start; the test runs last.
- ``test_same_answer_whatever_was_called_before``: in one process, a state evaluated
  alone, repeated after a history of other calls (batches, wrenches, errors, another
  robot, a simulation) and on a second Robot of the same URDF, is bitwise the same.
- ``test_batch_row_equals_single_state``: row k of a batch is bitwise the same state
  alone (it holds today; see the comment there).
- ``test_compare_catches_one_ulp``: the comparison itself, on planted 1-ulp differences.
"""
import atexit
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
import time
import warnings

import numpy as np
import pytest

import serial_dynamics as sd

ERD_ROOT = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share",
                        "example-robot-data", "robots")
# (URDF under ERD_ROOT, base_link, tip_link): the first one installed is used
SECOND_ROBOT = [("xarm_description/urdf/xarm7.urdf", "link_base", "link7"),
                ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8")]


def _second_robot():
    for rel, base, tip in SECOND_ROBOT:
        path = os.path.join(ERD_ROOT, rel)
        if os.path.isfile(path):
            return path, base, tip
    pytest.skip(f"example-robot-data is not installed (no {SECOND_ROBOT[0][0]} under {ERD_ROOT})")


# ----------------------------------------------------------------------------- helper
HELPER = r'''
"""Evaluate every public dynamics quantity on fixed states; save the raw arrays (npz).
argv: order ("forward" | "reverse"), output path, URDF path, base_link, tip_link."""
import sys
import warnings

import numpy as np

import serial_dynamics as sd

order, out_path, urdf, base, tip = sys.argv[1:6]
assert order in ("forward", "reverse"), order
N = 37          # a batch longer than one block of the batch kernels, with a short tail


def load(name):
    if name == "ur5e":
        return sd.default_robot()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # held joints off the chain (panda's fingers)
        return sd.load_urdf(urdf, base, tip)


def states(robot, seed):
    rng = np.random.default_rng(seed)
    n = robot.dof
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    return dict(q=rng.uniform(lo, hi, (N, n)), qd=rng.uniform(-2.0, 2.0, (N, n)),
                qdd=rng.uniform(-5.0, 5.0, (N, n)), tau=rng.uniform(-20.0, 20.0, (N, n)),
                w=rng.uniform(-10.0, 10.0, (N, 6)))


def tasks(name, robot, seed):
    """[(quantity, thunk)] in the forward order: single states, then batches; inverse
    dynamics first, forward dynamics last."""
    s = states(robot, seed)
    q, qd, qdd, tau, w = s["q"], s["qd"], s["qdd"], s["tau"], s["w"]
    calls = {
        "inverse_dynamics": lambda x: robot.inverse_dynamics(x(q), x(qd), x(qdd)),
        "inverse_dynamics+wrench": lambda x: robot.inverse_dynamics(x(q), x(qd), x(qdd), wrench=x(w)),
        "mass_matrix": lambda x: robot.mass_matrix(x(q)),
        "bias_torques": lambda x: robot.bias_torques(x(q), x(qd)),
        "gravity_torques": lambda x: robot.gravity_torques(x(q)),
        "forward_dynamics[cholesky]": lambda x: robot.forward_dynamics(x(q), x(qd), x(tau), method="cholesky"),
        "forward_dynamics[aba]": lambda x: robot.forward_dynamics(x(q), x(qd), x(tau), method="aba"),
        "forward_dynamics[aba]+wrench": lambda x: robot.forward_dynamics(x(q), x(qd), x(tau), wrench=x(w), method="aba"),
    }
    out = []
    for quantity, f in calls.items():      # single states: one call per state
        out.append((f"{name}/{quantity}/single",
                    lambda f=f: np.array([f(lambda a, k=k: a[k]) for k in range(N)])))
    for quantity, f in calls.items():      # one batch call
        out.append((f"{name}/{quantity}/batch", lambda f=f: f(lambda a: a)))
    return out


def simulations(name, robot):
    q0, qd0 = robot.random_state(7, speed=1.0)
    runs = [
        # adaptive: without friction (smoothed Coulomb friction makes xarm7 stiff for DOP853)
        ("DOP853", lambda: sd.simulate(robot, 0.2, q0, qd0, method="DOP853", dissipation=False,
                                       output_dt=0.01)),
        ("semi_implicit_euler", lambda: sd.simulate(robot, 0.2, q0, qd0,
                                                    method="semi_implicit_euler", dt=1e-3)),
    ]
    out = []
    for method, run in runs:
        box = {}

        def field(attr, run=run, box=box):
            if "res" not in box:
                box["res"] = run()
            return getattr(box["res"], attr)
        # t, q, qd of one run: consecutive tasks (the run happens at the first of them)
        for attr in ("t", "q", "qd"):
            out.append((f"{name}/simulate[{method}].{attr}", lambda attr=attr, field=field: field(attr)))
    return out


names = ["ur5e", "second"] if order == "forward" else ["second", "ur5e"]
robots = {name: load(name) for name in names}
plan = []
for seed, name in enumerate(("ur5e", "second")):
    plan += tasks(name, robots[name], 1000 + seed)
for name in ("ur5e", "second"):
    plan += simulations(name, robots[name])
if order == "reverse":
    # reversed as a whole: simulations first, then batches before single states, forward
    # dynamics before inverse; each simulation's t, q, qd stay together (run once)
    sims = [p for p in plan if "/simulate[" in p[0]]
    rest = [p for p in plan if "/simulate[" not in p[0]]
    groups = [sims[i:i + 3] for i in range(0, len(sims), 3)]
    plan = [p for g in groups[::-1] for p in g] + rest[::-1]
result = {}
for key, thunk in plan:
    result[key] = np.array(thunk(), dtype=np.float64)
np.savez(out_path, **result)
print(sd.__file__)
print(f"{len(result)} arrays, order {order}")
'''


def _start_helper(root, tag, order, cache_dir, second):
    """Start the helper (in the background) in ``root``; its output goes to files there,
    and its exit status to ``<tag>.rc`` when it ends (so that another process of the
    session, an xdist worker, can wait for it: ``_Run``)."""
    script = root / "reproduce.py"
    if not script.exists():
        script.write_text(HELPER)
    cache_dir.mkdir(exist_ok=True)
    # the serial_dynamics this test imported, not whichever one the script's folder finds
    src = os.path.dirname(os.path.dirname(os.path.abspath(sd.__file__)))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir),
               PYTHONPATH=os.pathsep.join([src] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    (root / f"{tag}.t0").write_text(repr(time.time()))
    with open(root / f"{tag}.out", "w") as out, open(root / f"{tag}.err", "w") as err:
        proc = subprocess.Popen(["sh", "-c", '"$0" "$@"; echo $? > "$RC"', sys.executable,
                                 str(script), order, str(root / f"{tag}.npz"), *second],
                                env=dict(env, RC=str(root / f"{tag}.rc")), stdout=out,
                                stderr=err, text=True, start_new_session=True)
    return proc


class _Run:
    """A helper started by ``_start_helper``, in this process or another of the session:
    ``wait`` for its ``<tag>.rc``; ``t0`` when it started."""

    def __init__(self, root, tag):
        self.rc, self.t0 = root / f"{tag}.rc", float((root / f"{tag}.t0").read_text())

    def wait(self, timeout):
        end = time.time() + timeout
        while not self.rc.exists() or not self.rc.read_text().strip():
            if time.time() > end:
                raise TimeoutError(f"{self.rc.name[:-3]} did not end in {timeout} s")
            time.sleep(0.5)
        return int(self.rc.read_text())


def _finish_helper(root, tag, timeout=900):
    """Wait for a helper; (its arrays, seconds from its start to its output written)."""
    run = _Run(root, tag)
    code = run.wait(timeout)
    stdout, stderr = (root / f"{tag}.out").read_text(), (root / f"{tag}.err").read_text()
    assert stdout.startswith(os.path.abspath(sd.__file__)), (stdout, sd.__file__)
    assert code == 0, f"process {tag} failed (exit {code}):\n{stderr[-4000:]}"
    elapsed = os.stat(root / f"{tag}.npz").st_mtime - run.t0
    with np.load(root / f"{tag}.npz") as data:
        return {k: data[k] for k in data.files}, elapsed


# (a) and (c) compile everything from an empty cache, a few minutes each. test/conftest.py
# starts them when the session starts (start_cold_runs: in xdist's controller, which then
# names their folder to the workers in COLD_RUNS), so that they compile beside the first
# tests, and runs this test last; a run of this file alone starts them here.
COLD_RUNS = "SERIAL_DYNAMICS_TEST_COLD_RUNS"
_EARLY = {}


def start_cold_runs():
    """Start (a) and (c), or find those another process of the session started."""
    if _EARLY:
        return
    if os.environ.get(COLD_RUNS):
        root = pathlib.Path(os.environ[COLD_RUNS])
        _EARLY.update(root=root, second=tuple(json.loads((root / "second.json").read_text())))
        return
    path, base, tip = _second_robot()
    root = pathlib.Path(tempfile.mkdtemp(prefix="reproducibility_"))
    (root / "second.json").write_text(json.dumps([path, base, tip]))
    _EARLY.update(root=root, second=(path, base, tip), procs=[
        _start_helper(root, "a_cold", "forward", root / "numba_cache_a", (path, base, tip)),
        _start_helper(root, "c_cold_reversed", "reverse", root / "numba_cache_c",
                      (path, base, tip))])
    os.environ[COLD_RUNS] = str(root)          # for the workers xdist starts after this
    atexit.register(_stop_cold_runs)


def _stop_cold_runs():
    for proc in _EARLY["procs"]:
        if proc.poll() is None:                  # the shell and the helper it runs
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    shutil.rmtree(_EARLY["root"], ignore_errors=True)


def _ulps(a, b):
    """Distance in units in the last place between float64 arrays of the same shape."""
    ia = a.view(np.int64).astype(object)
    ib = b.view(np.int64).astype(object)
    # map the sign-magnitude bit patterns to a monotonic integer line
    key = lambda i: i if i >= 0 else -(i & 0x7FFFFFFFFFFFFFFF)   # noqa: E731
    return np.array([abs(key(x) - key(y)) for x, y in zip(ia.ravel(), ib.ravel())], dtype=object)


def compare(ref, other, ref_name="a", other_name="b"):
    """[] if ``other`` equals ``ref`` byte for byte (same quantities, shapes, dtypes, bytes);
    else one line per quantity that differs, saying where and by how much."""
    problems = []
    for key in sorted(set(ref) | set(other)):
        if key not in other or key not in ref:
            problems.append(f"{key}: only in {ref_name if key in ref else other_name}")
            continue
        a, b = np.asarray(ref[key]), np.asarray(other[key])
        if a.dtype != b.dtype or a.shape != b.shape:
            problems.append(f"{key}: {ref_name} {a.dtype}{a.shape} vs {other_name} {b.dtype}{b.shape}")
            continue
        if a.tobytes() == b.tobytes():
            continue
        diff = a.view(np.uint64) != b.view(np.uint64)
        d = np.where(diff, np.abs(a - b), 0.0)
        worst = np.unravel_index(int(np.argmax(np.where(np.isnan(d), np.inf, d))), a.shape)
        where = lambda idx: tuple(int(i) for i in idx)   # noqa: E731
        ulps = _ulps(a[diff], b[diff])
        rel = d[worst] / abs(a[worst]) if a[worst] != 0 else np.inf
        problems.append(
            f"{key}: {int(diff.sum())} of {a.size} values differ (first at "
            f"{where(np.argwhere(diff)[0])}); largest |diff| {d[worst]:.3g} at {where(worst)}: "
            f"{ref_name} {float(a[worst])!r} vs {other_name} {float(b[worst])!r} "
            f"({_ulps(a[worst][None], b[worst][None])[0]} ulp, "
            f"relative {rel:.3g}); up to {max(ulps)} ulp; largest |value| {np.max(np.abs(a)):.3g}")
    return problems


def _listing(problems, limit=60):
    shown = problems[:limit]
    more = [f"... and {len(problems) - limit} more"] if len(problems) > limit else []
    return "\n  " + "\n  ".join(shown + more)


def test_compare_catches_one_ulp():
    rng = np.random.default_rng(0)
    ref = {"r/inverse_dynamics/single": rng.normal(size=(37, 6)), "r/mass_matrix/batch": rng.normal(size=(3, 6, 6))}
    same = {k: v.copy() for k, v in ref.items()}
    assert compare(ref, same) == []
    planted = {k: v.copy() for k, v in ref.items()}
    planted["r/mass_matrix/batch"][1, 2, 3] = np.nextafter(ref["r/mass_matrix/batch"][1, 2, 3], np.inf)
    (line,) = compare(ref, planted)
    assert line.startswith("r/mass_matrix/batch: 1 of 108 values differ (first at (1, 2, 3))"), line
    assert "(1 ulp, relative" in line and "up to 1 ulp" in line, line
    # signed zeros are different bits (np.array_equal would call them equal)
    zero = {"z": np.array([0.0])}
    (line,) = compare(zero, {"z": np.array([-0.0])})
    assert line.startswith("z: 1 of 1 values differ"), line
    # the same NaN is the same bits; a missing or reshaped quantity is reported
    assert compare({"n": np.array([np.nan])}, {"n": np.array([np.nan])}) == []
    assert compare(ref, {"r/inverse_dynamics/single": ref["r/inverse_dynamics/single"]}) == [
        "r/mass_matrix/batch: only in a"]
    assert compare({"x": np.zeros(3)}, {"x": np.zeros((1, 3))}) == ["x: a float64(3,) vs b float64(1, 3)"]


def test_identical_across_processes():
    start_cold_runs()                    # a no-op when conftest.py started them
    root, second = _EARLY["root"], _EARLY["second"]
    cold_a, cold_c = root / "numba_cache_a", root / "numba_cache_c"
    (a, ta), (c, tc) = _finish_helper(root, "a_cold"), _finish_helper(root, "c_cold_reversed")
    cached = sorted(f for _, _, fs in os.walk(cold_a) for f in fs)
    assert any(f.endswith(".nbi") for f in cached), \
        f"process (a) left no index in NUMBA_CACHE_DIR={cold_a}: (b) would not test a warm cache"
    snapshot = {os.path.join(dirpath, f): os.stat(os.path.join(dirpath, f)).st_mtime_ns
                for dirpath, _, fs in os.walk(cold_a) for f in fs}
    # (b): the same order on the cache (a) filled; (d): the same order on the cache (c)
    # filled in the reverse order (so each kernel was first compiled for another caller);
    # each on its own cache: side by side
    started = (_start_helper(root, "b_warm", "forward", cold_a, second),
               _start_helper(root, "d_warm_from_reversed", "forward", cold_c, second))
    (b, tb), (d, td) = (_finish_helper(root, "b_warm"),
                        _finish_helper(root, "d_warm_from_reversed"))
    for proc in started:
        proc.wait()
    recompiled = sorted(os.path.relpath(p, cold_a) for dirpath, _, fs in os.walk(cold_a)
                        for f in fs for p in [os.path.join(dirpath, f)]
                        if snapshot.get(p) != os.stat(p).st_mtime_ns)
    print(f"(a) cold {ta:.1f} s, (c) cold reversed {tc:.1f} s (concurrently), (b) warm {tb:.1f} s, "
          f"(d) warm from (c) {td:.1f} s; "
          f"{len(a)} quantities; cache entries {len(cached)}; rewritten by (b): {recompiled}")
    assert len(a) >= 40, sorted(a)
    problems = []
    for name, other in (("b (warm cache)", b), ("c (fresh cache, reversed order)", c),
                        ("d (cache written by c)", d)):
        problems += [f"[a (fresh cache) vs {name}] {p}" for p in compare(a, other, "a", name[0])]
    assert not problems, (f"outputs are not bitwise identical across processes "
                          f"({len(problems)} quantities differ; robots ur5e and "
                          f"'second' = {os.path.basename(path)} {base} -> {tip}):"
                          + _listing(problems))


# ----------------------------------------------------------------------------- in-process
def _robots():
    path, base, tip = _second_robot()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        second = sd.load_urdf(path, base, tip)
    return {"ur5e": sd.default_robot(), os.path.basename(path)[:-5]: second}, (path, base, tip)


def _quantities(robot, q, qd, qdd, tau, w):
    """Every public quantity at one state (or batch) -> {name: array}."""
    return {
        "inverse_dynamics": robot.inverse_dynamics(q, qd, qdd),
        "inverse_dynamics+wrench": robot.inverse_dynamics(q, qd, qdd, wrench=w),
        "mass_matrix": robot.mass_matrix(q),
        "bias_torques": robot.bias_torques(q, qd),
        "gravity_torques": robot.gravity_torques(q),
        "forward_dynamics[cholesky]": robot.forward_dynamics(q, qd, tau, method="cholesky"),
        "forward_dynamics[aba]": robot.forward_dynamics(q, qd, tau, method="aba"),
        "forward_dynamics[aba]+wrench": robot.forward_dynamics(q, qd, tau, wrench=w, method="aba"),
    }


def _batch(robot, seed, N=37):
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, batch=N, speed=2.0)
    return (q, qd, rng.uniform(-5, 5, (N, robot.dof)), rng.uniform(-20, 20, (N, robot.dof)),
            rng.uniform(-10, 10, (N, 6)))


def _row(args, k):
    return tuple(np.ascontiguousarray(a[k]) for a in args)


def _history(robots, urdf):
    """Other calls that leave state behind if anything does: other states and batches,
    wrenches (single calls keep the wrench in the robot's scratch memory), rejected
    inputs, ``out=``, lists, another robot, simulations."""
    for name, robot in robots.items():
        args = _batch(robot, 99)
        _quantities(robot, *args)
        for k in (0, 3, 36):
            _quantities(robot, *_row(args, k))
        n = robot.dof
        robot.inverse_dynamics(args[0][1], args[1][1], args[2][1], wrench=np.full(6, 1e3))
        bad = args[0][2].copy()
        bad[0] = np.nan
        for call in (lambda: robot.inverse_dynamics(bad, bad, bad),
                     lambda: robot.forward_dynamics(bad, bad, bad, method="aba"),
                     lambda: robot.mass_matrix(np.full(n, np.inf)),
                     lambda: robot.inverse_dynamics(np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1))):
            with pytest.raises(ValueError):
                call()
        robot.inverse_dynamics(list(args[0][4]), list(args[1][4]), list(args[2][4]))
        robot.mass_matrix(args[0][5], out=np.empty((n, n)))
        robot.forward_dynamics(args[0][:5], args[1][:5], args[3][:5], method="cholesky")
        robot.forward_dynamics(np.asfortranarray(args[0][:4]), args[1][:4], args[3][:4])
        robot.bias_torques(args[0][6], args[1][6], wrench=args[4][6])
        q0, qd0 = robot.random_state(5)
        sd.simulate(robot, 0.01, q0, qd0, method="semi_implicit_euler", dt=1e-3)
        sd.simulate(robot, 0.01, q0, qd0, method="DOP853", dissipation=False)
    path, base, tip = urdf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        other = sd.load_urdf(path, base, tip)
    _quantities(other, *_batch(other, 5))


def _assert_bitwise(ref, got, what):
    problems = compare(ref, got, "first", "again")
    assert not problems, f"{what}:" + _listing(problems)


def test_same_answer_whatever_was_called_before():
    robots, urdf = _robots()
    K = (4, 33)     # a row of the first block of a batch, and one of its short tail
    first = {}
    for name, robot in robots.items():    # the very first calls of these robots
        args = _batch(robot, 1)
        for k in K:
            first.update({f"{name}/{key}/state {k}": v.copy()
                          for key, v in _quantities(robot, *_row(args, k)).items()})
        first.update({f"{name}/{key}/batch": v.copy() for key, v in _quantities(robot, *args).items()})
    _history(robots, urdf)
    again = {}
    for name, robot in robots.items():
        args = _batch(robot, 1)
        for k in K[::-1]:
            again.update({f"{name}/{key}/state {k}": v
                          for key, v in _quantities(robot, *_row(args, k)).items()})
        again.update({f"{name}/{key}/batch": v for key, v in _quantities(robot, *args).items()})
    _assert_bitwise(first, again, "the same calls give other bits after a history of other calls")
    # a second Robot of the same URDF, fresh, gives the same bits as well
    fresh, _ = _robots()
    anew = {}
    for name, robot in fresh.items():
        args = _batch(robot, 1)
        for k in K:
            anew.update({f"{name}/{key}/state {k}": v
                         for key, v in _quantities(robot, *_row(args, k)).items()})
        anew.update({f"{name}/{key}/batch": v for key, v in _quantities(robot, *args).items()})
    _assert_bitwise(first, anew, "a second Robot of the same URDF gives other bits")


# Batch row vs single state: asserted BITWISE for every quantity, because it holds today
# (serial_dynamics/core: the batch kernels run the same per-sample arithmetic as the
# single-state ones, without fast-math; rnea_lanes is bitwise rnea per sample). Before that
# core (kernels.py, fastmath={"contract"}), inverse dynamics and bias torques of the rows
# of a full 32-state block differed from the state alone by a few ulps (up to ~1e-14 of the
# largest torque). Should a future batch kernel legitimately order its sums differently,
# relax this to ~1e-13 relative to the largest entry of the state's result, and say why.


def test_batch_row_equals_single_state():
    robots, _ = _robots()
    problems = []
    for name, robot in robots.items():
        # 37 rows: a block of the lane kernels and a short tail; then 1 and 300 rows (a
        # batch long enough to be split over threads)
        for N in (37, 1, 300):
            args = _batch(robot, 2, N)
            batch = _quantities(robot, *args)
            for k in range(N):
                single = _quantities(robot, *_row(args, k))
                problems += [f"{name}/batch of {N}/row {k}/{p}"
                             for p in compare(single, {key: v[k] for key, v in batch.items()},
                                              "single", "batch row")]
    assert not problems, "row k of a batch is not bitwise the state alone:" + _listing(problems)


LUMPED = r"""
import hashlib, sys, warnings
warnings.simplefilter("ignore")
import serial_dynamics as sd
for tip in ("panda_link8", "panda_hand"):
    m = sd.load_urdf(sys.argv[1], None, tip).model
    print(hashlib.sha256(b"".join(a.tobytes() for a in (m.mass, m.com, m.inertia, m.h, m.I_O))).hexdigest())
"""


def test_loaded_model_does_not_depend_on_the_hash_seed(tmp_path):
    """Off-chain parts (the Panda's hand and fingers) are lumped in a fixed order, so the
    model is the same bits whatever PYTHONHASHSEED is (it used to follow set order:
    the last body's mass was 1.4955219999999998 or 1.495522)."""
    from pin_reference import erd
    root = os.path.dirname(os.path.dirname(os.path.abspath(sd.__file__)))
    script = tmp_path / "lumped.py"
    script.write_text(LUMPED)
    digests = set()
    for seed in map(str, range(8)):     # before the fix, seeds 0-3 and 4-7 gave different bits
        env = dict(os.environ, PYTHONHASHSEED=seed, PYTHONPATH=root)
        out = subprocess.run([sys.executable, str(script), erd("panda_description/urdf/panda.urdf")],
                             env=env, capture_output=True, text=True, check=True)
        digests.add(out.stdout.strip())
    assert len(digests) == 1, digests
