"""Long-horizon energy of the fixed-step methods, their cost per step, and the implicit
methods' Jacobians before (finite differences) and after (analytical): the section
"simulate_energy" of bench/BENCHMARKS.md, written by ``bench_simulate.py`` (alone with
``--energy-only``). Plot: bench/energy_long_horizon.png.
"""
from __future__ import annotations

import time

import numpy as np

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import double_pendulum_urdf, stiff_chain_urdf
from serial_dynamics.sim.fixed_step import FixedStepIntegrator
from serial_dynamics.sim.methods import FIXED_STEP


DOUBLE_PENDULUM = double_pendulum_urdf()      # the double pendulum
UR5E_HANGING = np.array([0.0, np.pi / 2, 0.0, -1.2726512, np.pi / 2, 0.0])   # V minimal


def periods(robot, q_rest):
    """Periods (s) of the small oscillations about q_rest: M x'' + K x = 0, K = dg/dq."""
    h = 1e-6
    K = np.array([(robot.gravity_torques(q_rest + h * e) - robot.gravity_torques(q_rest - h * e))
                  / (2 * h) for e in np.eye(robot.dof)]).T
    w2 = np.linalg.eigvals(np.linalg.solve(robot.mass_matrix(q_rest), 0.5 * (K + K.T))).real
    w2 = w2[w2 > 1e-9 * w2.max()]
    return np.sort(2 * np.pi / np.sqrt(w2))[::-1]


def run_energy(robot, method, q0, q_rest, dt, nsteps, every):
    """(t, |E - E0| / swing every ``every`` steps, s per step): FixedStepIntegrator.step
    without dissipation, the energy evaluated outside the timed steps' count."""
    integ = FixedStepIntegrator(robot, method, dt, dissipation=False)
    q, qd, zero = np.array(q0, dtype=float), np.zeros(robot.dof), np.zeros(robot.dof)
    E0 = float(robot.total_energy(q, qd))
    swing = E0 - float(robot.potential_energy(q_rest))
    ts, errs, spent = [], [], 0.0
    for k in range(0, nsteps, every):
        t0 = time.perf_counter()
        for _ in range(every):
            q, qd = integ.step(q, qd, zero)
        spent += time.perf_counter() - t0
        ts.append((k + every) * dt)
        errs.append(abs(float(robot.total_energy(q, qd)) - E0) / swing)
    return np.array(ts), np.array(errs), spent / nsteps


