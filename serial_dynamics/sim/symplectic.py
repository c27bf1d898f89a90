"""Symplectic Euler in momentum form: a fixed step that conserves the energy of a
conservative chain over long runs (its energy error stays bounded, with no drift).

Owns ``symplectic_euler`` (a stepper with the signature of ``fixed_step.STEPPERS``, see
``explicit``), and ``lean_step`` (the real-time path of ``FixedStepIntegrator.step``), with
``Robot.kinetic_energy_gradient`` (dT/dq). The step, with p = M(q) qd
(Hairer, Lubich & Wanner, GNI, Sec. VI.3, with H = 1/2 p^T M(q)^-1 p + V(q)):

    p1 = p0 + dt (dT/dq(q0, v) - g(q0) + J^T w + tau + delta(v)),   v = M(q0)^-1 p1
    q1 = q0 + dt v,   qd1 = M(q1)^-1 p1

solved for v by fixed-point iteration (M, its factor and g once per step; each iteration
one O(n) gradient and two triangular solves), to a correction below ``TOL`` (relative)
or round-off. On the compiled core the whole step is one call
(``core/energy.py: symplectic_euler``); otherwise (the NumPy backend, mimic joints) the
same equations in NumPy through the ``Robot`` facade. The friction: viscous damping
implicit (-beta v: stable at any step), the Coulomb (+ Stribeck) torques of sliding
joints and a moving base's torques held at their values at the start of the step (as
semi-implicit Euler holds every torque); stuck joints and joints held on a stop are
removed from the step (their rows of M are the identity, v = 0 there).
"""
from __future__ import annotations

import numpy as np

from ..core import flags as F
from ..core.status import BAD_LENGTH, NOT_CONVERGED, NOT_FINITE
from .equations import External, split
from ..model.errors import SimulationError
from .methods import advice
from .servo import symplectic_terms, symplectic_torque

TOL = 1e-14          # relative correction at which the fixed-point iteration stops
MAX_ITER = 50        # iterations; more is a SimulationError (the step is too large)


def step(integ, q, qd, f, wrench, beta, held):
    """One step: (q1, qd1, v). ``f``: generalized forces held over the step, ``wrench``
    (6,) or None, ``beta``: viscous coefficients (implicit), ``held``: (n,) 1.0 where a
    joint is held."""
    robot, dt = integ.robot, integ.dt
    n = robot.dof
    P = robot.compiled_chain
    if P is not None:
        from ..core import K
        q1, qd1, v = np.empty(n), np.empty(n), np.empty(n)
        w = _NO_W if wrench is None else np.asarray(wrench, dtype=float)
        status = K.symplectic_euler(P, q, qd, f, w, beta, held, dt, TOL, MAX_ITER,
                                    0 if wrench is None else F.WRENCH, q1, qd1, v)
        if status in (-NOT_FINITE, -BAD_LENGTH):
            _check_inputs(robot, q, qd, f, wrench)      # raises the ValueError naming it
    else:
        q1, qd1, v, status = _step_numpy(robot, q, qd, f, wrench, beta, held, dt)
    integ.eq.calls += 1
    integ.eq.states += 1
    if status < 0:
        t = integ.t_now
        if status == -NOT_CONVERGED:
            raise SimulationError(
                f"symplectic Euler: the fixed-point iteration did not converge within "
                f"{MAX_ITER} iterations at t = {t:.6g} s (the step is too large for the "
                f"speeds reached). {advice('symplectic_euler', dt)}", t, None, "newton")
        raise SimulationError(f"simulation diverged at t = {t:.6g} s: a NaN or Inf in the "
                              f"symplectic Euler step. {advice('symplectic_euler', dt)}",
                              t, None, "nan")
    integ.newton_iterations += status
    return q1, qd1, v


_NO_W = np.zeros(6)


def _check_inputs(robot, q, qd, f, wrench):
    """ValueError for an input of the wrong length or with a NaN/Inf (the step's -3, -2)."""
    n = robot.dof
    for name, x in (("q", q), ("qd", qd), ("tau", f)):
        if np.shape(x) != (n,):
            raise ValueError(f"{name} has {np.size(x)} values; give one per joint ({n}: "
                             f"{robot.joint_names})")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name} has a NaN or Inf entry; give finite numbers")
    if wrench is not None:
        if np.shape(wrench) != (6,):
            raise ValueError(f"wrench has shape {np.shape(wrench)}; expected (6,) ordered "
                             "[fx, fy, fz, mx, my, mz]")
        if not np.all(np.isfinite(wrench)):
            raise ValueError("wrench has a NaN or Inf entry; give finite numbers")


