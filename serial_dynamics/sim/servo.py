"""A joint PD servo integrated implicitly: stable at any gain and step.

Owns ``Servo`` (gains and targets per joint), ``servo`` (builds one, with the masks),
``euler_servo`` (the servo torque of a semi-implicit Euler step) and ``symplectic_terms``
(the same servo folded into the symplectic Euler step). The servo torque

    tau_s = Kp (q* - q1) + Kd (qd* - qd1)

is evaluated at the END of the step (backward Euler in the servo's terms; Hairer & Wanner,
Solving ODEs II, Sec. IV.3: A-stable), with q1 = q0 + dt qd1. The velocity update of
semi-implicit Euler, M (qd1 - qd0) = dt (tau - b + tau_s), becomes

    (M + dt Kd + dt^2 Kp) qd1 = M qd0 + dt (tau - b + Kp (q* - q0) + Kd qd*)

-- a PD that stays stable at any Kp, Kd >= 0 (an explicit PD, the torque from the state at
the start of the step, is stable with semi-implicit Euler on one joint only for
omega_n dt < 2 (sqrt(zeta^2 + 1) - zeta), and lower on a coupled arm: bench/bench_servo.py).
Only Kp, Kd are implicit: the rest of the dynamics keeps its method's treatment.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Servo(NamedTuple):
    """Per-joint PD servo, arrays (n,): gains ``kp`` (N m/rad; N/m) and ``kd`` (N m s/rad;
    N s/m), 0 where a joint has no such term; targets ``q_target``, ``qd_target``."""

    kp: np.ndarray
    kd: np.ndarray
    q_target: np.ndarray
    qd_target: np.ndarray


def servo(kp, kd, q_target=None, qd_target=None, n=None):
    """A ``Servo`` with the masks applied. A NaN (or None: all joints) target means no
    target there: no position target -> no Kp term; a position target without a velocity
    target servoes the velocity to 0; neither -> the joint is not servoed (no torque).
    ``kp``, ``kd``: one value or one per joint, finite and >= 0."""
    if n is None:
        n = np.size(q_target) if q_target is not None else np.size(qd_target)
    qt = np.full(n, np.nan) if q_target is None else np.array(q_target, dtype=float)
    vt = np.full(n, np.nan) if qd_target is None else np.array(qd_target, dtype=float)
    gains = []
    for name, g in (("kp", kp), ("kd", kd)):
        g = np.asarray(g, dtype=float).ravel()
        if g.size not in (1, n) or not np.all(np.isfinite(g)) or np.any(g < 0):
            raise ValueError(f"servo {name} = {g.tolist()}: give one value or one per joint "
                             f"({n}), finite and >= 0")
        gains.append(np.broadcast_to(g, (n,)).copy())
    for name, x in (("q_target", qt), ("qd_target", vt)):
        if x.shape != (n,):
            raise ValueError(f"servo {name} has {x.size} values; give one per joint ({n})")
        if np.any(np.isinf(x)):
            raise ValueError(f"servo {name} has an Inf entry; give finite numbers (NaN: none)")
    has_q, has_v = ~np.isnan(qt), ~np.isnan(vt)
    kp_, kd_ = np.where(has_q, gains[0], 0.0), np.where(has_q | has_v, gains[1], 0.0)
    return Servo(kp_, kd_, np.where(has_q, qt, 0.0), np.where(has_v, vt, 0.0))


def euler_servo(M, q, qd, qdd, s, dt):
    """(tau_s, y): the servo torque of a semi-implicit Euler step from (q, qd) whose free
    acceleration (every other torque applied) is ``qdd``, and the acceleration it adds,
    y = M^-1 tau_s. With (q1f, qd1f) the step's end without the servo, the end with it is
    qd1 = qd1f + dt y, q1 = q1f + dt^2 y, and tau_s = Kp (q* - q1) + Kd (qd* - qd1):

        (M + D) y = e,   e = Kp (q* - q1f) + Kd (qd* - qd1f),   D = dt Kd + dt^2 Kp
    """
    qd1f = qd + dt * qdd                       # semi-implicit Euler without the servo
    q1f = q + dt * qd1f
    e = s.kp * (s.q_target - q1f) + s.kd * (s.qd_target - qd1f)
    D = dt * s.kd + dt * dt * s.kp
    y = np.linalg.solve(np.asarray(M, dtype=float) + np.diag(D), e)   # (M + dt Kd + dt^2 Kp) y = e
    return e - D * y, y                        # tau_s = M y = e - D y


def symplectic_terms(s, q, dt):
    """(beta_s, f_s): the servo as an implicit damping and a constant force of the
    symplectic Euler step, whose momentum update uses the velocity v of the position
    update (q1 = q0 + dt v): Kp (q* - q0 - dt v) + Kd (qd* - v) = f_s - beta_s v with
    beta_s = Kd + dt Kp, f_s = Kp (q* - q0) + Kd qd*."""
    return s.kd + dt * s.kp, s.kp * (s.q_target - q) + s.kd * s.qd_target


def symplectic_torque(s, q, v, dt):
    """The servo torque applied by the symplectic Euler step: Kp (q* - q0 - dt v) + Kd (qd* - v)."""
    return s.kp * (s.q_target - (q + dt * v)) + s.kd * (s.qd_target - v)
