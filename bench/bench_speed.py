"""Speed of the compiled core, side by side with Pinocchio, MuJoCo and (if installed)
roboticstoolbox-python, in one process on the same robots and states; each row also shows
its ratio on 2026-11-21 (the kernels before the dynamics-core rewrite), from EARLIER.

    python bench/bench_speed.py            # writes the "speed" section of bench/BENCHMARKS.md
                                           # and bench/scaling.png
    python bench/bench_speed.py --quick    # fewer rounds, no cold-cache compile
    python bench/bench_speed.py --before REV   # the *before* columns from commit REV
    python bench/bench_speed.py --yardstick-only   # the batches against the yardstick only

Each peer's answer is checked against ours before it is timed. Times are the minimum over
interleaved rounds (ours, peer, ours, peer, ...) of the mean over a round, wall clock, one
thread; ratio = ours / peer (lower is better).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import textwrap
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
# the package measured: this checkout's, or (--rows-only) the one earlier_rows() names
sys.path.insert(0, os.environ.get("BENCH_PACKAGE_ROOT", os.path.dirname(HERE)))

import serial_dynamics as sd                                  # noqa: E402
from serial_dynamics.algorithms import aba as aba_module      # noqa: E402
from serial_dynamics.builtin.synthetic import chain_urdf      # noqa: E402
from _report import stamp, write_section                      # noqa: E402

import pinocchio as pin                                       # noqa: E402

ROBOTS = {"Panda": ("panda_description/urdf/panda.urdf", "panda_link8"),
          "UR5": ("ur_description/urdf/ur5_robot.urdf", "tool0")}
N_BATCH = 10_000
EARLIER_REV = "52c6115"   # the last commit before the dynamics core was rewritten (2026-11-21)



def erd_path(rel):
    import sysconfig
    return os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share",
                        "example-robot-data", "robots", rel)


# ------------------------------------------------------------------ timing
def pair(a, b, number, rounds):
    """Interleaved min-of-rounds timing of two callables: seconds per call of each."""
    ta = tb = float("inf")
    clock = time.perf_counter
    for _ in range(rounds):
        t0 = clock()
        for _ in range(number):
            a()
        t1 = clock()
        for _ in range(number):
            b()
        t2 = clock()
        ta, tb = min(ta, (t1 - t0) / number), min(tb, (t2 - t1) / number)
    return ta, tb


def agree(ours, theirs, what, tol=1e-9):
    err = np.max(np.abs(np.asarray(ours) - theirs)) / max(np.max(np.abs(theirs)), 1e-300)
    if not err <= tol:
        raise AssertionError(f"{what}: ours and the peer's differ by {err:.2e} (relative)")
    return err


# ------------------------------------------------------------------ Pinocchio adapter
class PinModel:
    """Pinocchio model of one of our chains (the joints off the chain locked at zero), and
    our (q, v) in its layout (continuous joints are (cos, sin) in Pinocchio)."""

    def __init__(self, robot, urdf, is_file=True):
        full = pin.buildModelFromUrdf(urdf) if is_file else pin.buildModelFromXML(urdf)
        keep = set(robot.joint_names)
        lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()
        jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iq = [self.model.idx_qs[j] for j in jid]
        self.two = [self.model.nqs[j] == 2 for j in jid]
        self.iv = np.array([self.model.idx_vs[j] for j in jid])
        assert self.model.nv == robot.dof

    def q(self, q):
        q = np.atleast_2d(q)
        out = np.tile(pin.neutral(self.model), (q.shape[0], 1))
        for k, (i, two) in enumerate(zip(self.iq, self.two)):
            if two:
                out[:, i], out[:, i + 1] = np.cos(q[:, k]), np.sin(q[:, k])
            else:
                out[:, i] = q[:, k]
        return out

    def v(self, x):
        x = np.atleast_2d(x)
        out = np.zeros((x.shape[0], self.model.nv))
        out[:, self.iv] = x
        return out


# ------------------------------------------------------------------ rows
def single_calls(name, robot, pm, rounds):
    rng = np.random.default_rng(0)
    q, qd = robot.random_state(rng, speed=2.0)
    qdd = rng.normal(size=robot.dof)
    tau = robot.inverse_dynamics(q, qd, qdd)
    pq, pv, pa, pt = pm.q(q)[0], pm.v(qd)[0], pm.v(qdd)[0], pm.v(tau)[0]
    m, d = pm.model, pm.data
    iv = pm.iv
    agree(robot.inverse_dynamics(q, qd, qdd), pin.rnea(m, d, pq, pv, pa)[iv], "rnea")
    Mp = pin.crba(m, d, pq)
    agree(robot.mass_matrix(q), (np.triu(Mp) + np.triu(Mp, 1).T)[np.ix_(iv, iv)], "crba")
    agree(robot.forward_dynamics(q, qd, tau), pin.aba(m, d, pq, pv, pt)[iv], "aba", 1e-8)
    agree(robot.gravity_torques(q), pin.computeGeneralizedGravity(m, d, pq)[iv], "gravity")
    rows = []
    n = robot.dof
    o1, o2, o3 = np.empty(n), np.empty((n, n)), np.empty(n)   # out=: no allocation, as pin's data
    for label, ours, peer, peer_name, target in [
        ("inverse dynamics, one state", lambda: robot.inverse_dynamics(q, qd, qdd),
         lambda: pin.rnea(m, d, pq, pv, pa), "pinocchio.rnea", 1.0),
        ("inverse dynamics, one state, `out=`", lambda: robot.inverse_dynamics(q, qd, qdd, out=o1),
         lambda: pin.rnea(m, d, pq, pv, pa), "pinocchio.rnea", 1.0),
        ("mass matrix, one state", lambda: robot.mass_matrix(q),
         lambda: pin.crba(m, d, pq), "pinocchio.crba (upper triangle only)", 1.0),
        ("mass matrix, one state, `out=`", lambda: robot.mass_matrix(q, out=o2),
         lambda: pin.crba(m, d, pq), "pinocchio.crba (upper triangle only)", 1.0),
        ("forward dynamics, one state", lambda: robot.forward_dynamics(q, qd, tau),
         lambda: pin.aba(m, d, pq, pv, pt), "pinocchio.aba", 1.0),
        ("forward dynamics, one state, `out=`", lambda: robot.forward_dynamics(q, qd, tau, out=o3),
         lambda: pin.aba(m, d, pq, pv, pt), "pinocchio.aba", 1.0),
        ("gravity torques, one state", lambda: robot.gravity_torques(q),
         lambda: pin.computeGeneralizedGravity(m, d, pq), "pinocchio.computeGeneralizedGravity", None),
    ]:
        a, b = pair(ours, peer, 2000, rounds)
        rows.append((name, label, a, b, peer_name, target))
    return rows


def batch_calls(name, robot, pm, rounds):
    rng = np.random.default_rng(1)
    Q, QD = robot.random_state(rng, batch=N_BATCH, speed=2.0)
    QDD = rng.normal(size=Q.shape)
    m, d, iv = pm.model, pm.data, pm.iv
    Pq, Pv, Pa = pm.q(Q), pm.v(QD), pm.v(QDD)                # (N, nq) rows for the loop
    Fq, Fv, Fa = (np.asfortranarray(x.T) for x in (Pq, Pv, Pa))   # (nq, N) for the batch call
    pool = pin.ModelPool(m, 1)
    out = np.zeros((m.nv, N_BATCH), order="F")
    ours = robot.inverse_dynamics(Q, QD, QDD)
    pin.rneaInParallel(1, pool, Fq, Fv, Fa, out)
    agree(ours, out[iv].T, "rneaInParallel")
    agree(ours[:50], np.array([pin.rnea(m, d, Pq[k], Pv[k], Pa[k]) for k in range(50)])[:, iv], "rnea loop")

    def loop():
        for k in range(N_BATCH):
            pin.rnea(m, d, Pq[k], Pv[k], Pa[k])

    a, b = pair(lambda: robot.inverse_dynamics(Q, QD, QDD), loop, 1, max(3, rounds // 4))
    a2, c = pair(lambda: robot.inverse_dynamics(Q, QD, QDD),
                 lambda: pin.rneaInParallel(1, pool, Fq, Fv, Fa, out), 1, rounds)
    a = min(a, a2)
    rows = [(name, f"inverse dynamics, {N_BATCH:,} states, one call (per state)", a / N_BATCH,
             b / N_BATCH, "pinocchio.rnea in a Python loop", 0.2),
            (name, f"inverse dynamics, {N_BATCH:,} states, one call (per state)", a / N_BATCH,
             c / N_BATCH, "pinocchio.rneaInParallel, 1 thread", 1.0)]
    # forward dynamics in a batch, for information
    T = ours
    Ft = np.asfortranarray(pm.v(T).T)
    outa = np.zeros((m.nv, N_BATCH), order="F")
    pin.abaInParallel(1, pool, Fq, Fv, Ft, outa)
    agree(robot.forward_dynamics(Q, QD, T), outa[iv].T, "abaInParallel", 1e-7)
    a, c = pair(lambda: robot.forward_dynamics(Q, QD, T),
                lambda: pin.abaInParallel(1, pool, Fq, Fv, Ft, outa), 1, rounds)
    rows.append((name, f"forward dynamics, {N_BATCH:,} states, one call (per state)", a / N_BATCH,
                 c / N_BATCH, "pinocchio.abaInParallel, 1 thread", None))
    return rows


def cores(robot, rounds):
    """Per-state time of the batch methods, N_BATCH states: one thread against the
    default (the batch split over the cores: ``robot.facade.PARALLEL_MIN``), interleaved."""
    from serial_dynamics.robot import facade as robot_module
    rng = np.random.default_rng(2)
    Q, QD = robot.random_state(rng, batch=N_BATCH, speed=2.0)
    QDD = rng.normal(size=Q.shape)
    T = robot.inverse_dynamics(Q, QD, QDD)
    default = robot_module.PARALLEL_MIN

    def serial(f):
        def run():
            robot_module.PARALLEL_MIN = 10 ** 12
            try:
                return f()
            finally:
                robot_module.PARALLEL_MIN = default
        return run

    rows = []
    for what, f in [("inverse dynamics", lambda: robot.inverse_dynamics(Q, QD, QDD)),
                    ("mass matrix", lambda: robot.mass_matrix(Q)),
                    ("forward dynamics", lambda: robot.forward_dynamics(Q, QD, T))]:
        if not np.array_equal(serial(f)(), f()):
            raise AssertionError(f"{what}: the split batch differs from the serial one")
        one, split = pair(serial(f), f, 1, rounds)
        rows.append((what, one / N_BATCH, split / N_BATCH))
    return rows


YARDSTICK_ROBOTS = {"Panda": ("panda_description/urdf/panda.urdf", "panda_link8", None),
                    "UR5": ("ur_description/urdf/ur5_robot.urdf", "tool0", None),
                    "Baxter (tree, 15 joints)": ("baxter_description/urdf/baxter.urdf", None,
                                                 ["left_wrist", "right_wrist", "head"]),
                    "Talos reduced (tree)": ("talos_data/robots/talos_reduced.urdf", None, None)}
# issue 29's targets, as a multiple of the plain scalar inverse dynamics of the same run
# (the derivatives: "3x faster than today" relative to the yardstick, today 3094 / 522 = 5.93)
YARDSTICK_TARGETS = {"inverse dynamics": 0.33, "mass matrix": 0.45, "forward dynamics": 1.1,
                     "derivatives of inverse dynamics": 1.98}


def yardstick_rows(rounds):
    """Each batch against the yardstick (bench/yardstick.py), on one core (this process
    pinned to the first it may use, the batch split off): ns a state of ours and of the
    plain scalar Newton-Euler loop, interleaved; the counted operations; the core's peak.
    Returns (peak flop/s, rows of (robot, call, ours s, scalar s, flops or None), the
    packed-instruction counts of the lane kernels)."""
    import yardstick
    from serial_dynamics.robot import batches
    mask, workers = os.sched_getaffinity(0), batches.WORKERS
    cpu = sorted(mask)[0]
    os.sched_setaffinity(0, {cpu})
    batches.WORKERS = 1
    rows = []
    try:
        peak = yardstick.peak(cpu)
        for name, (rel, tip, tips) in YARDSTICK_ROBOTS.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sd.HeldJointsWarning)
                robot = sd.load_urdf(erd_path(rel), None, tip, tip_links=tips).warmup()
            counts = {**yardstick.flops(robot),
                      "derivatives of inverse dynamics": yardstick.derivative_flops(robot)}
            rng = np.random.default_rng(3)
            Q, QD = robot.random_state(rng, batch=N_BATCH, speed=2.0)
            QDD = rng.normal(size=Q.shape)
            T = robot.inverse_dynamics(Q, QD, QDD)
            yardstick.check(f"{name}: the scalar loop", yardstick.scalar_inverse_dynamics(
                robot, Q, QD, QDD), T)
            scalar = lambda: yardstick.scalar_inverse_dynamics(robot, Q, QD, QDD)  # noqa: E731
            for what, f in [("inverse dynamics", lambda: robot.inverse_dynamics(Q, QD, QDD)),
                            ("mass matrix", lambda: robot.mass_matrix(Q)),
                            ("forward dynamics", lambda: robot.forward_dynamics(Q, QD, T)),
                            ("forward dynamics (articulated bodies)",
                             lambda: robot.forward_dynamics(Q, QD, T, method="aba")),
                            ("derivatives of inverse dynamics",
                             lambda: robot.inverse_dynamics_derivatives(Q, QD, QDD))]:
                a, b = pair(f, scalar, 1, rounds)
                rows.append((name, what, a / N_BATCH, b / N_BATCH, counts.get(what)))
            print(f"yardstick: {name} done", flush=True)
    finally:
        batches.WORKERS = workers
        os.sched_setaffinity(0, mask)
    return peak, rows, yardstick.packed_instructions()


def write_yardstick(rounds, write=True):
    """Measure the yardstick rows and write them as the section "yardstick"."""
    peak, rows, packed = yardstick_rows(rounds)
    body = ("## Batches against the yardstick: a plain scalar loop and the core's peak\n\n"
            + stamp() + "\n\nRegenerate with `python bench/bench_speed.py --yardstick-only` "
            "(about 3 minutes; also part of the whole run).\n\n"
            + "\n".join(yardstick_lines(peak, rows, packed)) + "\n")
    print(body)
    if write:
        write_section("yardstick", body)


def yardstick_lines(peak, rows, packed):
    lines = [f"**Batches against the yardstick** (issue 29; {N_BATCH:,} states a call, one "
             "thread pinned to one core; `bench/yardstick.py`). *Scalar*: a plain recursive "
             "Newton-Euler written for the yardstick from the URDF's fields (general axes, any "
             "parent array), compiled by numba in this run, one state after the other, checked "
             "against ours to 1e-10 before it is timed, interleaved with each row. *Flops*: the "
             "operations of one state counted by running plain versions of the algorithm on "
             "numbers that count (Newton-Euler; composite rigid bodies; forward dynamics = mass "
             "matrix + Newton-Euler at qdd = 0 + Cholesky solve; articulated bodies with 3 x 3 "
             "blocks; the derivatives of inverse dynamics "
             "= that Newton-Euler on dual numbers along the 2n directions of q and qd, each "
             "operation counted on the directions alive, the sparse forward mode ours runs; a "
             "sine or cosine counts one); each is checked against ours first. *Peak*: a 1024 x 1024 dgemm on the same core, "
             f"one thread: {peak / 1e9:.1f} Gflop/s; *limit* = flops / peak. Targets: issue 29's, "
             "as a multiple of the scalar inverse dynamics of the same robot in the same run.", "",
             "| robot | batch | ours (ns/state) | scalar ID (ns/state) | x scalar | target "
             "| flops | limit (ns) | x limit |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name, what, a, b, ops in rows:
        target = YARDSTICK_TARGETS.get(what)
        met = "" if target is None else (f"≤ {target:g} " + ("yes" if a / b <= target else
                                                             f"**no** ({a / b / target:.1f}x)"))
        limit = "" if ops is None else f"{ops / peak * 1e9:.1f}"
        times = "" if ops is None else f"{a / (ops / peak):.1f}"
        lines.append(f"| {name} | {what} | {a * 1e9:.0f} | {b * 1e9:.0f} | {a / b:.2f} | {met} | "
                     f"{'' if ops is None else ops} | {limit} | {times} |")
    lines += ["", "**Packed instructions** in the machine code of each SIMD-lane block kernel "
              "(`yardstick.packed_instructions`: compiled afresh, numba's `inspect_asm`; "
              "add, sub, mul, div, sqrt and fused multiply-adds on doubles). Packed: on 4 or "
              "8 lanes at once (ymm, zmm registers). The scalar ones are the loops' remainders "
              "and the fallbacks LLVM keeps for arrays that might overlap, which the kernels' "
              "own stack arrays never do: a count of instructions, not of time. No fused "
              "multiply-add is used (none is on the single-state path either, so a batch row "
              "keeps its single state's bits).", "",
              "| kernel | packed (ymm/zmm) | packed (xmm) | scalar |", "|---|---:|---:|---:|"]
    for name, c in packed.items():
        lines.append(f"| `{name}` | {c['packed ymm/zmm']} | {c['packed xmm']} | {c['scalar']} |")
    return lines + [""]


def mujoco_model(urdf_path):
    import mujoco
    xml = open(urdf_path).read()
    xml = re.sub(r"<visual>.*?</visual>", "", xml, flags=re.S)            # no meshes here
    xml = re.sub(r"<collision>.*?</collision>", "", xml, flags=re.S)
    xml = xml.replace('type="prismatic"', 'type="fixed"')                 # fingers held, as ours
    xml = re.sub(r"(<robot[^>]*>)", r'\1<mujoco><compiler discardvisual="true" fusestatic="false" '
                 r'balanceinertia="false"/></mujoco>', xml, count=1)
    m = mujoco.MjModel.from_xml_string(xml)
    m.dof_armature[:] = 0
    m.dof_frictionloss[:] = 0
    m.opt.timestep = 1e-3
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER       # semi-implicit Euler, implicit damping
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    return m


def simulation(robot, rounds):
    """10 s of the Panda at 1 ms: ready pose, 90 % gravity compensation, 1 N m s/rad damping."""
    import mujoco
    import mujoco.rollout
    m = mujoco_model(erd_path(ROBOTS["Panda"][0]))
    d = mujoco.MjData(m)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    assert names == robot.joint_names, names
    n, steps, beta = robot.dof, 10_000, 1.0
    q0 = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    tau = 0.9 * robot.gravity_torques(q0)

    def mj(nsteps):
        d.qpos[:], d.qvel[:], d.qfrc_applied[:], d.time = q0, 0.0, tau, 0.0
        for _ in range(nsteps):
            mujoco.mj_step(m, d)
        return d.qpos.copy()

    def ours(nsteps):
        return simulate_fixed_step(robot, q0, np.zeros(n), tau, 1e-3, nsteps,
                                   viscous=np.full(n, beta))[0]

    if hasattr(sd, "kernels") or os.path.exists(os.path.join(os.path.dirname(sd.__file__), "kernels.py")):
        from serial_dynamics.kernels import simulate_fixed_step      # the 2026-11-21 code
    else:
        from serial_dynamics.sim.compiled_euler import simulate_fixed_step

    m.dof_damping[:] = beta
    err = np.max(np.abs(ours(steps)[-1] - mj(steps)))
    if not err < 1e-9:
        raise AssertionError(f"MuJoCo and ours differ by {err:.2e} rad after 10 s")
    a, b = pair(lambda: ours(steps), lambda: mj(steps), 1, rounds)
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    d.qpos[:], d.qvel[:], d.time = q0, 0.0, 0.0
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ctrl = np.zeros((1, steps, m.nu))
    with mujoco.rollout.Rollout(nthread=0) as ro:
        def roll():
            d.qfrc_applied[:] = tau
            return ro.rollout(m, d, state[None], ctrl, nstep=steps)
        roll()
        _, c = pair(lambda: None, roll, 1, rounds)
    return [("Panda", "simulation, 10 s at 1 ms, semi-implicit Euler (whole run)", a, b,
             "mujoco.mj_step in a Python loop", 2.0),
            ("Panda", "simulation, 10 s at 1 ms, semi-implicit Euler (whole run)", a, c,
             "mujoco.rollout (C loop)", None)], err


FIRST_CALL = textwrap.dedent("""
    import time
    t0 = time.perf_counter()
    import numpy as np
    import serial_dynamics as sd
    robot = sd.default_robot()
    t1 = time.perf_counter()
    q = np.zeros(robot.dof)
    robot.inverse_dynamics(q, q, q)
    t2 = time.perf_counter()
    robot.warmup()
    t3 = time.perf_counter()
    try:
        from serial_dynamics.sim.compiled_euler import _loop
    except ImportError:                       # the 2026-11-21 code
        from serial_dynamics.kernels import K
        _loop = lambda: K.simulate_semi_implicit_euler
    _loop()
    t4 = time.perf_counter()
    print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
