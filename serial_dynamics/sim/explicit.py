"""Explicit fixed steps: semi-implicit Euler and classical Runge-Kutta.

Owns ``semi_implicit_euler`` and ``rk4``, two steppers with the signature of
``fixed_step.STEPPERS``: ``(integ, s, inputs, energy) -> (q1, qd1, dW)``, with ``integ``
the ``FixedStepIntegrator`` (``dt``, ``eq`` and its work counters), ``s`` the
``StepStart`` (its stuck joints and sliding signs are held over the step), ``inputs``
the ``Inputs`` and dW the increments of [W_act, W_diss, W_ext] over the step (zeros
unless ``energy``). Also ``euler_update``, the update of the real-time path.
"""
from __future__ import annotations

import numpy as np

from .steps import semi_implicit_euler_step


def euler_update(q, qd, qdd, dt):
    """(q1, qd1) one semi-implicit Euler step from (q, qd) with acceleration qdd, as new
    arrays (the inputs are left alone)."""
    q1, qd1 = np.array(q, dtype=float), np.array(qd, dtype=float)
    semi_implicit_euler_step(q1, qd1, qdd, dt)
    return q1, qd1


def semi_implicit_euler(integ, s, inputs, energy):
    """Semi-implicit Euler: velocity first, then position with the new velocity; one
    dynamics call (at the start of the step, made by the caller). Symplectic only for a
    constant mass matrix (its energy error drifts on an arm; ``symplectic.py`` is the
    symplectic method)."""
    dt = integ.dt
    q1, qd1 = euler_update(s.q, s.qd, s.qdd, dt)
    # the discrete work: torques held over the step times the motion
    dW = dt * integ.eq.power(s.q, qd1, s.tau, s.delta, s.w) if energy else np.zeros(3)
    return q1, qd1, dW


def rk4(integ, s, inputs, energy):
    """Classical Runge-Kutta (Kutta 1901): four stages, the first at the start of the step."""
    eq, dt, t, q, qd = integ.eq, integ.dt, s.t, s.q, s.qd

    def f(tt, qq, vv):
        tau_, w_ = inputs(tt, qq, vv)
        a, d = eq.accel(qq, vv, tau_, w_, s.stuck, s.sign)
        integ.stages += 1
        return a, (eq.power(qq, vv, tau_, d, w_) if energy else None)

    k1v, k1a = qd, s.qdd
    p1 = eq.power(q, qd, s.tau, s.delta, s.w) if energy else None
    k2a, p2 = f(t + dt / 2, q + dt / 2 * k1v, qd + dt / 2 * k1a)
    k2v = qd + dt / 2 * k1a
    k3a, p3 = f(t + dt / 2, q + dt / 2 * k2v, qd + dt / 2 * k2a)
    k3v = qd + dt / 2 * k2a
    k4a, p4 = f(t + dt, q + dt * k3v, qd + dt * k3a)
    k4v = qd + dt * k3a
    q1 = q + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    qd1 = qd + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    dW = dt / 6 * (p1 + 2 * p2 + 2 * p3 + p4) if energy else np.zeros(3)
    return q1, qd1, dW
