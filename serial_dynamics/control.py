"""The library's model-based joint control laws, as pure functions (no ROS): the
computed-torque controller node and ``sweep.monte_carlo`` both call them.

With e = q_d - q, edot = qd_d - qd and the feed-forward acceleration qdd_d:

    computed_torque       tau = M(q) (qdd_d + Kp e + Kd edot) + b(q, qd)
                          (inverse dynamics at the commanded acceleration: one Newton-Euler call)
    pd_gravity            tau = Kp' e + Kd' edot + g(q)
    gravity_compensation  tau = g(q)
                          [- delta(qd) in each mode when compensating the joint dissipation]

(Siciliano et al., Robotics: Modelling, Planning and Control, 2009, Sec. 8.5.2 (PD with
gravity compensation) and 8.5.3 (inverse dynamics control)). Kp, Kd are in 1/s^2 and 1/s
for computed torque (they shape the error dynamics e'' + Kd e' + Kp e = 0), in N m/rad and
N m s/rad for pd_gravity (``pd_gains`` gives the defaults: kp, kd scaled by the effective
inertia at the pose, within the bound below).

The stability bound of a PD law sampled at the control period h, per joint, at a pose.

A joint with effective inertia m under an explicit PD (the torque from the state at the
start of each period h, held over it) is stable only for

    omega_n h < 2 (sqrt(zeta^2 + 1) - zeta),   omega_n = sqrt(Kp/m), zeta = Kd / (2 sqrt(Kp m))

(docs/simulation.md, "Why": the Jury conditions on the 2x2 step matrix), which, squared
out, is the same as

    Kp h^2 + 2 Kd h < 4 m                      (Kp = 0 included: Kd h < 2 m)

The inertia a joint's own torque meets, the others free, is m_i = 1 / (M(q)^-1)_ii
(the effective inertia at the pose); it is at most M_ii(q) and can be many times smaller:
on the xArm7 stretched upright (q = 0) the first and third axes line up and
M_ii(0) / m_i is about 14 for both. Gains scaled by M_ii then pass the bound at 500 Hz
only just (0.22 against 0.27), and any delay of the state (a queue, a busy core) takes
the loop over it. The bound has no margin for the state's delay: keep well inside it.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg

MODES = ("computed_torque", "pd_gravity", "gravity_compensation")


def _inverse_mass_matrix(robot, q) -> np.ndarray:
    M = robot.mass_matrix(q)
    return scipy.linalg.cho_solve(scipy.linalg.cho_factor(M), np.eye(len(M)))


def effective_inertia(robot, q) -> np.ndarray:
    """m_i = 1 / (M(q)^-1)_ii for every joint (kg m^2; kg): the inertia joint i's torque
    meets with the other joints free."""
    return 1.0 / np.diag(_inverse_mass_matrix(robot, q))


def pd_gains(robot, q, kp, kd):
    """pd_gravity's gains at q from the bandwidth gains kp (1/s^2) and kd (1/s):
    Kp' = kp m / lam, Kd' = kd m / lam, m the effective inertias and lam the largest
    eigenvalue of D^1/2 M^-1 D^1/2 (D = diag(m); unit diagonal, lam >= 1: the coupling of
    the joints; about 2 on the xArm7). Linearized at rest with gravity compensated, the arm
    M x'' = -Kp' x - Kd' x' then has modes x'' + mu kd x' + mu kp x = 0 with 0 < mu <= 1
    (Kp', Kd' are both proportional to D), so the bound kp h^2 + 2 kd h < 4 holds for every
    mode at every pose whenever it holds for kp, kd."""
    Minv = _inverse_mass_matrix(robot, q)
    m = 1.0 / np.diag(Minv)
    s = np.sqrt(m)
    lam = np.linalg.eigvalsh(s[:, None] * Minv * s[None, :])[-1]
    return kp * m / lam, kd * m / lam


def smallest_inertia(kp, kd, h) -> np.ndarray:
    """The effective inertia below which gains kp (N m/rad) and kd (N m s/rad) at the
    period h (s) are unstable: (Kp h^2 + 2 Kd h) / 4 (the bound above)."""
    return (np.asarray(kp, float) * h * h + 2.0 * np.asarray(kd, float) * h) / 4.0


def beyond(kp, kd, m, h) -> np.ndarray:
    """Indices of the joints whose gains are at or beyond the bound at inertias ``m``."""
    return np.flatnonzero(smallest_inertia(kp, kd, h) >= np.asarray(m, float))


def explain(name, kp, kd, m, h, what="pd.kp, pd.kd") -> str:
    """One joint's excess over the bound, in the terms of docs/simulation.md, with the fix."""
    wh = np.sqrt(kp / m) * h
    zeta = kd / (2.0 * np.sqrt(kp * m)) if kp > 0 else np.inf
    bound = 2.0 * (np.sqrt(zeta ** 2 + 1.0) - zeta) if np.isfinite(zeta) else 0.0
    scale = 4.0 * m / (kp * h * h + 2.0 * kd * h)
    return (f"{what} of {name} ({kp:.4g}, {kd:.4g}) are beyond the stability bound of an "
            f"explicit PD at {1.0 / h:.4g} Hz with the effective inertia {m:.4g} at this pose: "
            f"omega_n h = {wh:.3g}, the bound 2(sqrt(zeta^2+1) - zeta) = {bound:.3g} "
            f"(zeta = {zeta:.3g}); i.e. Kp h^2 + 2 Kd h = {kp * h * h + 2 * kd * h:.4g} "
            f">= 4 m = {4 * m:.4g}. Scale both by less than {scale:.3g}, or raise control_rate")


def torque(robot, mode, q, qd, e, ed, qdd_ff, kp, kd, compensate=False):
    """The joint torques of law ``mode`` (one of MODES) at the state (q, qd), tracking error
    (e, ed), feed-forward acceleration qdd_ff, with that law's gains kp, kd."""
    if mode == "computed_torque":
        tau = robot.inverse_dynamics(q, qd, qdd_ff + kp * e + kd * ed)
    elif mode == "pd_gravity":
        tau = kp * e + kd * ed + robot.gravity_torques(q)
    elif mode == "gravity_compensation":
        tau = robot.gravity_torques(q)
    else:
        raise ValueError(f"control law {mode!r} unknown; use one of {', '.join(MODES)}")
    if compensate:
        tau = tau - robot.dissipation_torques(qd)
    return tau