""")


def first_call(cold, earlier_root=None):
    """Fresh interpreter: (import + load, first inverse_dynamics, warmup of every kernel,
    the simulation loop). Cold: an empty numba cache (NUMBA_CACHE_DIR), then the same
    again warm; and, cold, the 2026-11-21 code from ``earlier_root``."""
    env = dict(os.environ)
    out = {}
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as cache2:
        runs = [("cold", cache, None), ("warm", cache, None)] if cold else []
        runs.append(("warm (package cache)", None, None))
        if cold and earlier_root:
            runs.append((f"cold, the {EARLIER_REV} code (2026-11-21)", cache2, earlier_root))
        for label, cdir, root in runs:
            e = dict(env)
            if cdir:
                e["NUMBA_CACHE_DIR"] = cdir
            if root:
                e["PYTHONPATH"] = root
            res = subprocess.run([sys.executable, "-c", FIRST_CALL], env=e, capture_output=True,
                                 text=True, check=True, cwd=root or os.path.dirname(HERE))
            out[label] = [float(x) for x in res.stdout.split()]
    return out


def precompile_wall():
    """Wall time of ``python -m serial_dynamics.precompile`` (every kernel, two processes)
    on an empty cache, the whole command."""
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "serial_dynamics.precompile"], check=True,
                       env=dict(os.environ, NUMBA_CACHE_DIR=cache), capture_output=True,
                       cwd=os.path.dirname(HERE))
        return time.perf_counter() - t0


def earlier_code(tmp, rev=EARLIER_REV):
    """The package of commit ``rev`` (default: the 2026-11-21 code, EARLIER_REV; git
    archive) under ``tmp``, or None (no git history here)."""
    repo = os.path.dirname(HERE)
    try:
        arch = subprocess.run(["git", "-C", repo, "archive", rev, "serial_dynamics"],
                              capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    subprocess.run(["tar", "-x", "-C", tmp], input=arch, check=True)
    return tmp


def earlier_rows(root, rounds):
    """This script's single and batch rows measured on the 2026-11-21 code, in a
    subprocess that imports that package: {(robot, row, peer): (ours, peer's)}."""
    e = dict(os.environ, BENCH_PACKAGE_ROOT=root, NUMBA_CACHE_DIR=os.path.join(root, "numba_cache"))
    res = subprocess.run([sys.executable, os.path.abspath(__file__), "--rows-only",
                          "--rounds", str(rounds)], env=e, capture_output=True, text=True,
                         check=True, cwd=root)
    return {(r, w, p): (a, b) for r, w, a, b, p, _ in json.loads(res.stdout.splitlines()[-1])}


def scaling(rounds):
    ns = [6, 10, 15, 20, 30, 50, 75, 100, 150, 200]
    res = {k: [] for k in ("id", "m", "chol", "aba", "pin_id", "pin_m", "pin_aba")}
    for n in ns:
        xml = chain_urdf(n, kinds=(["revolute"] * 4 + ["prismatic"]) * (n // 5) + ["revolute"] * (n % 5))
        robot = sd.load_urdf(xml).warmup()
        pm = PinModel(robot, xml, is_file=False)
        rng = np.random.default_rng(n)
        q, qd = robot.random_state(rng)
        tau = rng.normal(size=n)
        pq, pv, pt = pm.q(q)[0], pm.v(qd)[0], pm.v(tau)[0]
        agree(robot.inverse_dynamics(q, qd, tau), pin.rnea(pm.model, pm.data, pq, pv, pt)[pm.iv], f"rnea n={n}")
        number = max(10, 4000 // n)
        r = max(5, rounds // 2)
        for key, ours, peer in [
            ("id", lambda: robot.inverse_dynamics(q, qd, tau), lambda: pin.rnea(pm.model, pm.data, pq, pv, pt)),
            ("m", lambda: robot.mass_matrix(q), lambda: pin.crba(pm.model, pm.data, pq)),
            ("aba", lambda: robot.forward_dynamics(q, qd, tau, method="aba"),
             lambda: pin.aba(pm.model, pm.data, pq, pv, pt)),
        ]:
            a, b = pair(ours, peer, number, r)
            res[key].append(a)
            res["pin_" + key].append(b)
        a, _ = pair(lambda: robot.forward_dynamics(q, qd, tau, method="cholesky"), lambda: None, number, r)
        res["chol"].append(a)
    # crossover: single-call forward dynamics, ABA against Cholesky
    cross = []
    for n in range(6, 33, 2):
        robot = sd.load_urdf(chain_urdf(n)).warmup()
        q, qd = robot.random_state(n)
        tau = np.ones(n)
        a, c = pair(lambda: robot.forward_dynamics(q, qd, tau, method="aba"),
                    lambda: robot.forward_dynamics(q, qd, tau, method="cholesky"), 2000, rounds)
        cross.append((n, a, c))
    return ns, res, cross


def plot(ns, res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.8))
    us = lambda v: np.array(v) * 1e6                                     # noqa: E731
    ax.loglog(ns, us(res["id"]), "o-", color="C0", label="ours: inverse dynamics (RNEA)")
    ax.loglog(ns, us(res["aba"]), "s-", color="C1", label="ours: forward dynamics, ABA")
    ax.loglog(ns, us(res["chol"]), "^-", color="C2", label="ours: forward dynamics, CRBA + Cholesky")
    ax.loglog(ns, us(res["m"]), "d-", color="C3", label="ours: mass matrix (CRBA)")
    ax.loglog(ns, us(res["pin_id"]), "o--", color="C0", alpha=0.6, label="Pinocchio rnea")
    ax.loglog(ns, us(res["pin_aba"]), "s--", color="C1", alpha=0.6, label="Pinocchio aba")
    ax.loglog(ns, us(res["pin_m"]), "d--", color="C3", alpha=0.6, label="Pinocchio crba")
    ref = np.array(ns, dtype=float)
    ax.loglog(ref, us(res["id"])[-1] * ref / ref[-1], ":", color="gray", label="slope 1 (O(n))")
    ax.set_xlabel("joints n (synthetic chain, every 5th joint prismatic)")
    ax.set_ylabel("time per call from Python [µs]")
    ax.set_title("serial_dynamics: cost against chain length")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7.5)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def rtb_rows(robot_ur5, rounds):
    """roboticstoolbox-python (its URDF robot, Python RNE) on the UR5, if it installs."""
    try:
        import roboticstoolbox as rtb
    except Exception as exc:                                      # noqa: BLE001
        return [], f"roboticstoolbox-python not available ({type(exc).__name__})"
    try:
        import io

        from roboticstoolbox.models.URDF.URDFRobot import URDF_file
        xml = open(erd_path(ROBOTS["UR5"][0])).read()
        xml = re.sub(r"<(visual|collision)>.*?</(visual|collision)>", "", xml, flags=re.S)  # no meshes
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            links, name, _ = URDF_file(io.StringIO(xml))
            peer = rtb.Robot(links, name=name)
        peer.gravity = robot_ur5.gravity
        rng = np.random.default_rng(3)
        q, qd = robot_ur5.random_state(rng)
        qdd = rng.normal(size=6)
        theirs = peer.rne(q, qd, qdd)
        err = agree(robot_ur5.inverse_dynamics(q, qd, qdd), theirs, "roboticstoolbox rne", 1e-9)
        a, b = pair(lambda: robot_ur5.inverse_dynamics(q, qd, qdd), lambda: peer.rne(q, qd, qdd),
                    200, max(3, rounds // 4))
        return [("UR5", "inverse dynamics, one state", a, b,
                 f"roboticstoolbox-python {rtb.__version__} Robot.rne", None)], f"agrees to {err:.1e}"
    except AssertionError as exc:
        return [], f"roboticstoolbox-python disagrees, not timed: {exc}"
    except Exception as exc:                                      # noqa: BLE001
        return [], f"roboticstoolbox-python could not run the UR5 ({type(exc).__name__}: {exc})"


# ------------------------------------------------------------------ report
def fmt_t(s):
    return f"{s * 1e9:.0f} ns" if s < 1e-6 * 10 else (f"{s * 1e6:.1f} µs" if s < 1e-3 else f"{s * 1e3:.2f} ms")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds, no cold-cache compile")
    ap.add_argument("--no-write", action="store_true", help="print, do not write BENCHMARKS.md")
    ap.add_argument("--rows-only", action="store_true",
                    help="print the single and batch rows as JSON (used on the 2026-11-21 code)")
    ap.add_argument("--rounds", type=int, default=None)
    ap.add_argument("--yardstick-only", action="store_true",
                    help="only the batches against the yardstick (the \"yardstick\" section)")
    ap.add_argument("--before", default=EARLIER_REV, metavar="REV",
                    help=f"the commit of the *before* columns (default {EARLIER_REV}, the 2026-11-21 code)")
    args = ap.parse_args()
    rounds = args.rounds or (8 if args.quick else 30)
    if args.yardstick_only:
        return write_yardstick(rounds, not args.no_write)
    if args.rows_only:
        rows, robots = [], {}
        for name, (rel, tip) in ROBOTS.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", sd.HeldJointsWarning)
                robots[name] = robot = sd.load_urdf(erd_path(rel), None, tip).warmup()
            pm = PinModel(robot, erd_path(rel))
            rows += single_calls(name, robot, pm, rounds) + batch_calls(name, robot, pm, rounds)
        rows += simulation(robots["Panda"], max(5, rounds // 3))[0]
        print(json.dumps(rows))
        return
    import mujoco
    tmp = tempfile.mkdtemp()
    root = earlier_code(tmp, args.before)
    earlier = earlier_rows(root, rounds) if root else {}
    print(f"the {args.before} code measured" if root else "no git: no earlier code", flush=True)

    rows, robots = [], {}
    for name, (rel, tip) in ROBOTS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sd.HeldJointsWarning)
            robot = sd.load_urdf(erd_path(rel), None, tip).warmup()
        robots[name] = robot
        pm = PinModel(robot, erd_path(rel))
        rows += single_calls(name, robot, pm, rounds)
        rows += batch_calls(name, robot, pm, rounds)
        print(f"{name}: single and batch rows done", flush=True)
    sim_rows, sim_err = simulation(robots["Panda"], max(5, rounds // 3))
    rows += sim_rows
    extra, rtb_note = rtb_rows(robots["UR5"], rounds)
    rows += extra
    print("simulation, peers done", flush=True)
    from serial_dynamics.robot import facade as robot_module
    core_rows = cores(robots["Panda"], rounds)
    print("cores done", flush=True)
    write_yardstick(rounds, not args.no_write)
    first = first_call(cold=not args.quick, earlier_root=root if args.before == EARLIER_REV else None)
    both_cores = None if args.quick else precompile_wall()
    print("first call done", flush=True)
    ns, res, cross = scaling(rounds)
    plot(ns, res, os.path.join(HERE, "scaling.png"))
    print("scaling done", flush=True)

    lines = [stamp(), "",
             "Regenerate with `python bench/bench_speed.py` (about 1 minute; the machine may be shared "
             "with other jobs, so every ratio is from interleaved rounds of ours and the peer's). "
             f"Peers: Pinocchio {pin.__version__}, MuJoCo {mujoco.__version__}. Panda = "
             "example-robot-data `panda.urdf` to `panda_link8` (7 joints, fingers held and lumped), "
             "UR5 = `ur5_robot.urdf` to `tool0`. Every peer's result is checked against ours before "
             "it is timed (rigid-body terms agree to ~1e-15 relative, forward dynamics to cond(M) eps).",
             "", (f"*Before*: the same row measured in this run, on this machine, on the code as it "
                  f"was before the dynamics core was rewritten (commit {EARLIER_REV}, 2026-11-21: "
                  "joint-aligned kernels with a shared scratch array and fused multiply-add), imported "
                  "from a git archive in a subprocess, each with its own interleaved peer; *change*: "
                  "this row's ratio against that one. The rewrite must keep every row within 5 % or "
                  "better." if args.before == EARLIER_REV else
                  f"*Before*: the same row measured in this run, on this machine, on commit "
                  f"{args.before} (`--before {args.before}`), imported from a git archive in a "
                  "subprocess, each with its own interleaved peer; *change*: this row's ratio "
                  "against that one."),
             "", "| robot | what | ours | peer | peer's time | ratio | target | met "
             "| before | ratio before | change |",
             "|---|---|---:|---|---:|---:|---:|:---:|---:|---:|---:|"]
    for robot_name, what, a, b, peer, target in rows:
        ratio = a / b
        met = "" if target is None else ("yes" if ratio <= target else f"**no** (+{(ratio / target - 1) * 100:.0f} %)")
        a_old, b_old = earlier.get((robot_name, what, peer), (None, None))
        old = (f"{fmt_t(a_old)} | {a_old / b_old:.3g} | {(ratio / (a_old / b_old) - 1) * 100:+.0f} %"
               if a_old else " | | ")
        lines.append(f"| {robot_name} | {what} | {fmt_t(a)} | {peer} | {fmt_t(b)} | {ratio:.3g} | "
                     f"{'' if target is None else f'≤ {target:g}'} | {met} | {old} |")
    lines += ["", "*`out=`*: the result is written into an array the caller keeps, as Pinocchio writes into "
              "its `Data` (a 1 kHz loop then allocates nothing); without it each call returns a new array, "
              "whose allocation is the difference between the two rows.", ""]
    lines += [f"Simulation check: after 10 s our trajectory and MuJoCo's differ by {sim_err:.1e} rad "
              "(both integrate the joint damping implicitly: MuJoCo's Euler does, and so does "
              "`sim.compiled_euler.simulate_fixed_step` by default). roboticstoolbox-python: " + rtb_note + ".", ""]
    lines += [f"**Batches over the cores** (Panda, {N_BATCH:,} states, per state; a batch of at least "
              f"`serial_dynamics.robot.facade.PARALLEL_MIN` = {robot_module.PARALLEL_MIN} states is split into "
              f"one chunk per core, {os.cpu_count()} here; the results are bitwise those of one thread, "
              "checked before timing):", "",
              "| method | one thread | split over the cores | speed-up |", "|---|---:|---:|---:|"]
    for what, one, split in core_rows:
        lines.append(f"| {what} | {fmt_t(one)} | {fmt_t(split)} | {one / split:.2f} |")
    lines += ["", "The rows of the main table are measured with the default, so their batch rows use "
              "both cores; Pinocchio's `*InParallel` rows use one thread, as its `1` argument says "
              "(compare them with the one-thread column here).", ""]
    lines += ["**First call in a fresh process** (import + URDF load — with a cold cache this compiles "
              "the core's algorithms, which have explicit signatures; the first `inverse_dynamics`; "
              "`Robot.warmup()`, which compiles or loads the entry points of the Robot methods; the "
              "whole-run simulation loop, which `sd.simulate` compiles on first use):", "",
              "| numba cache | import + load | first inverse_dynamics | warmup (all Robot kernels) "
              "| simulation loop | all |", "|---|---:|---:|---:|---:|---:|"]
    for label, times in first.items():
        lines.append("| " + label + " | " + " | ".join(f"{t:.2f} s" for t in times)
                     + f" | {sum(times):.2f} s |")
    cold = [v for k, v in first.items() if k.startswith("cold")]
    if len(cold) == 2:
        lines += ["", f"Cold compile of everything in one process, as above: {sum(cold[0]):.1f} s "
                  f"against {sum(cold[1]):.1f} s before ({sum(cold[0]) / sum(cold[1]) * 100:.0f} %)."]
        if both_cores:
            lines += [f"`python -m serial_dynamics.precompile` (what the tests' session start and "
                      f"the demo run; a second process compiles half of the kernels), whole "
                      f"command on an empty cache: {both_cores:.1f} s "
                      f"({both_cores / sum(cold[1]) * 100:.0f} % of the one-process compile before)."]
    lines += ["", "Targets: a cold compile of everything in at most half of 2026-11-21's; a node whose "
              "kernels are cached ready in under 2 s (import + load + warmup, warm rows). "
              "`python -m serial_dynamics.precompile` fills the cache ahead of time.", ""]
    slope = lambda key: np.polyfit(np.log(ns[-4:]), np.log(res[key][-4:]), 1)[0]   # noqa: E731
    lines += ["**Cost against chain length** (single calls from Python, synthetic chain, every 5th joint "
              "prismatic; plot: `bench/scaling.png`):", "",
              "| n | " + " | ".join(str(n) for n in ns) + " |", "|---|" + "---:|" * len(ns)]
    for key, label in [("id", "ours ID"), ("pin_id", "Pinocchio rnea"), ("aba", "ours FD (ABA)"),
                       ("pin_aba", "Pinocchio aba"), ("chol", "ours FD (Cholesky)"), ("m", "ours M (CRBA)"),
                       ("pin_m", "Pinocchio crba")]:
        lines.append(f"| {label} | " + " | ".join(f"{t * 1e6:.2f}" for t in res[key]) + " |")
    lines += ["", f"Times in µs. Log-log slope over n = {ns[-4]}..{ns[-1]}: inverse dynamics {slope('id'):.2f}, "
              f"ABA {slope('aba'):.2f} (O(n)), Cholesky route {slope('chol'):.2f}, mass matrix {slope('m'):.2f}.", ""]
    first_aba = next((n for n, a, c in cross if a < c), None)
    lines += [f"**Crossover** (single-call forward dynamics, all-revolute chain): ABA is faster than "
              f"CRBA + Cholesky from n = {first_aba} on "
              "(" + ", ".join(f"n={n}: {a * 1e6:.2f}/{c * 1e6:.2f} µs" for n, a, c in cross) + "; ABA/Cholesky). "
              f"`forward_dynamics(method=\"auto\")` switches at n ≥ {aba_module.CROSSOVER} "
              "(`algorithms.aba.CROSSOVER`)."]
    body = "## Speed: the compiled core against Pinocchio and MuJoCo\n\n" + "\n".join(lines) + "\n"
    print(body)
    if not args.no_write:
        write_section("speed", body)


if __name__ == "__main__":
    main()