def tenths(err):
    m = max(1, err.size // 10)
    return float(err[:m].max()), float(err[-m:].max())


def long_horizon(n_periods=1e4, steps_per_period=40, log=print):
    """Each fixed-step method on the double pendulum at small amplitude (regular,
    quasi-periodic motion) over ``n_periods`` periods of its slow mode."""
    robot = sd.load_urdf(DOUBLE_PENDULUM)
    q_rest = np.zeros(2)
    T = periods(robot, q_rest)
    dt = T[0] / steps_per_period
    nsteps = int(n_periods * steps_per_period)
    out = {}
    for method in FIXED_STEP:
        t, err, per_step = run_energy(robot, method, [0.1, -0.05], q_rest, dt, nsteps,
                                      max(1, nsteps // 4000))
        out[method] = (t, err, per_step)
        first, last = tenths(err)
        log(f"long horizon: {method:20s} {per_step * 1e6:6.1f} us/step  first tenth "
            f"{first:.2e}  last tenth {last:.2e}")
    return robot, T, dt, nsteps, out


def targets(log=print):
    """Issue 12's targets at 2 ms over 100 s: the double pendulum from q0 = (0.6, -0.4)
    at rest, and the UR5e hanging at small amplitude."""
    rows = []
    cases = (("double pendulum, q0 = (0.6, -0.4)", sd.load_urdf(DOUBLE_PENDULUM),
              [0.6, -0.4], np.zeros(2)),
             ("UR5e hanging, 0.05-0.1 rad", sd.default_robot(),
              UR5E_HANGING + np.array([0.1, 0.08, -0.1, 0.1, 0.05, 0.0]), UR5E_HANGING))
    for name, robot, q0, q_rest in cases:
        for method in FIXED_STEP:
            t, err, per_step = run_energy(robot, method, q0, q_rest, 2e-3, 50000, 10)
            first, last = tenths(err)
            rows.append((name, method, first, last, per_step))
            log(f"targets: {name:36s} {method:20s} first {first:.2e} last {last:.2e} "
                f"ratio {last / first:.2f}")
    return rows


def cost_per_step(log=print, steps=3000):
    """s per FixedStepIntegrator.step of each method: the UR5e swinging, no dissipation."""
    robot = sd.default_robot().warmup()
    q0 = np.array([0.3, -1.0, 0.8, -0.5, 0.4, 0.2])
    out = {}
    for method in FIXED_STEP:
        integ = FixedStepIntegrator(robot, method, 1e-3, dissipation=False)
        best = np.inf
        for _ in range(3):
            q, qd, zero = q0.copy(), np.zeros(6), np.zeros(6)
            t0 = time.perf_counter()
            for _ in range(steps):
                q, qd = integ.step(q, qd, zero)
            best = min(best, (time.perf_counter() - t0) / steps)
        out[method] = best
        log(f"cost: {method:20s} {best * 1e6:.1f} us/step")
    return out


def jacobian_before_after(log=print):
    """The implicit methods on the stiff chain with both Jacobian routes."""
    robot = sd.load_urdf(stiff_chain_urdf())
    q0 = np.array([0.3, 0.8, -0.5, 0.6])
    T = 0.5
    ref = sd.simulate(robot, T, q0, None, method="Radau", rtol=1e-11, atol=1e-13)
    grid = [(m, dict(rtol=r, atol=r * 1e-2)) for m in ("Radau", "BDF", "LSODA")
            for r in (1e-5, 1e-7, 1e-9)]
    grid += [("implicit_midpoint", dict(dt=d)) for d in (2e-3, 1e-3, 5e-4)]
    rows = []
    for method, kw in grid:
        setting = ", ".join(f"{k} = {v:g}" for k, v in kw.items())
        row = [method, setting]
        for jac in ("finite_differences", "analytical"):
            best, res = np.inf, None
            for _ in range(3):
                t0 = time.perf_counter()
                res = sd.simulate(robot, T, q0, None, method=method, jacobian=jac, **kw)
                best = min(best, time.perf_counter() - t0)
            err = float(np.abs(np.r_[res.q[-1] - ref.q[-1], res.qd[-1] - ref.qd[-1]]).max())
            row.append((best, res.stats.nfev, res.stats.njev, res.stats.dynamics_states, err))
        rows.append(row)
        (tb, _, _, sb, eb), (ta, _, _, sa, ea) = row[2], row[3]
        log(f"jacobian: {method:18s} {setting:26s} FD {tb * 1e3:6.1f} ms {sb:6d} states "
            f"{eb:.1e} | analytical {ta * 1e3:6.1f} ms {sa:6d} states {ea:.1e}")
    return rows


def plot(long, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    robot, T, dt, nsteps, out = long
    fig, ax = plt.subplots(figsize=(8, 5))
    for method, (t, err, _) in out.items():
        ax.loglog(t / T[0], np.maximum(err, 1e-16), label=method, lw=0.8)
    ax.set_xlabel("time / slow period")
    ax.set_ylabel("|E - E0| / (E0 - V_min)")
    ax.set_title(f"double pendulum at small amplitude, dt = slow period / "
                 f"{round(T[0] / dt)} = {dt * 1e3:.1f} ms", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def section(long, target_rows, cost, jac_rows, stamp, seconds):
    robot, T, dt, nsteps, out = long
    md = ["## Simulation: long-horizon energy, cost per step, Jacobians", "", stamp,
          f"`python bench/bench_simulate.py --energy-only` ({seconds:.0f} s; the full script "
          "also writes it). Plot: `bench/energy_long_horizon.png`.", "",
          "### Energy over 10^4 periods (regular motion)", "",
          f"The double pendulum of issue 12 (two 1 m, 1 kg links, 0.02 kg m^2 about their "
          f"centres) from q0 = (0.1, -0.05) rad at rest: small oscillations, quasi-periodic, "
          f"periods {T[0]:.3f} s and {T[1]:.3f} s. Every method at dt = slow period / "
          f"{round(T[0] / dt)} = {dt * 1e3:.2f} ms for {nsteps} steps "
          f"({nsteps * dt:.0f} s, 10^4 slow periods), no dissipation, stepped with "
          "`FixedStepIntegrator.step`. Energy error |E - E0| / (E0 - V_min).", "",
          "| method | first tenth | last tenth | last / first | us per step |",
          "| --- | ---: | ---: | ---: | ---: |"]
    for method, (t, err, per_step) in out.items():
        first, last = tenths(err)
        md.append(f"| {method} | {first:.2e} | {last:.2e} | {last / first:.2f} | "
                  f"{per_step * 1e6:.1f} |")
    md += ["", "### Issue 12's targets: 100 s at dt = 2 ms", "",
           "Energy error over the first and the last tenth of the run (same measure). "
           "Target for symplectic_euler: last / first <= 1.2.", "",
           "| case | method | first tenth | last tenth | last / first |",
           "| --- | --- | ---: | ---: | ---: |"]
    for name, method, first, last, _ in target_rows:
        md.append(f"| {name} | {method} | {first:.2e} | {last:.2e} | {last / first:.2f} |")
    base = cost["semi_implicit_euler"]
    md += ["", "### Cost per step (UR5e, `FixedStepIntegrator.step`, no dissipation)", "",
           "Target: symplectic_euler <= 2.5 x semi_implicit_euler.", "",
           "| method | us per step | / semi_implicit_euler |", "| --- | ---: | ---: |"]
    for method, c in cost.items():
        md.append(f"| {method} | {c * 1e6:.1f} | {c / base:.2f} |")
    md += ["", "### Implicit methods on the stiff chain: Jacobian by finite differences "
           "(before) and analytical (after)", "",
           "`sd.simulate(..., jacobian=\"finite_differences\" | \"analytical\")`, stiff chain "
           "of the work-precision report (0.5 s). *states*: dynamics states evaluated (a "
           "finite-difference Jacobian counts its 2n + 1 = 9 states, an analytical one 1 call "
           "of the derivatives of forward dynamics); wall: best of 3. The implicit midpoint "
           "rule also starts Newton from the explicit Euler prediction now (both routes).", "",
           "| method | setting | FD: wall ms | FD: RHS evals | FD: Jacobians | FD: states | "
           "FD: error | analytical: wall ms | analytical: RHS evals | analytical: Jacobians | "
           "analytical: states | analytical: error |",
           "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for method, setting, b, a in jac_rows:
        md.append(f"| {method} | {setting} | {b[0] * 1e3:.1f} | {b[1]} | {b[2]} | {b[3]} | "
                  f"{b[4]:.1e} | {a[0] * 1e3:.1f} | {a[1]} | {a[2]} | {a[3]} | {a[4]:.1e} |")
    return "\n".join(md)


def main(here, stamp, write_section, log=print, t0=None):
    t0 = time.perf_counter() if t0 is None else t0
    long = long_horizon(log=log)
    target_rows = targets(log=log)
    cost = cost_per_step(log=log)
    jac_rows = jacobian_before_after(log=log)
    import os
    plot(long, os.path.join(here, "energy_long_horizon.png"))
    write_section("simulate_energy", section(long, target_rows, cost, jac_rows, stamp(),
                                             time.perf_counter() - t0))

