"""Forward-dynamics simulation of a serial chain.

State equations (x = [q, qd]):

    qd' = qdd = M(q)^-1 (tau + delta(qd) - b(q, qd) + J(q)^T w)

with tau the applied (actuator) torques, delta the dissipative joint torques
(``Dissipation``), b the bias torques and w a wrench on the tip. Every dynamics call
goes through the ``Robot`` facade (``forward_dynamics``, ``mass_matrix``,
``bias_torques`` ...), so faster kernels behind it speed this module up unchanged.

Methods (see docs/simulation.md):

- adaptive, by scipy.integrate: "RK45", "DOP853" (explicit Runge-Kutta), "Radau", "BDF"
  (implicit, for stiff chains; Jacobian by one batched forward-dynamics call over
  perturbed states), "LSODA" (automatic stiff / non-stiff switching). Coulomb friction
  is regularized (``Dissipation.smooth_torque``).
- fixed step (``dt``), for real time: "semi_implicit_euler" (symplectic Euler),
  "rk4" (classical Runge-Kutta), "implicit_midpoint" (symplectic, A-stable, Newton with
  a batched finite-difference Jacobian). Coulomb friction with stick-slip: a joint at
  rest sticks while the torque that holds it is within its static friction.
  ``position_limits=True`` adds hard stops at the URDF joint limits (plastic impacts,
  ``FixedStepIntegrator._stop``).

Energies are integrated alongside: the work of the actuators int tau.qd dt, of the
dissipation int delta.qd dt (<= 0) and of the tip wrench int (J^T w).qd dt, so that
E(t) - E(0) = W_act + W_diss + W_ext along any run. Divergence (NaN/Inf, a speed
beyond any physical bound, energy growing without input) raises ``SimulationError``.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import numpy as np

from .dissipation import Dissipation

ADAPTIVE = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
FIXED_STEP = ("semi_implicit_euler", "rk4", "implicit_midpoint")
METHODS = ADAPTIVE + FIXED_STEP
IMPLICIT = ("Radau", "BDF", "LSODA", "implicit_midpoint")
DEFAULT_RTOL, DEFAULT_ATOL, DEFAULT_DT = 1e-6, 1e-9, 1e-3
REST_SPEED = 1e-9            # rad/s (m/s): a Coulomb joint slower than this is at rest
SPEED_BOUND_FACTOR = 1e3    # divergence: |qd| > 1000 x velocity limit (1e5 where none)
PRISMATIC_BOUND = 1e3        # m: no prismatic joint travels a kilometre
JACOBIAN_AGE = 20            # implicit midpoint: steps a Jacobian is reused at most
NEWTON_ACCEPT = 1e-7         # implicit midpoint: largest relative correction accepted at the
                             # last Newton iteration (the target is newton_tol = 1e-10)


class SimulationError(RuntimeError):
    """The simulation diverged (NaN/Inf, a state out of bounds, energy growing).

    Attributes: ``t`` (s, time of detection), ``joint`` (name or None), ``reason``.
    """

    def __init__(self, message, t=None, joint=None, reason=None):
        super().__init__(message)
        self.t, self.joint, self.reason = t, joint, reason


def _advice(method, dt=None):
    if method in FIXED_STEP:
        smaller = f"a smaller step (dt = {dt / 10:.3g} s)" if dt else "a smaller step"
        alt = ("'Radau' or a smaller step" if method == "implicit_midpoint"
               else "the implicit method 'implicit_midpoint' (or 'Radau')")
        return f"Try {smaller} or {alt}."
    if method in ("RK45", "DOP853"):
        return "Try a tighter tolerance (rtol) or an implicit method ('Radau', 'BDF', 'LSODA')."
    return "Try a tighter tolerance (rtol) or a smaller max_step."


# ----------------------------------------------------------------------------- inputs
def _input_fn(value, width, name, duration, joint_names):
    """Normalize a torque/wrench spec into (f(t, q, qd) -> (width,) array, kind).

    kind: "zero", "const" or "fn" (time-varying or state feedback)."""
    if value is None:
        zero = np.zeros(width)
        return (lambda t, q, qd: zero), "zero"
    if callable(value):
        def fn(t, q, qd, _f=value):
            out = np.asarray(_f(t, q, qd), dtype=float)
            if out.shape != (width,):
                out = np.broadcast_to(out, (width,)) if out.ndim == 0 else out
                if out.shape != (width,):
                    raise ValueError(f"the {name} callable returned shape {out.shape}; it must "
                                     f"return ({width},) values")
            if not np.all(np.isfinite(out)):
                k = int(np.flatnonzero(~np.isfinite(out))[0])
                who = f"joint {joint_names[k]!r}" if width == len(joint_names) else f"entry {k}"
                raise SimulationError(f"the {name} callable returned {out[k]} for {who} at "
                                      f"t = {t:.6g} s; fix the controller (simulation stopped)",
                                      t, joint_names[k] if who.startswith("joint") else None,
                                      "input")
            return out
        return fn, "fn"
    if isinstance(value, tuple) and len(value) == 2:          # (times, samples)
        ts, vals = np.asarray(value[0], float), np.asarray(value[1], float)
        if ts.ndim != 1 or vals.shape != (ts.size, width) or ts.size < 2 or \
                np.any(np.diff(ts) <= 0):
            raise ValueError(f"{name} given as (times, samples) needs increasing times (K,) and "
                             f"samples ({ts.size}, {width}); got {ts.shape}, {vals.shape}")
        return _interp_fn(ts, vals), "fn"
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 or a.shape == (width,):
        const = np.broadcast_to(a, (width,)).copy()
        if not np.all(np.isfinite(const)):
            raise ValueError(f"{name} has a NaN or Inf entry")
        if not np.any(const):
            return (lambda t, q, qd: const), "zero"
        return (lambda t, q, qd: const), "const"
    if a.ndim == 2 and a.shape[1] == width and a.shape[0] >= 2:   # uniform samples over [0, T]
        return _interp_fn(np.linspace(0.0, duration, a.shape[0]), a), "fn"
    what = f"one per joint {joint_names}" if name == "torque" else "[fx, fy, fz, mx, my, mz]"
    raise ValueError(f"{name} has shape {a.shape}; give a scalar, ({width},) values ({what}), "
                     f"(K, {width}) samples over [0, duration], (times, samples), or a "
                     "callable f(t, q, qd)")


def _interp_fn(ts, vals):
    if not np.all(np.isfinite(vals)):
        raise ValueError("input samples have a NaN or Inf entry")

    def fn(t, q, qd):   # piecewise linear, held constant outside the samples
        k = int(np.clip(np.searchsorted(ts, t) - 1, 0, ts.size - 2))
        s = np.clip((t - ts[k]) / (ts[k + 1] - ts[k]), 0.0, 1.0)
        return (1.0 - s) * vals[k] + s * vals[k + 1]
    return fn


# ----------------------------------------------------------------------------- state equations
class _Equations:
    """The state equations of one robot with one dissipation model; counts dynamics calls."""

    def __init__(self, robot, dissipation, smoothing=1e-4):
        self.robot = robot
        self.n = n = robot.dof
        if dissipation is True:
            diss = robot.dissipation
        elif dissipation is False or dissipation is None:
            diss = Dissipation.none(robot.joint_names)
        elif isinstance(dissipation, Dissipation):
            diss = dissipation
        else:
            raise ValueError("dissipation must be True, False or a serial_dynamics.Dissipation")
        if tuple(diss.joint_names) != tuple(robot.joint_names):
            raise ValueError(f"dissipation is for joints {list(diss.joint_names)}, the robot has "
                             f"{robot.joint_names}")
        self.diss = diss
        self.diss_on = diss.enabled
        self.beta = np.asarray(diss.viscous, float)
        self.viscous_on = bool(np.any(self.beta > 0))
        self.tau_s = np.asarray(diss.static_friction, float)
        self.coulomb = self.tau_s > 0                      # joints with Coulomb friction
        self.coulomb_on = bool(np.any(self.coulomb))
        if not smoothing > 0:
            raise ValueError(f"friction_smoothing = {smoothing}; give a speed > 0 (rad/s)")
        self.v_eps = float(smoothing)
        self.names = list(robot.joint_names)
        vl = np.asarray(robot.velocity_limit, float)
        self.speed_bound = np.where(np.isfinite(vl) & (vl > 0), SPEED_BOUND_FACTOR * vl, 1e5)
        self.prismatic = np.array([t == "prismatic" for t in robot.joint_types])
        self.calls = 0       # calls to the dynamics
        self.states = 0      # states evaluated (a batch of N counts N)

    # -- dissipation
    def delta(self, qd, sign=None, smooth=False):
        """Dissipative torques: exact (sgn(0) = 0), smooth (tanh) or with fixed sliding signs."""
        if not self.diss_on:
            return np.zeros_like(qd)
        if not self.coulomb_on:
            return -self.beta * qd
        if smooth:
            return self.diss.smooth_torque(qd, self.v_eps)
        if sign is None:
            return self.diss.torque(qd)
        return -self.beta * qd - self.diss.sliding_friction(qd) * sign

    # -- dynamics through the facade
    def fd(self, q, qd, tau, w=None):
        self.calls += 1
        self.states += 1 if np.ndim(q) == 1 else len(q)
        return self.robot.forward_dynamics(q, qd, tau, w)

    def accel(self, q, qd, tau, w=None, stuck=None, sign=None, smooth=False, coulomb=None):
        """qdd and delta for (batches of) states. ``stuck``: joints held by static friction
        (qdd = 0; their delta is the holding torque), ``sign``: sliding direction per
        Coulomb joint, fixed over a step (None: exact sgn, or tanh when ``smooth``);
        ``coulomb``: Coulomb torques frozen over a step (then only the viscous part
        depends on qd)."""
        if coulomb is not None:
            delta = -self.beta * qd + coulomb
        else:
            delta = self.delta(qd, sign, smooth)
        if stuck is None or not stuck.any():
            return self.fd(q, qd, tau + delta, w), delta
        self.calls += 2
        self.states += 2 * (1 if np.ndim(q) == 1 else len(q))
        M = self.robot.mass_matrix(q)
        r = tau + delta - self.robot.bias_torques(q, qd, w)
        return _held(M, r, stuck, delta)

    def ext_power(self, q, qd, w):
        """(J^T w) . qd, the power of the tip wrench; batches of states."""
        J = self.robot.jacobian(q)
        return np.einsum("...i,...ij,...j->...", w, J, qd)

    # -- stick-slip modes at the start of a fixed step
    def modes(self, q, qd, tau, w):
        """(stuck, sign, qdd, delta) at one state: Coulomb joints at rest stick while the
        torque that holds them is within tau_c + eps (active set, the worst violation
        breaks away first, in the direction of the net torque)."""
        sign = np.where(self.coulomb, np.sign(qd), 0.0)
        rest = self.coulomb & (np.abs(qd) <= REST_SPEED)
        if not rest.any():
            qdd, delta = self.accel(q, qd, tau, w, None, sign)
            return None, sign, qdd, delta
        qd = np.where(rest, 0.0, qd)
        sign[rest] = 0.0
        self.calls += 2
        self.states += 2
        M = self.robot.mass_matrix(q)
        b = self.robot.bias_torques(q, qd, w)
        stuck = rest.copy()
        for _ in range(int(rest.sum()) + 1):
            delta = self.delta(qd, sign)
            qdd, delta = _held(M, tau + delta - b, stuck, delta)
            ratio = np.where(stuck, np.abs(delta) / np.where(self.coulomb, self.tau_s, 1.0), 0.0)
            i = int(np.argmax(ratio))
            if ratio[i] <= 1.0:
                break
            stuck[i] = False                 # breaks away against its holding torque
            sign[i] = -np.sign(delta[i])
        return (stuck if stuck.any() else None), sign, qdd, delta

    # -- checks
    def check_state(self, t, q, qd, method, dt=None):
        """Raise SimulationError on NaN/Inf or a state beyond any physical bound."""
        if np.all(np.isfinite(q)) and np.all(np.isfinite(qd)) and \
                np.all(np.abs(qd) <= self.speed_bound) and \
                not np.any(self.prismatic & (np.abs(q) > PRISMATIC_BOUND)):
            return
        bad_q, bad_qd = ~np.isfinite(q), ~np.isfinite(qd)
        if bad_q.any() or bad_qd.any():
            j = int(np.flatnonzero(bad_q | bad_qd)[0])
            reason = "nan"
            what = f"its {'position' if bad_q[j] else 'speed'} is {q[j] if bad_q[j] else qd[j]}"
        elif np.any(np.abs(qd) > self.speed_bound):
            j = int(np.argmax(np.abs(qd) / self.speed_bound))
            reason = "speed"
            what = (f"its speed {qd[j]:.4g} exceeds the bound {self.speed_bound[j]:.4g} "
                    f"({SPEED_BOUND_FACTOR:g} x its velocity limit, or 1e5 where none)")
        else:
            j = int(np.argmax(self.prismatic * np.abs(q)))
            reason = "position"
            what = f"its position {q[j]:.4g} m is beyond {PRISMATIC_BOUND:g} m"
        raise SimulationError(f"simulation diverged at t = {t:.6g} s: joint {self.names[j]!r}: "
                              f"{what}. {_advice(method, dt)}", t, self.names[j], reason)


def _held(M, r, stuck, delta):
    """Solve M qdd = r + h with qdd = 0 on ``stuck`` joints, h the holding torques there
    (zero elsewhere). Works on batches. Returns qdd and delta with h added."""
    free = ~stuck
    qdd = np.zeros_like(r)
    if free.any():
        Mff = M[..., free[:, None] & free[None, :]].reshape(M.shape[:-2] + (free.sum(), free.sum()))
        qdd[..., free] = np.linalg.solve(Mff, r[..., free][..., None])[..., 0]
    h = np.einsum("...ij,...j->...i", M[..., stuck, :], qdd) - r[..., stuck]
    delta = np.array(delta, dtype=float, copy=True)
    delta[..., stuck] += h
    return qdd, delta


# ----------------------------------------------------------------------------- fixed step
class FixedStepIntegrator:
    """One fixed step at a time, for real-time use (the simulator node).

    ``step(q, qd, tau, wrench=None) -> (q, qd)`` advances (n,) states by ``dt`` seconds
    with the robot's dissipation added when ``dissipation`` is true (or a ``Dissipation``).

    Methods: "semi_implicit_euler" (symplectic Euler: velocity first, then position with
    the new velocity; one dynamics call a step), "rk4" (classical Runge-Kutta, 4 calls),
    "implicit_midpoint" (x1 = x0 + dt f((x0 + x1)/2): symplectic, A-stable; simplified
    Newton with a Jacobian from one batched call over 2n+1 perturbed states, typically
    2 calls a step). Coulomb friction: stick-slip, see ``_Equations.modes``; a sliding
    joint whose speed crosses zero within a step stops there (no chattering).
    ``position_limits``: hard stops at the joints' finite URDF limits, see ``_stop``.
    """

    METHODS = FIXED_STEP

    def __init__(self, robot, method="semi_implicit_euler", dt=1e-3, dissipation=True, *,
                 position_limits=False, newton_tol=1e-10, max_newton=10):
        if method not in self.METHODS:
            raise ValueError(f"fixed-step method {method!r} unknown; use one of {self.METHODS}")
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.robot, self.method, self.dt, self.dissipation = robot, method, float(dt), dissipation
        self.eq = _Equations(robot, dissipation)
        self.newton_tol, self.max_newton = float(newton_tol), int(max_newton)
        self.newton_iterations = 0
        self.newton_stalls = 0   # steps accepted with a correction between tol and NEWTON_ACCEPT
        self._jac_cache = None   # implicit midpoint: (modes, age, dqdd/dq, LU) of the last step
        self.jacobians = 0
        self.stages = 0          # right-hand-side evaluations (a Jacobian batch counts 1)
        self._lean = method == "semi_implicit_euler" and not self.eq.coulomb_on
        self.lower = np.asarray(robot.lower, dtype=float)
        self.upper = np.asarray(robot.upper, dtype=float)
        self.stops = bool(position_limits) and bool(np.any(np.isfinite(self.lower))
                                                    or np.any(np.isfinite(self.upper)))
        self.impacts = 0         # steps in which a joint reached a stop

    def step(self, q, qd, tau, wrench=None, t=None):
        """Advance (q, qd) by dt under constant torques ``tau`` (n,) and ``wrench`` (6,) or
        None. Raises SimulationError on divergence (``t``, if given, names the time)."""
        eq, dt = self.eq, self.dt
        if self._lean and not (self.stops and ((q >= self.upper) | (q <= self.lower)).any()):
            # the real-time path: one forward-dynamics call
            q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
            tau = np.asarray(tau, dtype=float)
            if eq.viscous_on:
                tau = tau - eq.beta * qd
            self.stages += 1
            qd_new = qd + dt * eq.fd(q, qd, tau, wrench)   # semi-implicit (symplectic) Euler:
            q_new = q + dt * qd_new                          # velocity first, then position
            eq.check_state(dt if t is None else t + dt, q_new, qd_new, self.method, dt)
            if self.stops:
                q_new, qd_new, _ = self._stop(q_new, qd_new, False)
            return q_new, qd_new
        tau = np.asarray(tau, dtype=float)
        w = None if wrench is None else np.asarray(wrench, dtype=float)
        q_new, qd_new, _ = self._advance(0.0 if t is None else t, q, qd,
                                         lambda t, q, qd: tau,
                                         None if w is None else (lambda t, q, qd: w))
        return q_new, qd_new

    # the general step: torque_fn(t, q, qd) and wrench_fn(t, q, qd) (or None)
    def _advance(self, t, q, qd, torque_fn, wrench_fn, energy=False):
        """One step from t. Returns (q1, qd1, rec) with rec = (tau0, delta0, qdd0, dW):
        the torques and the acceleration at the start, and dW the increments of
        [W_act, W_diss, W_ext] over the step (only when ``energy``)."""
        eq, dt, method = self.eq, self.dt, self.method
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        tau0 = torque_fn(t, q, qd)
        w0 = None if wrench_fn is None else wrench_fn(t, q, qd)
        if eq.coulomb_on:
            stuck, sign, qdd0, delta0 = eq.modes(q, qd, tau0, w0)
            if stuck is not None:
                qd = np.where(stuck, 0.0, qd)
        else:
            stuck, sign = None, None
            qdd0, delta0 = eq.accel(q, qd, tau0, w0)
        if self.stops:
            stuck, qdd0, delta0 = self._hold(q, qd, tau0, w0, stuck, sign, qdd0, delta0)
            if stuck is not None:
                qd = np.where(stuck, 0.0, qd)
        self.stages += 1
        dW = np.zeros(3)

        def power(q_, qd_, tau_, delta_, w_):
            return np.array([tau_ @ qd_, delta_ @ qd_,
                             0.0 if w_ is None else float(eq.ext_power(q_, qd_, w_))])

        if method == "semi_implicit_euler":     # symplectic Euler
            qd1 = qd + dt * qdd0
            q1 = q + dt * qd1
            if energy:   # the discrete work: torques held over the step times the motion
                dW = dt * power(q, qd1, tau0, delta0, w0)
        elif method == "rk4":                   # classical Runge-Kutta (Kutta 1901)
            def f(tt, qq, vv):
                tau_ = torque_fn(tt, qq, vv)
                w_ = None if wrench_fn is None else wrench_fn(tt, qq, vv)
                a, d = eq.accel(qq, vv, tau_, w_, stuck, sign)
                self.stages += 1
                return a, (power(qq, vv, tau_, d, w_) if energy else None)
            k1v, k1a = qd, qdd0
            p1 = power(q, qd, tau0, delta0, w0) if energy else None
            k2a, p2 = f(t + dt / 2, q + dt / 2 * k1v, qd + dt / 2 * k1a)
            k2v = qd + dt / 2 * k1a
            k3a, p3 = f(t + dt / 2, q + dt / 2 * k2v, qd + dt / 2 * k2a)
            k3v = qd + dt / 2 * k2a
            k4a, p4 = f(t + dt, q + dt * k3v, qd + dt * k3a)
            k4v = qd + dt * k3a
            q1 = q + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            qd1 = qd + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
            if energy:
                dW = dt / 6 * (p1 + 2 * p2 + 2 * p3 + p4)
        else:                                   # implicit midpoint (Hairer, Lubich & Wanner, GNI)
            coulomb = None
            if eq.coulomb_on:
                # the Coulomb (+ Stribeck) magnitude is held over the step at its value for
                # the predicted midpoint speed (second order while sliding); Newton then sees
                # only the smooth viscous and rigid-body terms, not the kink of |qd| at zero
                # nor the negative slope of the Stribeck rise
                v_mid = qd + dt / 2 * qdd0
                coulomb = np.where(sign != 0, -eq.diss.sliding_friction(np.maximum(sign * v_mid, 0.0)) * sign,
                                   0.0)
            q1, qd1, dW = self._midpoint(t, q, qd, torque_fn, wrench_fn, stuck, sign, coulomb,
                                         energy, power)
        if eq.coulomb_on:   # a sliding joint whose speed crossed zero stops (and may stick)
            moving = eq.coulomb & (sign != 0)
            qd1 = np.where(moving & (qd1 * sign <= 0.0), 0.0, qd1)
        if stuck is not None:
            qd1 = np.where(stuck, 0.0, qd1)
            q1 = np.where(stuck, q, q1)
        eq.check_state(t + dt, q1, qd1, method, dt)
        if self.stops:
            q1, qd1, dE = self._stop(q1, qd1, energy)
            dW[1] += dE
        return q1, qd1, (tau0, delta0, qdd0, dW)

    def _on_stop(self, q):
        """+1 / -1 for joints on (or beyond) their upper / lower limit, else 0."""
        return np.where(q >= self.upper, 1.0, np.where(q <= self.lower, -1.0, 0.0))

    def _hold(self, q, qd, tau, w, stuck, sign, qdd, delta):
        """At the start of a step: joints at rest on a stop are held there (qdd = 0, as
        joints stuck by friction) while the stop pushes; one that the stop would have to
        pull is let go, largest pull first. Returns (stuck, qdd, delta) with the held
        joints added to ``stuck`` and the stops' holding torques to ``delta``."""
        side = self._on_stop(q)
        held = (side != 0.0) & (np.abs(qd) <= REST_SPEED)
        if not held.any():
            return stuck, qdd, delta
        eq, robot = self.eq, self.eq.robot
        base = np.zeros(eq.n, dtype=bool) if stuck is None else stuck
        qd = np.where(held, 0.0, qd)
        eq.calls += 2
        eq.states += 2
        M, b = robot.mass_matrix(q), robot.bias_torques(q, qd, w)
        d0 = eq.delta(qd, sign)
        for _ in range(int(held.sum()) + 1):
            qdd, delta = _held(M, tau + d0 - b, base | held, d0)
            pull = np.where(held & ~base, (delta - d0) * side, 0.0)   # > 0: pulls outward
            i = int(np.argmax(pull))
            if pull[i] <= 0.0:
                break
            held[i] = False
        stuck = base | held
        return (stuck if stuck.any() else None), qdd, delta

    def _stop(self, q, qd, energy):
        """Hard stops at the joint limits, after a step: a joint beyond a limit is put back
        on it, and if it moves outward it stops in a plastic impact. The impulse acts at
        the stopped joints S only: M (qd+ - qd) = S^T lambda with qd+_S = 0, so that
        qd+_F = qd_F + M_FF^-1 M_FS qd_S on the free joints F (impulsive dynamics,
        Featherstone 2008, ch. 11). A stop only pushes: a joint whose impulse would pull
        it onto the stop is released, largest pull first (as in ``_Equations.modes``),
        and a joint on its stop that the impulse would push through it is stopped too.
        At the next step ``_hold`` holds a stopped joint on its stop. Returns (q, qd, dE),
        dE = E(after) - E(before): the work of the stops (kinetic energy lost, and the
        potential energy of the position reset), counted with the dissipated work; 0.0
        unless ``energy``."""
        hi, lo = q > self.upper, q < self.lower                                  # beyond
        if not (hi.any() or lo.any()):
            return q, qd, 0.0
        side = hi * 1.0 - lo
        self.impacts += 1
        robot = self.eq.robot
        E0 = float(robot.kinetic_energy(q, qd) + robot.potential_energy(q)) if energy else 0.0
        q = np.clip(q, self.lower, self.upper)
        stopped = (side != 0.0) & (qd * side > 0.0)           # moving outward
        if stopped.any():
            on = self._on_stop(q)                             # beyond before, or already on
            M = robot.mass_matrix(q)
            for _ in range(2 * self.eq.n):                    # active set over the stops
                free = ~stopped
                v = qd.copy()
                v[stopped] = 0.0
                if free.any():
                    v[free] += np.linalg.solve(M[np.ix_(free, free)],
                                               M[np.ix_(free, stopped)] @ qd[stopped])
                pull = np.where(stopped, (M @ (v - qd)) * on, 0.0)   # impulse > 0: pulls
                if np.any(pull > 0.0):
                    stopped[int(np.argmax(pull))] = False
                    continue
                kicked = free & (v * on > 0.0)                # pushed out through its stop
                if not kicked.any():
                    break
                stopped |= kicked
            qd = v
        dE = (float(robot.kinetic_energy(q, qd) + robot.potential_energy(q)) - E0
              if energy else 0.0)
        return q, qd, dE

    def _midpoint(self, t, q, qd, torque_fn, wrench_fn, stuck, sign, coulomb, energy, power):
        eq, dt, n = self.eq, self.dt, self.eq.n
        tm = t + dt / 2

        def inputs(Q, V):
            if Q.ndim == 1:
                return torque_fn(tm, Q, V), (None if wrench_fn is None else wrench_fn(tm, Q, V))
            tau = np.array([torque_fn(tm, a, b) for a, b in zip(Q, V)])
            w = None if wrench_fn is None else np.array([wrench_fn(tm, a, b) for a, b in zip(Q, V)])
            return tau, w

        def jacobian(x, v):
            """qdd at (x, v) and its derivatives by forward differences: one batched call
            over the state and its 2n perturbations."""
            hq = 1e-7 * np.maximum(1.0, np.abs(x))
            hv = 1e-7 * np.maximum(1.0, np.abs(v))
            Q = np.repeat(x[None], 2 * n + 1, axis=0)
            V = np.repeat(v[None], 2 * n + 1, axis=0)
            Q[1 + np.arange(n), np.arange(n)] += hq
            V[1 + n + np.arange(n), np.arange(n)] += hv
            tau, w = inputs(Q, V)
            A, D = eq.accel(Q, V, tau, w, stuck, sign, coulomb=coulomb)
            self.jacobians += 1
            self.stages += 1
            a0 = A[0]
            Aq = ((A[1:n + 1] - a0) / hq[:, None]).T
            Av = ((A[n + 1:] - a0) / hv[:, None]).T
            # Newton on G(dq, dv) = [dq - dt (qd + dv/2); dv - dt a(q + dq/2, qd + dv/2)] = 0
            # with the position rows eliminated: (1 - dt/2 A_v - dt^2/4 A_q) s_v = ...
            lu = _lu(np.eye(n) - dt / 2 * Av - dt * dt / 4 * Aq)
            return a0, Aq, lu, (x, v, tau[0], D[0], None if w is None else w[0])

        key = (None if stuck is None else stuck.tobytes(), None if sign is None else
               sign.tobytes())
        cache = self._jac_cache
        if cache is not None and cache[0] == key and cache[1] < JACOBIAN_AGE:
            # reuse the last Jacobian (simplified Newton); refreshed below when it converges
            # slowly, when the stick-slip modes change, or after JACOBIAN_AGE steps
            dA_dq, lu = cache[2], cache[3]
            self._jac_cache = (key, cache[1] + 1, dA_dq, lu)
            tau_0, w_0 = inputs(q, qd)
            a, d_0 = eq.accel(q, qd, tau_0, w_0, stuck, sign, coulomb=coulomb)
            self.stages += 1
            p_args = (q, qd, tau_0, d_0, w_0)
        else:
            a, dA_dq, lu, p_args = jacobian(q, qd)
            self._jac_cache = (key, 1, dA_dq, lu)
        dq, dv = np.zeros(n), np.zeros(n)
        scale = 1.0 + np.concatenate([np.abs(q), np.abs(qd)])
        prev, refreshed = None, 0
        for it in range(1, self.max_newton + 1):
            Gq, Gv = dq - dt * (qd + dv / 2), dv - dt * a
            sv = _lu_solve(lu, -Gv - dt / 2 * (dA_dq @ Gq))
            step = np.concatenate([-Gq + dt / 2 * sv, sv])
            dq, dv = dq + step[:n], dv + sv
            self.newton_iterations += 1
            size = np.max(np.abs(step) / scale)
            # simplified Newton converges linearly at rate rho; the error left after this
            # correction is about rho / (1 - rho) of it (Hairer & Wanner, Sec. IV.8)
            rho = size / prev if prev else None
            if not np.isfinite(size) or size <= self.newton_tol or \
                    (rho is not None and rho < 0.5 and rho / (1.0 - rho) * size <= self.newton_tol):
                break
            prev = size
            qm, vm = q + dq / 2, qd + dv / 2
            if not (np.all(np.isfinite(qm)) and np.all(np.isfinite(vm))):
                break
            if rho is not None and rho > 0.2 and refreshed < 2:
                # slow contraction: a new Jacobian at the current midpoint (it gives a too)
                a, dA_dq, lu, p_args = jacobian(qm, vm)
                self._jac_cache = (key, 1, dA_dq, lu)
                refreshed += 1
                prev = None
            else:
                tau_m, w_m = inputs(qm, vm)
                a, d_m = eq.accel(qm, vm, tau_m, w_m, stuck, sign, coulomb=coulomb)
                self.stages += 1
                p_args = (qm, vm, tau_m, d_m, w_m)
        else:
            # a correction just above newton_tol after max_newton iterations is accepted
            if not size <= NEWTON_ACCEPT:
                raise SimulationError(
                    f"implicit midpoint: Newton did not converge within {self.max_newton} "
                    f"iterations at t = {t:.6g} s (last relative correction {size:.3g}). "
                    f"{_advice('implicit_midpoint', dt)}", t, None, "newton")
            self.newton_stalls += 1
        dW = dt * power(*p_args) if energy else np.zeros(3)
        return q + dq, qd + dv, dW