def _step_numpy(robot, q, qd, f, wrench, beta, held, dt):
    """The step of ``core/energy.py`` in NumPy through the facade (same equations)."""
    n = robot.dof
    free = held == 0.0

    def masked(M):
        M = np.array(M, dtype=float)
        M[~free, :] = 0.0
        M[:, ~free] = 0.0
        M[~free, ~free] = 1.0
        return M

    gw = robot.bias_torques(q, np.zeros(n), wrench)           # g(q0) - J^T w
    M = masked(robot.mass_matrix(q))
    p0 = np.where(free, M @ np.where(free, qd, 0.0), 0.0)
    if not (np.all(np.isfinite(p0)) and np.all(np.isfinite(f)) and np.all(np.isfinite(gw))):
        return q, qd, qd, -NOT_FINITE
    r = np.where(free, p0 + dt * (f - gw), 0.0)
    A = M + np.diag(np.where(free, dt * beta, 0.0))
    L = np.linalg.cholesky(A)
    v = np.where(free, qd, 0.0)
    prev, status = 0.0, -NOT_CONVERGED
    for k in range(1, MAX_ITER + 1):
        x = np.where(free, r + dt * robot.kinetic_energy_gradient(q, v), 0.0)
        x = np.linalg.solve(L.T, np.linalg.solve(L, x))
        diff, scale = np.max(np.abs(x - v)), 1.0 + np.max(np.abs(x))
        v = x
        if not np.isfinite(diff):
            return q, qd, v, -NOT_FINITE
        if diff <= TOL * scale or (k > 1 and diff >= prev and diff <= 1e-10 * scale):
            status = k
            break
        prev = diff
    p1 = np.where(free, M @ v, 0.0)
    q1 = q + dt * v
    M1 = masked(robot.mass_matrix(q1))
    return q1, np.linalg.solve(M1, p1), v, status


def symplectic_euler(integ, s, inputs, energy):
    """Symplectic Euler in momentum form (module doc); one dynamics evaluation at the
    start of the step (made by the caller) and one step call."""
    eq, dt = integ.eq, integ.dt
    n = eq.n
    integ.t_now = s.t
    wrench, base = split(s.w)
    f = np.array(s.tau, dtype=float)
    coulomb = np.zeros(n)
    if eq.coulomb_on and s.sign is not None:       # sliding joints: held at the start's value
        coulomb = -eq.diss.sliding_friction(s.qd) * s.sign
    beta_base = None
    if base is not None:                           # the base's torques, held over the step
        beta_base = (eq.bias(s.q, s.qd, External(None, base))
                     - eq.robot.bias_torques(s.q, s.qd))
        f = f - beta_base
    held = np.zeros(n) if s.stuck is None else s.stuck.astype(float)
    beta = eq.beta if eq.diss_on else np.zeros(n)
    q1, qd1, v = step(integ, np.asarray(s.q, float), np.asarray(s.qd, float), f + coulomb,
                      wrench, np.ascontiguousarray(beta, dtype=float), held)
    if not energy:
        return q1, qd1, np.zeros(3)
    # the discrete work: the forces of the step times the velocity of the position update
    p_ext = 0.0
    if wrench is not None:
        p_ext = float(eq.ext_power(s.q, v, wrench))
    if beta_base is not None:
        p_ext -= float(beta_base @ v)
    dW = dt * np.array([s.tau @ v, (coulomb - beta * v) @ v, p_ext])
    return q1, qd1, dW


def lean_step(integ, q, qd, tau, wrench, t, servo=None):
    """The real-time path (no Coulomb friction, no joint held): one step call. A ``servo``
    (``servo.Servo``) enters the step as an implicit damping and a force
    (``servo.symplectic_terms``); the torque it applied is left in ``integ.servo_torque``."""
    integ.t_now = 0.0 if t is None else t
    integ.stages += 1
    beta, f = integ.sym_beta, tau
    if servo is not None:
        beta_s, f_s = symplectic_terms(servo, q, integ.dt)
        beta, f = np.ascontiguousarray(beta + beta_s), np.ascontiguousarray(tau + f_s)
    q1, qd1, v = step(integ, q, qd, f, wrench, beta, integ.sym_held)
    if servo is not None:
        integ.servo_torque = symplectic_torque(servo, q, v, integ.dt)
    return q1, qd1
