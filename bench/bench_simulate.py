"""Speed against error of the simulator's methods, and model fidelity.

    python bench/bench_simulate.py                # about 4-6 minutes on 2 cores
    python bench/bench_simulate.py --energy-only  # only the section "simulate_energy"

Scenarios: the default robot (UR5e) swinging freely from rest, the stiff chain
(builtin/synthetic.py: stiff_chain_urdf) and the UR5e with joint friction (viscous,
Coulomb, Stribeck) under shaking torques. Each method runs over a range of tolerances
(adaptive) or steps (fixed step); the error is the largest deviation of (q, qd) at the
final time from a tight-tolerance reference, the energy error the largest violation of
E(t) - E(0) = W_act + W_diss relative to the run's energy scale.

Writes the "simulate" section of bench/BENCHMARKS.md and bench/work_precision.png, and
(``_energy_long.py``) the "simulate_energy" section: the fixed-step methods' energy over
10^4 periods, their cost per step, and the implicit methods' Jacobians before (finite
differences) and after (analytical); plot bench/energy_long_horizon.png.
Also a model-fidelity table: on a fast pick-and-place move of the UR5e, the torque error
and the time saved by dropping terms of the inverse dynamics.
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import serial_dynamics as sd                                   # noqa: E402
from serial_dynamics.builtin.synthetic import stiff_chain_urdf  # noqa: E402
from serial_dynamics.sim.driver import simulate as run          # noqa: E402
from serial_dynamics.sim.methods import SimulationError         # noqa: E402

from _report import stamp, write_section                        # noqa: E402

Q0 = np.array([0.3, -1.0, 0.8, -0.5, 0.4, 0.2])
ADAPTIVE = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
NAMES = {"friction_smoothing": "v_eps"}
FIXED = ("semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint")
T0 = time.perf_counter()


def log(msg):
    print(f"[{time.perf_counter() - T0:6.1f} s] {msg}", flush=True)


def timed(fn):
    """Run once; runs shorter than 0.2 s are repeated (best of 3)."""
    t = time.perf_counter()
    out = fn()
    best = time.perf_counter() - t
    if best < 0.2:
        for _ in range(2):
            t = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t)
    return out, best


def sweep(name, robot, duration, q0, torque, ref, grid, positions_only=False):
    """grid: list of (method, kwargs). Returns rows of dicts."""
    rows = []
    for method, kw in grid:
        setting = ", ".join(f"{NAMES.get(k, k)} = {v:g}" for k, v in kw.items())
        label = method + (f" (v_eps = {kw['friction_smoothing']:g})"
                          if "friction_smoothing" in kw else "")
        try:
            res, wall = timed(lambda: run(robot, duration, q0, None, torque, method=method,
                                          **kw))
        except SimulationError as exc:
            rows.append(dict(method=method, label=label, setting=setting, diverged=True,
                             reason=f"diverged at t = {exc.t:.3g} s ({exc.reason})"))
            log(f"{name}: {method:20s} {setting:28s} diverged ({exc.reason} at t = {exc.t:.3g} s)")
            continue
        err = float(np.max(np.abs(res.q[-1] - ref.q[-1]) if positions_only else
                           np.abs(np.r_[res.q[-1] - ref.q[-1], res.qd[-1] - ref.qd[-1]])))
        s = res.stats
        row = dict(method=method, label=label, setting=setting, diverged=False, wall=wall,
                   steps=s.steps, nfev=s.nfev, states=s.dynamics_states, rejected=s.rejected, err=err,
                   energy=res.relative_energy_error())
        rows.append(row)
        log(f"{name}: {method:20s} {setting:28s} {wall * 1e3:9.1f} ms  {s.nfev:7d} RHS  "
            f"error {err:.2e}  energy {row['energy']:.1e}")
    return rows


def table(rows):
    out = ["| method | setting | wall ms | steps | RHS evals | dynamics states | rejected | "
           "final error | energy error |",
           "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        if r["diverged"]:
            out.append(f"| {r['method']} | {r['setting']} | | | | | | {r['reason']} | |")
        else:
            out.append(f"| {r['method']} | {r['setting']} | {r['wall'] * 1e3:.1f} | {r['steps']} | "
                       f"{r['nfev']} | {r['states']} | {r['rejected']} | {r['err']:.2e} | "
                       f"{r['energy']:.1e} |")
    return "\n".join(out)


def grid(tols, dts, methods_a=ADAPTIVE, methods_f=FIXED):
    g = [(m, dict(rtol=t, atol=t * 1e-2)) for m in methods_a for t in tols]
    g += [(m, dict(dt=d)) for m in methods_f for d in dts]
    return g


# ----------------------------------------------------------------------------- scenarios
def scenario_swing():
    robot = sd.default_robot().warmup()
    T = 1.0
    log("UR5e free swing: reference DOP853 rtol 1e-13")
    ref = run(robot, T, Q0, None, method="DOP853", rtol=1e-13, atol=1e-14)
    rows = sweep("swing", robot, T, Q0, None, ref,
                 grid([1e-4, 1e-6, 1e-8, 1e-10], [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4]))
    return rows, T


def scenario_stiff():
    robot = sd.load_urdf(stiff_chain_urdf())
    q0 = np.array([0.3, 0.8, -0.5, 0.6])
    T = 0.5
    log("stiff chain: reference Radau rtol 1e-11")
    ref = run(robot, T, q0, None, method="Radau", rtol=1e-11, atol=1e-13)
    rows = sweep("stiff", robot, T, q0, None, ref,
                 grid([1e-3, 1e-5, 1e-7, 1e-9], [2e-3, 1e-3, 5e-4, 2e-4, 1e-4]))
    return rows, T


def friction_robot():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(
        viscous=[0.8, 0.8, 0.5, 0.1, 0.1, 0.05], coulomb=[4, 4, 3, 0.6, 0.6, 0.2],
        stribeck=[2, 2, 1, 0.2, 0.2, 0.05], stribeck_rate=5.0)
    return robot


def scenario_friction():
    """Gravity compensation plus torques that swing around the static friction, so that
    joints stick and slip. Reference: the stick-slip model (RK4, 10 us steps; stick-slip
    transitions fall on step boundaries, so it is first order there). The adaptive methods
    integrate the regularized model (tanh(qd / v_eps)), whose distance from stick-slip
    shrinks with v_eps; the explicit adaptive ones are held to tiny steps by its stiffness."""
    robot = friction_robot()
    amp = 1.3 * robot.dissipation.static_friction
    freq = 2 * np.pi * np.array([0.9, 1.3, 1.1, 1.7, 2.1, 2.9])

    def torque(t, q, qd):
        return robot.gravity_torques(q) + amp * np.sin(freq * t)

    T = 0.5
    log("friction: reference rk4 dt 1e-5 (stick-slip)")
    ref = run(robot, T, Q0, None, torque, method="rk4", dt=1e-5)
    sticking = float(np.mean(ref.qd == 0.0))
    g = [(m, dict(rtol=1e-6, atol=1e-8, friction_smoothing=1e-3)) for m in ("RK45", "DOP853")]
    g += [("Radau", dict(rtol=1e-8, atol=1e-10, friction_smoothing=v)) for v in (1e-3, 1e-5)]
    g += grid([1e-4, 1e-6, 1e-8], [1e-3, 5e-4, 2e-4, 1e-4, 5e-5],
              methods_a=("Radau", "BDF", "LSODA"))
    rows = sweep("friction", robot, T, Q0, torque, ref, g, positions_only=True)
    return rows, T, sticking


# ----------------------------------------------------------------------------- fidelity
QA = np.array([-1.2, -1.9, 1.9, -1.6, -1.57, 0.0])
QB = np.array([1.2, -1.1, 1.0, -1.4, -1.57, 1.0])


def desired(t, T):
    """A fast rest-to-rest move QA -> QB with a quintic (minimum-jerk) profile s(t / T)."""
    x = np.clip(np.asarray(t, dtype=float) / T, 0.0, 1.0)
    s, ds, dds = (10 * x**3 - 15 * x**4 + 6 * x**5, (30 * x**2 - 60 * x**3 + 30 * x**4) / T,
                  (60 * x - 180 * x**2 + 120 * x**3) / T**2)
    dq = QB - QA
    return QA + np.multiply.outer(s, dq), np.multiply.outer(ds, dq), np.multiply.outer(dds, dq)


def per_call(fn, args_list, repeat=5):
    """Seconds per sample, calling fn once per sample (a control loop's use)."""
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for a in args_list:
            fn(*a)
        best = min(best, time.perf_counter() - t)
    return best / len(args_list)


def fidelity(T=1.5, N=400):
    robot = sd.default_robot().warmup()
    ts = np.linspace(0, T, N)
    q, qd, qdd = desired(ts, T)
    full = robot.inverse_dynamics(q, qd, qdd)
    M_bar = robot.mass_matrix(q[N // 2])
    models = {   # name: (torques over the move, one sample's computation)
        "full: M(q) qdd + C(q, qd) qd + g(q) (RNEA)":
            (full, lambda a, b, c: robot.inverse_dynamics(a, b, c)),
        "no Coriolis/centrifugal: M(q) qdd + g(q)":
            (np.einsum("kij,kj->ki", robot.mass_matrix(q), qdd) + robot.gravity_torques(q),
             lambda a, b, c: robot.mass_matrix(a) @ c + robot.gravity_torques(a)),
        "frozen mass matrix M(q_mid), exact C qd + g":
            (qdd @ M_bar.T + robot.bias_torques(q, qd),
             lambda a, b, c: M_bar @ c + robot.bias_torques(a, b)),
        "frozen M(q_mid), no Coriolis: M(q_mid) qdd + g(q)":
            (qdd @ M_bar.T + robot.gravity_torques(q),
             lambda a, b, c: M_bar @ c + robot.gravity_torques(a)),
        "gravity only: g(q)":
            (robot.gravity_torques(q), lambda a, b, c: robot.gravity_torques(a)),
    }
    samples = list(zip(q, qd, qdd))
    peak = np.max(np.abs(full), axis=0)
    # tracking with each model as feedforward plus the same PD feedback
    Kp = np.array([400.0, 400.0, 200.0, 20.0, 20.0, 2.0])
    Kd = np.array([40.0, 40.0, 20.0, 2.0, 2.0, 0.05])
    rows = []
    t_full = None
    for name, (tau, fn) in models.items():
        t = per_call(fn, samples)
        t_full = t if t_full is None else t_full

        def control(t_, q_, qd_, tau=tau):
            qd_des, vd_des, _ = desired(t_, T)
            ff = np.array([np.interp(t_, ts, tau[:, j]) for j in range(6)])
            return ff + Kp * (qd_des - q_) + Kd * (vd_des - qd_)

        res = run(robot, T, q[0], qd[0], control, method="DOP853", rtol=1e-8, atol=1e-10,
                  dissipation=False, output_dt=T / 200)
        track = float(np.max(np.abs(res.q - desired(res.t, T)[0])))
        err = np.abs(tau - full)
        rows.append((name, float(np.max(err)), float(np.max(err) / np.max(peak)),
                     float(np.sqrt(np.mean((tau - full) ** 2))), t, 1.0 - t / t_full, track))
        log(f"fidelity: {name:52s} max err {np.max(err):8.3f} N m  {t * 1e6:7.1f} us/sample  "
            f"tracking {track:.2e} rad")
    return rows, peak, T


# ----------------------------------------------------------------------------- report
def ill_conditioned():
    """Forward dynamics of the ill-conditioned chain against a 50-digit reference (the
    mpmath RNEA of test/sim/test_simulate_hard.py)."""
    try:
        import mpmath
        sys.path.insert(0, os.path.join(os.path.dirname(HERE), "test"))
        from test_simulate_hard import _mp_forward
    except ImportError:
        return None
    from serial_dynamics.builtin.synthetic import ill_conditioned_chain_urdf
    mpmath.mp.dps = 50
    robot = sd.load_urdf(ill_conditioned_chain_urdf())
    numpy_path = sd.Robot(robot.model, backend="numpy")
    rng = np.random.default_rng(7)
    out = {"cholesky": [], "qr": [], "cholesky, NumPy path": [], "cond": [], "cond_h": []}
    for _ in range(4):
        q, qd = robot.random_state(rng)
        tau = rng.uniform(-1, 1, 6) * np.geomspace(10, 1e-5, 6)
        M, _, x = _mp_forward(robot.model, q, qd, tau)
        ref = np.array([float(v) for v in x])
        Mf = np.array([[float(M[i, j]) for j in range(6)] for i in range(6)])
        d = np.sqrt(np.diag(Mf))
        out["cond"].append(np.linalg.cond(Mf))
        out["cond_h"].append(np.linalg.cond(Mf / np.outer(d, d)))
        for key, r, m in (("cholesky", robot, "cholesky"), ("qr", robot, "qr"),
                          ("cholesky, NumPy path", numpy_path, "cholesky")):
            out[key].append(np.max(np.abs(r.forward_dynamics(q, qd, tau, method=m) - ref)
                                   / np.abs(ref)))
    return {k: float(np.max(v)) for k, v in out.items()}


def plot(panels, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 5))
    styles = {"RK45": "C0o-", "DOP853": "C1s-", "Radau": "C2^-", "BDF": "C3v-", "LSODA": "C4D-",
              "semi_implicit_euler": "C5o--", "rk4": "C6s--", "implicit_midpoint": "C7^--",
              "symplectic_euler": "C8D--"}
    for ax, (title, rows, what) in zip(axes, panels):
        labels = []
        for r in rows:
            if not r["diverged"] and r["label"] not in labels:
                labels.append(r["label"])
        extra = iter(["k*", "kP", "kX", "k+"])
        for label in labels:     # points in sweep order (tolerance or step decreasing)
            pts = [(r["wall"], max(r["err"], 1e-16)) for r in rows
                   if r["label"] == label and not r["diverged"]]
            x, y = zip(*pts)
            ax.loglog(x, y, styles.get(label) or next(extra), label=label, ms=4 if label in
                      styles else 8)
        ax.legend(fontsize=7)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(f"error of {what} at the final time")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("sd.simulate: work-precision (adaptive: solid, rtol sweep; "
                 "fixed step: dashed, dt sweep)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def best_under(rows, tol):
    """Fastest run of each method with final error <= tol."""
    out = {}
    for r in rows:
        if not r["diverged"] and r["err"] <= tol:
            if r["method"] not in out or r["wall"] < out[r["method"]]["wall"]:
                out[r["method"]] = r
    return out


def main():
    import _energy_long
    if "--energy-only" in sys.argv[1:]:
        _energy_long.main(HERE, stamp, write_section, log, T0)
        return
    _energy_long.main(HERE, stamp, write_section, log)
    swing, T_swing = scenario_swing()
    stiff, T_stiff = scenario_stiff()
    fric, T_fric, sticking = scenario_friction()
    fid, peak, T_move = fidelity()
    ill = ill_conditioned()
    plot([(f"UR5e free swing from rest, {T_swing:g} s", swing, "(q, qd)"),
          (f"stiff chain, {T_stiff:g} s", stiff, "(q, qd)"),
          (f"UR5e with stick-slip friction, {T_fric:g} s", fric, "q")],
         os.path.join(HERE, "work_precision.png"))

    def summary(rows, tol):
        best = best_under(rows, tol)
        if not best:
            return "none"
        return ", ".join(f"{m} {r['wall'] * 1e3:.1f} ms ({r['setting']})"
                         for m, r in sorted(best.items(), key=lambda kv: kv[1]["wall"]))

    md = ["## Simulation: speed against error", "", stamp(),
          "`python bench/bench_simulate.py` (total "
          f"{time.perf_counter() - T0:.0f} s). Every method of `sd.simulate` over a range of "
          "tolerances (adaptive: rtol, atol = rtol/100) or steps (fixed step: dt). "
          "*final error*: max |(q, qd)(T) - reference|; *energy error*: max |E(t) - E(0) - "
          "W_act - W_diss| / energy scale; *RHS evals*: right-hand-side evaluations (for the "
          "fixed-step methods: stage evaluations); *dynamics states*: every state the "
          "dynamics was evaluated at, including the 2n+1 perturbed states of each batched "
          "Jacobian. Wall times include the Python overhead of each step (best of 3 for "
          "runs under 0.2 s). Plot: `bench/work_precision.png`.", "",
          f"### UR5e swinging freely from rest ({T_swing:g} s, q0 = {Q0.tolist()})", "",
          "Reference: DOP853, rtol 1e-13. The wrist whips up to ~100 rad/s, so errors grow "
          "fast; no dissipation.", "",
          f"Fastest run of each method with final error <= 1e-6: {summary(swing, 1e-6)}.", "",
          table(swing), "",
          f"### Stiff chain ({T_stiff:g} s, `stiff_chain_urdf()`: 20 kg .. 10 g links, damping "
          "2 .. 0.2 N m s/rad, damped modes up to ~1.6e4 /s)", "",
          "Reference: Radau, rtol 1e-11. Explicit methods are held to tiny steps by stability "
          "(semi-implicit Euler and RK4 diverge at 1 ms and are reported so); the implicit "
          "ones follow the slow motion, and so does symplectic Euler (first order), whose "
          "viscous damping, the source of the stiffness here, is implicit. The implicit "
          "methods use the analytical Jacobian (default); the same runs with finite "
          "differences are in the section \"Simulation: long-horizon energy, cost per step, "
          "Jacobians\".", "",
          f"Fastest run of each method with final error <= 1e-6: {summary(stiff, 1e-6)}.", "",
          table(stiff), "",
          f"### UR5e with friction, stick-slip ({T_fric:g} s)", "",
          "Viscous 0.8 .. 0.05 N m s/rad, Coulomb 4 .. 0.2 N m, Stribeck rise 2 .. 0.05 N m "
          "(rate 5 s/rad); torques = gravity compensation + 1.3 x static friction x sin(...). "
          f"Joints are stuck {100 * sticking:.0f} % of the joint-samples of the reference "
          "(stick-slip model, RK4 at 10 us; against RK4 at 20 us it differs by ~1e-5 rad). "
          "*final error* here is in the positions only (speeds jump at stick-slip "
          "transitions). The fixed-step methods integrate the stick-slip model; each "
          "transition falls on a step boundary, so they converge at first order. The adaptive "
          "ones integrate the regularized model (sgn -> tanh(qd / v_eps), default v_eps = "
          "1e-4 rad/s), whose distance from stick-slip shrinks with v_eps at no extra cost "
          "for Radau; RK45 and DOP853 are held to tiny steps by its stiffness (shown once, "
          "at v_eps = 1e-3).", "",
          f"Fastest run of each method with final position error <= 1e-4: {summary(fric, 1e-4)}.",
          "",
          table(fric), ""]
    if ill is not None:
        md += ["### Ill-conditioned chain: forward dynamics against 50 digits", "",
               f"`ill_conditioned_chain_urdf()`: cond(M) up to {ill['cond']:.2e}, but cond of the "
               f"diagonally scaled D^-1/2 M D^-1/2 only {ill['cond_h']:.2f}: the ill-conditioning "
               "is in the scales, to which both routes are invariant. Worst componentwise "
               "relative error of qdd over 4 states (reference: mpmath RNEA at 50 digits for the "
               "float64 model and inputs):", "",
               "| route | worst relative error | cond(M) eps |", "| --- | ---: | ---: |",
               f"| Cholesky of M (compiled) | {ill['cholesky']:.1e} | "
               f"{ill['cond'] * 2.2e-16:.1e} |",
               f"| QR of P = H T | {ill['qr']:.1e} | |",
               f"| Cholesky, NumPy reference path | {ill['cholesky, NumPy path']:.1e} | |", "",
               "(The NumPy reference forms the last joint's tiny torque, a 1e-5 kg rod spun about "
               "its own axis, from moments about the body origin, with some round-off "
               "cancellation; the compiled kernels do not.)", ""]
    md += [f"### Model fidelity: fast pick-and-place ({T_move:g} s, quintic, UR5e)", "",
           f"Rest to rest from q = {QA.tolist()} to {QB.tolist()} rad (peak joint speed "
           f"{np.max(np.abs(desired(T_move / 2, T_move)[1])):.2f} rad/s, about the UR5e's "
           "rated 3.14 rad/s); peak torques "
           f"{np.round(peak, 1).tolist()} N m. For each model of the inverse dynamics: its "
           "torque error against the full model over 400 samples, its cost per sample (one call "
           "per sample, as a control loop makes them; compiled kernels), and the largest "
           "tracking error when it is the feedforward of the same PD loop (Kp = 400 .. 2, Kd = "
           "40 .. 0.05), simulated with the full dynamics.", "",
           "| model | max torque error N m | / peak torque | RMS error N m | us per sample | "
           "time saved | max tracking error rad |",
           "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for name, emax, erel, rms, t, saved, track in fid:
        md.append(f"| {name} | {emax:.3f} | {100 * erel:.1f} % | {rms:.3f} | {t * 1e6:.2f} | "
                  f"{100 * saved:+.0f} % | {track:.2e} |")
    cheaper = [name.split(":")[0] for name, *_, saved, _ in fid[1:] if saved > 0.1]
    md += ["", "Recursive Newton-Euler computes all the terms in one O(n) pass, so dropping "
           "Coriolis and centrifugal terms or freezing the mass matrix saves no time (those "
           "models need the mass matrix, or a second call); "
           + (f"only {', '.join(cheaper)} is cheaper, " if cheaper else
              "not even gravity alone is markedly cheaper, ")
           + "and every simplification multiplies the tracking error on a fast move."]
    write_section("simulate", "\n".join(md))
    log(f"done in {time.perf_counter() - T0:.0f} s; wrote "
        f"{os.path.join(HERE, 'work_precision.png')}")


if __name__ == "__main__":
    main()
