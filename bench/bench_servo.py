"""The joint servo's largest stable gain at 1 ms: the implicit servo of
``FixedStepIntegrator.step(..., servo=...)`` against an explicit PD (the same torque
computed from the state at the start of each step), on the UR5e.

Gains per joint from one natural frequency omega_n and one damping ratio zeta, with the
joint's own inertia M_ii at the target: Kp_i = M_ii omega_n^2, Kd_i = 2 zeta M_ii omega_n.
A run: 2000 steps of 1 ms from HOME to the target (gravity feed-forward g(q) at the
current state); stable when it neither diverges nor fails to halve the initial error over
its last 200 steps. omega_n h is bisected (in log) between 1e-2 and 1e3 for each method
and zeta. For a single joint, semi-implicit Euler with an explicit PD is stable only for
omega_n h < 2 (sqrt(zeta^2 + 1) - zeta) (the Jury conditions on its 2x2 step matrix); on
the arm, with Kp and Kd both proportional to diag(M_ii), each eigenvalue lambda of
M^-1 diag(M_ii) is a mode with omega_n sqrt(lambda) and zeta sqrt(lambda): the bound of the
linearization at the target is the smallest over the modes (a check of the measurement).
Also the time per step with and without the servo.

    .venv/bin/python bench/bench_servo.py            (about a minute)
"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _report import stamp, write_section  # noqa: E402

import serial_dynamics as sd  # noqa: E402
from serial_dynamics.sim.fixed_step import FixedStepIntegrator  # noqa: E402
from serial_dynamics.sim.methods import SimulationError  # noqa: E402
from serial_dynamics.sim.servo import servo  # noqa: E402

ROBOT = sd.default_robot()
HOME = np.array([0.0, -1.571, 1.571, -1.571, -1.571, 0.0])
TARGET = np.array([0.4, -1.2, 1.3, -1.4, -1.2, 0.3])
DT, STEPS, TAIL = 1e-3, 2000, 200
M_II = np.diag(ROBOT.mass_matrix(TARGET)).copy()
METHODS = ("semi_implicit_euler", "symplectic_euler")
ZETAS = (0.3, 0.7, 1.0)
W_LO, W_HI = 1e-2, 1e3        # omega_n h searched


def coupled_bound(zeta):
    """Largest omega_n h of the explicit PD linearized at the target (see the module doc)."""
    lam = np.linalg.eigvals(np.linalg.solve(ROBOT.mass_matrix(TARGET), np.diag(M_II))).real
    return float(np.min(2 * (np.sqrt(zeta**2 * lam + 1) - zeta * np.sqrt(lam)) / np.sqrt(lam)))


def gains(w, zeta):
    wn = w / DT
    return M_II * wn**2, 2 * zeta * M_II * wn


def stable(method, w, zeta, implicit):
    kp, kd = gains(w, zeta)
    integ = FixedStepIntegrator(ROBOT, method, DT, False)
    s = servo(kp, kd, TARGET)
    q, qd = HOME.copy(), np.zeros(6)
    e0, tail = np.max(np.abs(q - TARGET)), 0.0
    try:
        for k in range(STEPS):
            g = ROBOT.gravity_torques(q)
            if implicit:
                q, qd = integ.step(q, qd, g, servo=s)
            else:
                q, qd = integ.step(q, qd, g + kp * (TARGET - q) - kd * qd)
            if k >= STEPS - TAIL:
                tail = max(tail, np.max(np.abs(q - TARGET)))
    except SimulationError:
        return False
    return bool(np.all(np.isfinite(q)) and tail < 0.5 * e0)


def largest_stable(method, zeta, implicit, iterations=14):
    """The largest omega_n h in [W_LO, W_HI] found stable (bisection in log); W_HI if
    stable there, 0 if not even at W_LO."""
    if stable(method, W_HI, zeta, implicit):
        return W_HI
    if not stable(method, W_LO, zeta, implicit):
        return 0.0
    lo, hi = np.log(W_LO), np.log(W_HI)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(method, np.exp(mid), zeta, implicit) else (lo, mid)
    return float(np.exp(lo))


def step_time(method, with_servo, reps=3000):
    integ = FixedStepIntegrator(ROBOT, method, DT, False)
    kp, kd = gains(0.5, 0.7)
    s = servo(kp, kd, TARGET) if with_servo else None
    q, qd, tau = TARGET.copy(), np.zeros(6), ROBOT.gravity_torques(TARGET)
    integ.step(q, qd, tau, servo=s)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(reps):
            integ.step(q, qd, tau, servo=s)
        best = min(best, (time.perf_counter() - t0) / reps)
    return best


def main():
    ROBOT.warmup()
    rows = []
    for method in METHODS:
        for zeta in ZETAS:
            theory = 2 * (np.sqrt(zeta**2 + 1) - zeta)
            exp_w = largest_stable(method, zeta, False)
            imp_w = largest_stable(method, zeta, True)
            rows.append((method, zeta, theory, coupled_bound(zeta), exp_w, imp_w))
            print(method, zeta, theory, rows[-1][3], exp_w, imp_w, flush=True)
    times = {(m, sv): step_time(m, sv) for m in METHODS for sv in (False, True)}
    kp_base = lambda w: M_II[0] * (w / DT) ** 2   # noqa: E731
    kp_wrist = lambda w: M_II[5] * (w / DT) ** 2   # noqa: E731
    lines = [
        "## Joint servo: largest stable gain at 1 ms (`bench/bench_servo.py`)", "",
        stamp(),
        "UR5e, h = 1 ms, gains per joint from omega_n and zeta with the joint's inertia M_ii "
        f"at the target (M_ii = {', '.join(f'{x:.3g}' for x in M_II)} kg m^2, base to tip): "
        "Kp_i = M_ii omega_n^2, Kd_i = 2 zeta M_ii omega_n. A run is 2 s from HOME to the "
        "target with gravity feed-forward; stable = no divergence and the error halved over "
        "its last 0.2 s. omega_n h bisected in log between 1e-2 and 1e3 (14 halvings); "
        "'>= 1000' = stable at the top of the range. Explicit PD: the same torque from the "
        "state at the start of the step. Single-joint bound of semi-implicit Euler with an "
        "explicit PD: omega_n h < 2 (sqrt(zeta^2 + 1) - zeta); on the arm, the bound of the "
        "linearization at the target (modes of M^-1 diag(M_ii), see the script).", "",
        "| method | zeta | single-joint bound | arm, linearized bound | explicit PD: largest stable omega_n h (Kp base / wrist 3, N m/rad) | implicit servo: largest stable omega_n h (Kp base / wrist 3) | ratio implicit / explicit |",
        "| --- | --- | --- | --- | --- | --- | --- |"]
    for method, zeta, theory, bound, e, i in rows:
        ishow = ">= 1000" if i >= W_HI else f"{i:.3g}"
        lines.append(f"| {method} | {zeta} | {theory:.3f} | {bound:.3f} | {e:.3f} ({kp_base(e):.3g} / "
                     f"{kp_wrist(e):.3g}) | {ishow} ({kp_base(i):.3g} / {kp_wrist(i):.3g}) | "
                     f"{'>= ' if i >= W_HI else ''}{i / e:.0f} |" if e > 0 else "| - |")
    lines += ["", "Time per step (`FixedStepIntegrator.step`, best of 3 x 3000, warm):", "",
              "| method | no servo (us) | implicit servo (us) | ratio |", "| --- | --- | --- | --- |"]
    for m in METHODS:
        a, b = times[(m, False)] * 1e6, times[(m, True)] * 1e6
        lines.append(f"| {m} | {a:.1f} | {b:.1f} | {b / a:.2f} |")
    lines += ["", "The servo of semi-implicit Euler costs a mass matrix and a linear solve a "
              "step (besides the forward dynamics); in symplectic Euler it enters the step "
              "as an implicit damping and a force (no extra call)."]
    write_section("servo", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