def _lu(K):
    from scipy.linalg import lu_factor
    return lu_factor(K, check_finite=False)


def _lu_solve(lu, b):
    from scipy.linalg import lu_solve
    return lu_solve(lu, b, check_finite=False)


# ----------------------------------------------------------------------------- results
@dataclass
class SolverStats:
    """Work done by a run. ``nfev``: right-hand-side evaluations (for the fixed-step
    methods: stage evaluations; a batched Jacobian call counts once in ``njev``);
    ``dynamics_states``: every state the dynamics was evaluated at (a Jacobian over 2n+1
    perturbed states counts 2n+1): the honest cost. ``rejected``: rejected step attempts
    (exact for RK45/DOP853; for Radau/BDF/LSODA, the accepted steps that were shorter
    than the solver had proposed, a lower bound)."""

    method: str
    steps: int = 0
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    rejected: int = 0
    newton_iterations: int = 0
    dynamics_calls: int = 0
    dynamics_states: int = 0
    wall_time: float = 0.0
    message: str = ""


@dataclass
class SimulationResult:
    """A simulated motion. Arrays over the output times ``t`` (K,):

    q, qd, qdd (K, n); tau (applied torques), delta (dissipative torques, holding torques
    of stuck joints included) (K, n); kinetic, potential (K,) J; work_actuators
    int tau.qd, work_dissipation int delta.qd (<= 0), work_external int (J^T w).qd (K,) J.
    ``stats``: a ``SolverStats``."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    delta: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_actuators: np.ndarray
    work_dissipation: np.ndarray
    work_external: np.ndarray
    stats: SolverStats
    joint_names: list = field(default_factory=list)

    method = property(lambda self: self.stats.method)

    @property
    def energy(self):
        """Total mechanical energy T + V (J)."""
        return self.kinetic + self.potential

    @property
    def energy_dissipated(self):
        """Energy taken out by the dissipation so far, -int delta.qd dt >= 0 (J)."""
        return -self.work_dissipation

    @property
    def energy_balance_error(self):
        """E(t) - E(0) - W_act - W_diss - W_ext: zero for an exact solution (J)."""
        e = self.energy
        return e - e[0] - self.work_actuators - self.work_dissipation - self.work_external

    def energy_scale(self):
        """A scale for relative energy errors: the largest of the kinetic energy, the
        potential-energy swing and the works over the run (J)."""
        v = self.potential
        return max(np.max(self.kinetic), np.ptp(v), np.max(np.abs(self.work_actuators)),
                   np.max(np.abs(self.work_dissipation)), np.max(np.abs(self.work_external)),
                   1e-300)

    def relative_energy_error(self):
        """max |energy balance error| / energy_scale() over the run."""
        return float(np.max(np.abs(self.energy_balance_error)) / self.energy_scale())

    def columns(self):
        """(header, table) with t, q_*, qd_*, tau_*, delta_*, energies and works."""
        names = self.joint_names or [f"j{i}" for i in range(self.q.shape[1])]
        head = (["t"] + [f"q_{j}" for j in names] + [f"qd_{j}" for j in names]
                + [f"tau_{j}" for j in names] + [f"delta_{j}" for j in names]
                + ["kinetic", "potential", "energy", "work_actuators", "work_dissipation",
                   "work_external"])
        table = np.column_stack([self.t, self.q, self.qd, self.tau, self.delta, self.kinetic,
                                 self.potential, self.energy, self.work_actuators,
                                 self.work_dissipation, self.work_external])
        return head, table

    def to_csv(self, path):
        head, table = self.columns()
        np.savetxt(path, table, delimiter=",", header=",".join(head), comments="", fmt="%.10g")

    def plot(self, path=None, title=None):
        """Figure with q(t), tau(t) and the energies; saved to ``path`` when given."""
        import matplotlib
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        names = self.joint_names or [f"j{i}" for i in range(self.q.shape[1])]
        fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
        for j, name in enumerate(names):
            line, = ax[0].plot(self.t, self.q[:, j], label=name)
            ax[1].plot(self.t, self.tau[:, j], color=line.get_color(), label=f"tau {name}")
            if np.any(self.delta[:, j]):
                ax[1].plot(self.t, self.delta[:, j], color=line.get_color(), ls="--", lw=0.8)
        ax[0].set_ylabel("q (rad, m)")
        ax[0].legend(fontsize=7, ncol=3, loc="best")
        ax[1].set_ylabel("torque (N m, N)")
        quiet = not (np.any(self.tau) or np.any(self.delta))
        ax[1].set_title("no applied or dissipative torque (free motion)" if quiet else
                        "applied (solid), dissipative (dashed)", fontsize=8)
        e0 = self.energy[0]
        ax[2].plot(self.t, self.kinetic, label="kinetic T")
        ax[2].plot(self.t, self.potential - self.potential[0], label="potential V - V(0)")
        ax[2].plot(self.t, self.energy - e0, label="E - E(0)", lw=2)
        ax[2].plot(self.t, self.work_actuators + self.work_dissipation + self.work_external,
                   "k:", label="W_act + W_diss + W_ext")
        ax[2].set_ylabel("energy (J)")
        ax[2].set_xlabel("t (s)")
        ax[2].legend(fontsize=7, loc="best")
        s = self.stats
        fig.suptitle(title or f"{s.method}: {s.steps} steps, {s.nfev} RHS evaluations, "
                     f"{s.wall_time:.2f} s wall; energy balance error "
                     f"{self.relative_energy_error():.1e} (relative)", fontsize=9)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=110)
            plt.close(fig)
        return fig


# ----------------------------------------------------------------------------- progress
class _Progress:
    """A text progress bar on stderr that appears only once a run has lasted 1 s."""

    def __init__(self, duration, enabled, stream=None, delay=1.0):
        self.duration, self.enabled = duration, enabled
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.delay, self.shown, self.last = delay, False, -1

    def __call__(self, t):
        if not self.enabled:
            return
        if callable(self.enabled):
            self.enabled(t / self.duration)
            return
        now = time.perf_counter() - self.start
        pct = int(100 * t / self.duration)
        if now < self.delay or pct == self.last:
            return
        self.shown, self.last = True, pct
        bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
        self.stream.write(f"\rsimulating [{bar}] {pct:3d}%  t = {t:.3f} s  ({now:.1f} s)")
        self.stream.flush()

    def close(self):
        if self.shown and not callable(self.enabled):
            self.stream.write("\n")
            self.stream.flush()


# ----------------------------------------------------------------------------- simulate
def simulate(robot, duration, q0=None, qd0=None, torque=None, *, method="DOP853", rtol=None,
             atol=None, dt=None, dissipation=True, wrench=None, output_dt=None,
             max_step=np.inf, first_step=None, friction_smoothing=1e-4, check_energy=True,
             position_limits=False, progress=False) -> SimulationResult:
    """Simulate ``duration`` seconds of motion from (q0, qd0) (zeros by default).

    torque: None (zero), a scalar or (n,) constant, (K, n) samples uniformly spaced over
        [0, duration] (piecewise linear), a (times, samples) pair, or a callable
        ``torque(t, q, qd) -> (n,)`` (a controller closed around the robot; adaptive and
        RK methods call it at trial states, so it must be a pure function of its arguments).
    wrench: None, (6,) [fx, fy, fz, mx, my, mz] on the tip (base frame), or a callable.
    method: "RK45", "DOP853", "Radau", "BDF", "LSODA" (adaptive: rtol, atol, default 1e-6,
        1e-9) or "semi_implicit_euler", "rk4", "implicit_midpoint" (fixed step: dt,
        default 1e-3 s).
    dissipation: True (the robot's), False, or a ``Dissipation``. Adaptive methods replace
        sgn(qd) in Coulomb friction by tanh(qd / friction_smoothing) (default 1e-4 rad/s:
        below breakaway a joint creeps at friction_smoothing * atanh(tau / tau_s); this
        makes the equations stiff, so use Radau, BDF or LSODA); fixed-step methods do
        stick-slip.
    output_dt: spacing of the output samples (default: every step of the solver).
    check_energy: raise SimulationError when the energy balance is violated by more than
        half the energy scale (energy growing without input).
    position_limits: hard stops at the finite URDF joint limits (plastic impacts; their
        work is counted in W_diss); fixed-step methods only.
    progress: True for a progress bar on stderr (shown when the run lasts over 1 s), or a
        callable(fraction).
    """
    if method not in METHODS:
        raise ValueError(f"method {method!r} unknown; use one of {list(METHODS)}")
    duration = float(duration)
    if not (duration > 0 and np.isfinite(duration)):
        raise ValueError(f"duration = {duration}; give a positive, finite time in seconds")
    n = robot.dof
    q0 = np.zeros(n) if q0 is None else np.array(q0, dtype=float).reshape(-1)
    qd0 = np.zeros(n) if qd0 is None else np.array(qd0, dtype=float).reshape(-1)
    for name, x in (("q0", q0), ("qd0", qd0)):
        if x.shape != (n,):
            raise ValueError(f"{name} has {x.size} values; give one per joint ({n}: "
                             f"{robot.joint_names})")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name} has a NaN or Inf entry")
    outside = np.flatnonzero((q0 < robot.lower) | (q0 > robot.upper)) if position_limits else []
    if len(outside):
        j = outside[0]
        raise ValueError(f"q0: {robot.joint_names[j]} = {q0[j]:g} is outside its limits "
                         f"[{robot.lower[j]:g}, {robot.upper[j]:g}]; start inside them, or "
                         "simulate without position_limits")
    torque_fn, torque_kind = _input_fn(torque, n, "torque", duration, robot.joint_names)
    wrench_fn, wrench_kind = _input_fn(wrench, 6, "wrench", duration, robot.joint_names)
    if wrench_kind == "zero":
        wrench_fn = None
    if output_dt is not None and not output_dt > 0:
        raise ValueError(f"output_dt = {output_dt}; give a spacing > 0 s")
    bar = _Progress(duration, progress)
    start = time.perf_counter()
    try:
        if method in FIXED_STEP:
            if rtol is not None or atol is not None:
                raise ValueError(f"{method!r} is a fixed-step method: give dt, not rtol/atol")
            dt = DEFAULT_DT if dt is None else float(dt)
            args = (robot, duration, q0, qd0, torque_fn, wrench_fn, method, dt, dissipation,
                    output_dt, check_energy, bar)
            if (method == "semi_implicit_euler" and robot.backend == "numba"
                    and not callable(torque) and wrench_fn is None and not position_limits):
                out = _run_compiled(*args)          # the compiled loop has no stops
            else:
                out = _run_fixed(*args, position_limits)
        else:
            if position_limits:
                raise ValueError(f"position_limits needs a fixed-step method "
                                 f"{list(FIXED_STEP)}: {method!r} has no impact events")
            if dt is not None:
                raise ValueError(f"{method!r} is adaptive: give rtol/atol (and max_step), "
                                 "not dt; dt is for the fixed-step methods "
                                 f"{list(FIXED_STEP)}")
            rtol = DEFAULT_RTOL if rtol is None else rtol
            atol = DEFAULT_ATOL if atol is None else atol
            out = _run_adaptive(robot, duration, q0, qd0, torque_fn, wrench_fn, method, rtol,
                                atol, max_step, first_step, dissipation, friction_smoothing,
                                output_dt, check_energy, bar)
    finally:
        bar.close()
    out.stats.wall_time = time.perf_counter() - start
    return out


def _energy_scale_static(robot):
    """An upper bound of the potential-energy swing, |g| sum m_i 2 r_i with r_i the
    largest distance of body i's center of mass from the base origin."""
    m = robot.model
    reach = np.cumsum(np.linalg.norm(m.p_parent, axis=1)) + np.linalg.norm(m.com, axis=1)
    travel = np.cumsum(np.where(m.kind == 1, np.minimum(np.abs(m.lower), PRISMATIC_BOUND)
                                + np.minimum(np.abs(m.upper), PRISMATIC_BOUND), 0.0))
    return float(np.linalg.norm(m.gravity) * np.sum(m.mass * 2 * (reach + travel)))


class _EnergyGuard:
    """Raises when E(t) - E(0) - W_act - W_ext exceeds half the energy scale: energy from
    nowhere (dissipation can only take energy out, so its work is left out of the test)."""

    def __init__(self, eq, q0, qd0, method, dt, enabled):
        self.eq, self.method, self.dt, self.enabled = eq, method, dt, enabled
        if enabled:
            r = eq.robot
            self.T0 = float(r.kinetic_energy(q0, qd0))
            self.E0 = self.T0 + float(r.potential_energy(q0))
            self.static = _energy_scale_static(r)
            self.wmax = 0.0

    def __call__(self, t, q, qd, W):
        if not self.enabled:
            return
        r = self.eq.robot
        self.wmax = max(self.wmax, abs(float(W[0])), abs(float(W[2])))
        E = float(r.kinetic_energy(q, qd) + r.potential_energy(q))
        excess = E - self.E0 - float(W[0]) - float(W[2])
        scale = self.T0 + self.static + self.wmax + 1e-9
        if excess > 0.5 * scale:
            j = int(np.argmax(np.abs(qd)))
            name = self.eq.names[j]
            raise SimulationError(
                f"simulation diverged at t = {t:.6g} s: the energy grew by {excess:.4g} J more "
                f"than the work put in (energy scale {scale:.4g} J); the fastest joint is "
                f"{name!r} at {qd[j]:.4g}. {_advice(self.method, self.dt)}", t, name, "energy")


def _finish(eq, ts, Q, QD, QDD, TAU, DELTA, W, stats, names):
    robot = eq.robot
    Q, QD = np.asarray(Q), np.asarray(QD)
    kinetic = np.asarray(robot.kinetic_energy(Q, QD), dtype=float).reshape(-1)
    potential = np.asarray(robot.potential_energy(Q), dtype=float).reshape(-1)
    W = np.asarray(W).reshape(-1, 3)
    stats.dynamics_calls, stats.dynamics_states = eq.calls, eq.states
    return SimulationResult(np.asarray(ts), Q, QD, np.asarray(QDD), np.asarray(TAU),
                            np.asarray(DELTA), kinetic, potential, W[:, 0], W[:, 1], W[:, 2],
                            stats, list(names))


def _run_fixed(robot, duration, q0, qd0, torque_fn, wrench_fn, method, dt, dissipation,
               output_dt, check_energy, bar, position_limits=False):
    integ = FixedStepIntegrator(robot, method, dt, dissipation, position_limits=position_limits)
    eq = integ.eq
    nsteps = int(np.ceil(duration / dt - 1e-9))
    every = 1 if output_dt is None else max(1, int(round(output_dt / dt)))
    guard = _EnergyGuard(eq, q0, qd0, method, dt, check_energy)
    check_every = max(1, min(200, nsteps // 50))
    q, qd, W = q0.copy(), qd0.copy(), np.zeros(3)
    ts, Q, QD, QDD, TAU, DELTA, WS = [], [], [], [], [], [], []
    for k in range(nsteps):
        t = k * dt
        q1, qd1, (tau0, delta0, qdd0, dW) = integ._advance(t, q, qd, torque_fn, wrench_fn, True)
        if k % every == 0:
            ts.append(t); Q.append(q); QD.append(qd); TAU.append(tau0)   # noqa: E702
            DELTA.append(delta0); WS.append(W.copy()); QDD.append(qdd0)  # noqa: E702
        q, qd, W = q1, qd1, W + dW
        if (k + 1) % check_every == 0:
            guard((k + 1) * dt, q, qd, W)
            bar((k + 1) * dt)
    # the final state, with the torques at the final time
    t = nsteps * dt
    tau = torque_fn(t, q, qd)
    w = None if wrench_fn is None else wrench_fn(t, q, qd)
    if eq.coulomb_on:
        _, _, qdd, delta = eq.modes(q, qd, tau, w)
    else:
        qdd, delta = eq.accel(q, qd, tau, w)
    ts.append(t); Q.append(q); QD.append(qd); TAU.append(tau); DELTA.append(delta)  # noqa: E702
    WS.append(W); QDD.append(qdd)   # noqa: E702
    guard(t, q, qd, W)
    stats = SolverStats(method, steps=nsteps, nfev=integ.stages, njev=integ.jacobians,
                        nlu=integ.jacobians, newton_iterations=integ.newton_iterations,
                        message=f"fixed step dt = {dt:g} s"
                        + (f"; a joint reached a stop in {integ.impacts} steps"
                           if integ.impacts else ""))
    return _finish(eq, ts, Q, QD, QDD, TAU, DELTA, WS, stats, robot.joint_names)


def _run_compiled(robot, duration, q0, qd0, torque_fn, wrench_fn, method, dt, dissipation,
                  output_dt, check_energy, bar):
    """Semi-implicit Euler in one compiled loop (kernels.simulate_fixed_step), for torques
    known in advance (not state feedback), no tip wrench and no Coulomb friction; the same
    steps, explicit damping and work quadrature as FixedStepIntegrator. Falls back to the
    step-by-step loop otherwise."""
    from .kernels import simulate_fixed_step
    eq = _Equations(robot, dissipation)
    if eq.coulomb_on:   # stick-slip needs the step-by-step integrator
        return _run_fixed(robot, duration, q0, qd0, torque_fn, wrench_fn, method, dt,
                          dissipation, output_dt, check_energy, bar)
    nsteps = int(np.ceil(duration / dt - 1e-9))
    ts = np.arange(nsteps + 1) * dt
    tau = np.array([torque_fn(t, None, None) for t in ts])        # (nsteps + 1, n)
    Q, QD = simulate_fixed_step(robot, q0, qd0, tau[:-1], dt, nsteps, eq.beta, None,
                                implicit_damping=False)
    eq.calls += nsteps
    eq.states += nsteps
    delta = -eq.beta * QD                                         # viscous only here
    # discrete work, as in FixedStepIntegrator: torques held over a step times the new speed
    dW = dt * np.stack([np.einsum("ki,ki->k", tau[:-1], QD[1:]),
                        np.einsum("ki,ki->k", delta[:-1], QD[1:]), np.zeros(nsteps)], axis=1)
    W = np.vstack([np.zeros(3), np.cumsum(dW, axis=0)])
    # the checks of the step-by-step loop, at its check points, in time order
    guard = _EnergyGuard(eq, q0, qd0, method, dt, check_energy)
    bad = np.flatnonzero(~np.all(np.isfinite(QD) & np.isfinite(Q), axis=1))
    last = nsteps if bad.size == 0 else bad[0]
    for k in np.unique(np.r_[np.arange(0, last + 1, max(1, min(200, nsteps // 50))), last]):
        eq.check_state(ts[k], Q[k], QD[k], method, dt)            # raises at the first bad row
        guard(ts[k], Q[k], QD[k], W[k])
    bar(duration)
    qdd_end, _ = eq.accel(Q[-1], QD[-1], tau[-1])
    QDD = np.vstack([np.diff(QD, axis=0) / dt, qdd_end])          # qd1 = qd + dt qdd
    keep = np.unique(np.r_[np.arange(0, nsteps, 1 if output_dt is None else
                                     max(1, int(round(output_dt / dt)))), nsteps])
    stats = SolverStats(method, steps=nsteps, nfev=nsteps,
                        message=f"fixed step dt = {dt:g} s (compiled loop)")
    return _finish(eq, ts[keep], Q[keep], QD[keep], QDD[keep], tau[keep], delta[keep], W[keep],
                   stats, robot.joint_names)


def _run_adaptive(robot, duration, q0, qd0, torque_fn, wrench_fn, method, rtol, atol,
                  max_step, first_step, dissipation, smoothing, output_dt, check_energy, bar):
    import scipy.integrate as si
    eq = _Equations(robot, dissipation, smoothing)
    n = eq.n
    smooth = eq.coulomb_on
    has_w = wrench_fn is not None
    counter = [0]

    def rhs_parts(t, q, qd):
        tau = torque_fn(t, q, qd)
        w = wrench_fn(t, q, qd) if has_w else None
        qdd, delta = eq.accel(q, qd, tau, w, smooth=smooth)
        return tau, w, qdd, delta

    def fun(t, y):
        counter[0] += 1
        q, qd = y[:n], y[n:2 * n]
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            return np.full_like(y, np.nan)      # the solver rejects the step
        tau, w, qdd, delta = rhs_parts(t, q, qd)
        p_ext = float(eq.ext_power(q, qd, w)) if has_w else 0.0
        return np.concatenate([qd, qdd, [tau @ qd, delta @ qd, p_ext]])

    def jac(t, y):
        """Forward differences of the state equations: one batched dynamics call over the
        state and its 2n perturbations (instead of scipy's column-by-column differences)."""
        q, qd = y[:n], y[n:2 * n]
        h = 1e-7 * np.maximum(1.0, np.abs(y[:2 * n]))
        X = np.repeat(y[None, :2 * n], 2 * n + 1, axis=0)
        X[1 + np.arange(2 * n), np.arange(2 * n)] += h
        Q, V = X[:, :n], X[:, n:]
        tau = np.array([torque_fn(t, a, b) for a, b in zip(Q, V)])
        w = np.array([wrench_fn(t, a, b) for a, b in zip(Q, V)]) if has_w else None
        A, D = eq.accel(Q, V, tau, w, smooth=smooth)
        P = np.column_stack([np.einsum("ij,ij->i", tau, V), np.einsum("ij,ij->i", D, V),
                             eq.ext_power(Q, V, w) if has_w else np.zeros(len(V))])
        J = np.zeros((2 * n + 3, 2 * n + 3))
        J[:n, n:2 * n] = np.eye(n)
        J[n:2 * n, :2 * n] = ((A[1:] - A[0]) / h[:, None]).T
        J[2 * n:, :2 * n] = ((P[1:] - P[0]) / h[:, None]).T
        return J

    y0 = np.concatenate([q0, qd0, np.zeros(3)])
    Solver = getattr(si, method)
    kw = dict(rtol=rtol, atol=atol, max_step=max_step)
    if first_step is not None:
        kw["first_step"] = first_step
    if method in IMPLICIT:
        kw["jac"] = jac
    solver = Solver(fun, 0.0, y0, duration, **kw)
    per_attempt = getattr(solver, "n_stages", None)   # RK: evaluations per attempted step
    guard = _EnergyGuard(eq, q0, qd0, method, None, check_energy)
    grid = None if output_dt is None else np.append(np.arange(0.0, duration, output_dt), duration)
    ts, Ys = [0.0], [y0]
    gi = 1
    steps = rejected = 0
    while solver.status == "running":
        t_old = solver.t
        proposed = _proposed_step(solver, method, max_step, duration)
        before = counter[0]
        message = solver.step()
        if solver.status == "failed":
            y = solver.y
            j = int(np.argmax(np.abs(y[n:2 * n]))) if np.all(np.isfinite(y)) else 0
            raise SimulationError(
                f"{method} failed at t = {solver.t:.6g} s ({message}); the fastest joint is "
                f"{eq.names[j]!r}. {_advice(method)}", solver.t, eq.names[j], "solver")
        steps += 1
        taken = solver.t - t_old
        if per_attempt is not None:
            rejected += max(0, (counter[0] - before) // per_attempt - 1)
        elif proposed is not None and taken < proposed * (1 - 1e-9):
            rejected += 1
        y = solver.y
        eq.check_state(solver.t, y[:n], y[n:2 * n], method)
        if grid is None:
            ts.append(solver.t)
            Ys.append(y.copy())
        else:
            dense = None
            while gi < grid.size and grid[gi] <= solver.t + 1e-12 * max(1.0, duration):
                if grid[gi] >= solver.t - 1e-15:
                    ts.append(solver.t)
                    Ys.append(y.copy())
                else:
                    dense = dense or solver.dense_output()
                    ts.append(grid[gi])
                    Ys.append(dense(grid[gi]))
                gi += 1
        if steps % 20 == 0:
            guard(solver.t, y[:n], y[n:2 * n], y[2 * n:])
        bar(solver.t)
    y = solver.y
    guard(solver.t, y[:n], y[n:2 * n], y[2 * n:])
    Y = np.array(Ys)
    Q, QD = Y[:, :n], Y[:, n:2 * n]
    TAU = np.array([torque_fn(t, a, b) for t, a, b in zip(ts, Q, QD)])
    calls, states = eq.calls, eq.states
    WR = np.array([wrench_fn(t, a, b) for t, a, b in zip(ts, Q, QD)]) if has_w else None
    QDD, DELTA = eq.accel(Q, QD, TAU, WR, smooth=smooth)
    eq.calls, eq.states = calls, states          # output evaluation is not solver work
    stats = SolverStats(method, steps=steps, nfev=counter[0], njev=solver.njev, nlu=solver.nlu,
                        rejected=rejected, message="ok")
    res = _finish(eq, ts, Q, QD, QDD, TAU, DELTA, Y[:, 2 * n:], stats, robot.joint_names)
    res.stats.dynamics_calls = calls
    res.stats.dynamics_states = states
    return res


def _proposed_step(solver, method, max_step, t_bound):
    """The step the solver will try next (clipped as scipy does), or None if unknown."""
    if method == "LSODA":
        try:
            h = float(solver._lsoda_solver._integrator.rwork[11])
        except (AttributeError, IndexError, TypeError):
            return None
        if not h > 0:
            return None
    else:
        h = getattr(solver, "h_abs", None)
        if h is None:
            return None
        h = min(h, max_step)
    return min(h, t_bound - solver.t)
