"""``simulate``: checks and normalises its inputs (initial state; torque and wrench given
as constants, samples or callables, made functions of (t, q, qd)) and runs the loop of the
method: ``compiled_run.run_compiled`` or ``run_fixed``, or ``adaptive.run_adaptive``.

Methods (see docs/simulation.md):

- adaptive, by scipy.integrate: "RK45", "DOP853" (explicit Runge-Kutta), "Radau", "BDF"
  (implicit, for stiff chains; analytical Jacobian, ``jacobians.py``), "LSODA" (automatic
  stiff / non-stiff switching). Coulomb friction is regularized
  (``Dissipation.smooth_torque``).
- fixed step (``dt``), for real time: "semi_implicit_euler" (velocity, then position;
  symplectic only for a constant mass matrix), "symplectic_euler" (momentum form:
  symplectic, bounded energy error, ``symplectic.py``), "rk4" (classical Runge-Kutta),
  "implicit_midpoint" (symmetric, A-stable; Newton with the analytical Jacobian).
  Coulomb friction with stick-slip: a joint at
  rest sticks while the torque that holds it is within its static friction.
  ``position_limits=True`` adds hard stops at the URDF joint limits (plastic impacts,
  ``stops.JointStops``).

Energies are integrated alongside: the work of the actuators int tau.qd dt, of the
dissipation int delta.qd dt (<= 0) and of the environment (the tip wrench int (J^T w).qd dt
and a moving base's torques int -beta.qd dt, ``Equations.ext_power``), so that
E(t) - E(0) = W_act + W_diss + W_ext along any run. Divergence (NaN/Inf, a speed
beyond any physical bound, energy growing without input) raises ``SimulationError``.
"""
from __future__ import annotations

import time

import numpy as np

from ..contacts.stepper import run_with_ground
from ..contacts.stepping import check_ground
from ..model.errors import SimulationError
from ..robot.base_motion import BaseMotion
from ..robot.wrenches import generalized_forces
from .adaptive import run_adaptive
from .equations import Inputs
from .compiled_run import run_compiled
from .fixed_step import run_fixed
from .group import run_on_group
from .jacobians import check_jacobian
from .methods import DEFAULT_ATOL, DEFAULT_DT, DEFAULT_RTOL, FIXED_STEP, METHODS, on_a_group
from .progress import Progress
from .result import SimulationResult


def input_fn(value, width, name, duration, joint_names):
    """Normalize a torque/wrench spec into (f(t, q, qd) -> (width,) array, kind).

    kind: "zero", "const", "time" (samples over time) or "fn" (a callable: time-varying
    or state feedback)."""
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
        return interp_fn(ts, vals), "time"
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 or a.shape == (width,):
        const = np.broadcast_to(a, (width,)).copy()
        if not np.all(np.isfinite(const)):
            raise ValueError(f"{name} has a NaN or Inf entry")
        if not np.any(const):
            return (lambda t, q, qd: const), "zero"
        return (lambda t, q, qd: const), "const"
    if a.ndim == 2 and a.shape[1] == width and a.shape[0] >= 2:   # uniform samples over [0, T]
        return interp_fn(np.linspace(0.0, duration, a.shape[0]), a), "time"
    what = f"one per joint {joint_names}" if name == "torque" else "[fx, fy, fz, mx, my, mz]"
    raise ValueError(f"{name} has shape {a.shape}; give a scalar, ({width},) values ({what}), "
                     f"(K, {width}) samples over [0, duration], (times, samples), or a "
                     "callable f(t, q, qd)")


def base_fn(base_motion):
    """None, or f(t) -> BaseMotion (checked on each call) for a constant or a callable."""
    if base_motion is None:
        return None
    if isinstance(base_motion, BaseMotion):
        return lambda t: base_motion

    def fn(t, _f=base_motion):
        bm = _f(t)
        if not isinstance(bm, BaseMotion):
            raise TypeError(f"the base_motion callable returned {type(bm).__name__} at "
                            f"t = {t:.6g} s; it must return a serial_dynamics.BaseMotion")
        return bm
    if not callable(base_motion):
        raise TypeError(f"base_motion must be None, a serial_dynamics.BaseMotion or a callable "
                        f"f(t) -> BaseMotion; got {type(base_motion).__name__}")
    return fn


def interp_fn(ts, vals):
    if not np.all(np.isfinite(vals)):
        raise ValueError("input samples have a NaN or Inf entry")

    def fn(t, q, qd):   # piecewise linear, held constant outside the samples
        k = int(np.clip(np.searchsorted(ts, t) - 1, 0, ts.size - 2))
        s = np.clip((t - ts[k]) / (ts[k + 1] - ts[k]), 0.0, 1.0)
        return (1.0 - s) * vals[k] + s * vals[k + 1]
    return fn


def with_link_wrenches(robot, torque_fn, wrenches, q0, qd0):
    """``torque_fn`` plus the generalized forces sum_k J_k(q)^T w_k of ``wrenches`` (each a
    (6,) wrench or a callable of (t, q, qd)), checked once at the initial state. On a
    floating base the sum has nv = n + 6 entries: the joint torques come after six zeros
    (sim/group.py takes the first six as forces on the base)."""
    pad = np.zeros(robot.nv - robot.dof)
    if not isinstance(wrenches, dict):
        raise ValueError(f"wrenches must be a dict {{link: wrench or callable}}; got "
                         f"{type(wrenches).__name__}")

    def at(t, q, qd):
        return {k: (w(t, q, qd) if callable(w) else w) for k, w in wrenches.items()}

    generalized_forces(robot, q0, at(0.0, q0, qd0))      # names a bad link or wrench now
    return lambda t, q, qd: (np.concatenate([pad, torque_fn(t, q, qd)])
                             + generalized_forces(robot, q, at(t, q, qd)))


def simulate(robot, duration, q0=None, qd0=None, torque=None, *, method="DOP853", rtol=None,
             atol=None, dt=None, dissipation=True, wrench=None, output_dt=None,
             max_step=np.inf, first_step=None, friction_smoothing=1e-4, check_energy=True,
             position_limits=False, progress=False, base_motion=None,
             jacobian="analytical", wrenches=None, ground=None,
             contacts=None) -> SimulationResult:
    """Simulate ``duration`` seconds of motion from (q0, qd0) (zeros by default).

    torque: None (zero), a scalar or (n,) constant, (K, n) samples uniformly spaced over
        [0, duration] (piecewise linear), a (times, samples) pair, or a callable
        ``torque(t, q, qd) -> (n,)`` (a controller closed around the robot; adaptive and
        RK methods call it at trial states, so it must be a pure function of its arguments).
    wrench: None, (6,) [fx, fy, fz, mx, my, mz] on the tip (base frame), or a callable.
    wrenches: {link: w} with w a (6,) wrench or a callable ``w(t, q, qd) -> (6,)``, each on
        that link at its origin, in the axes of ``robot.jacobian`` (the base frame on a fixed
        base, the world on a floating one): their generalized forces sum_k J_k^T w_k add to
        the torque (``robot/wrenches.py``; their work on the joints counted with the
        torque's, on a floating base's six coordinates with the external work).
    method: "RK45", "DOP853", "Radau", "BDF", "LSODA" (adaptive: rtol, atol, default 1e-6,
        1e-9) or "semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint"
        (fixed step: dt, default 1e-3 s).
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
    base_motion: None (a base at rest), a ``BaseMotion`` or a callable ``f(t) ->
        BaseMotion`` (a ship's deck, a vehicle): q stays relative to the base, the energies
        are relative to the base, and ``work_external`` includes the work of the base's
        motion, so that the energy balance still holds.
    jacobian: the Jacobian of the implicit methods (Radau, BDF, LSODA, implicit_midpoint):
        "analytical" (``Robot.forward_dynamics_derivatives``, the default) or
        "finite_differences" (forward differences in one batched dynamics call over 2n+1
        states; for comparison). ``jacobians.py``.
    ground: None, or an ``sd.Ground`` that ``contacts`` (point ``sd.Contact``s; default
        ``robot.contact_points()``) touch: unilateral contacts with Coulomb friction by
        velocity-level time stepping (``contacts/stepping.py``), method
        "semi_implicit_euler" only; the result's ``contact_forces`` (K, k, 3) and
        ``contact_active`` (K, k).
    """
    if method not in METHODS:
        raise ValueError(f"method {method!r} unknown; use one of {list(METHODS)}")
    duration = float(duration)
    if not (duration > 0 and np.isfinite(duration)):
        raise ValueError(f"duration = {duration}; give a positive, finite time in seconds")
    n = robot.dof
    q0 = robot.neutral() if q0 is None else np.array(q0, dtype=float).reshape(-1)
    qd0 = np.zeros(robot.nv) if qd0 is None else np.array(qd0, dtype=float).reshape(-1)
    for name, x, size, base in (("q0", q0, robot.nq, "pose [x, y, z, qx, qy, qz, qw]"),
                                ("qd0", qd0, robot.nv, "velocity [v_O, omega]")):
        if x.shape != (size,):
            raise ValueError(f"{name} has {x.size} values; give "
                             + (f"the base's {base} and " if size > n else "")
                             + f"one per joint ({n}: {robot.joint_names})")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{name} has a NaN or Inf entry")
    if on_a_group(robot):           # q on a group, stepped in the robot's chart: sim/group.py
        check_on_group(method, position_limits, base_motion, dt, rtol, atol)
    qj = q0[q0.shape[0] - n:]                       # the joints (after a floating base's pose)
    outside = np.flatnonzero((qj < robot.lower) | (qj > robot.upper)) if position_limits else []
    if len(outside):
        j = outside[0]
        raise ValueError(f"q0: {robot.joint_names[j]} = {qj[j]:g} is outside its limits "
                         f"[{robot.lower[j]:g}, {robot.upper[j]:g}]; start inside them, or "
                         "simulate without position_limits")
    torque_fn, torque_kind = input_fn(torque, n, "torque", duration, robot.joint_names)
    if wrenches is not None:
        torque_fn, torque_kind = with_link_wrenches(robot, torque_fn, wrenches, q0, qd0), "fn"
    wrench_fn, wrench_kind = input_fn(wrench, 6, "wrench", duration, robot.joint_names)
    inputs = Inputs(torque_fn, None if wrench_kind == "zero" else wrench_fn,
                    base_fn(base_motion), "fn" in (torque_kind, wrench_kind))
    check_jacobian(jacobian)
    if output_dt is not None and not output_dt > 0:
        raise ValueError(f"output_dt = {output_dt}; give a spacing > 0 s")
    if ground is None and contacts is not None:
        raise ValueError("contacts are given without a ground; give ground=sd.Ground(...) "
                         "for them to touch")
    if ground is not None:
        ground, contacts = check_ground(robot, ground, contacts, method)
        if position_limits or base_motion is not None or rtol is not None or atol is not None:
            raise ValueError("with a ground: no position_limits, base_motion, rtol or atol "
                             "(semi-implicit Euler with contacts has none of them yet)")
    bar = Progress(duration, progress)
    start = time.perf_counter()
    try:
        if ground is not None:
            q0 = robot.integrate(q0, np.zeros(robot.nv), 0.0) if on_a_group(robot) else q0
            out = run_with_ground(robot, duration, q0, qd0, inputs,
                                  DEFAULT_DT if dt is None else float(dt), dissipation,
                                  output_dt, check_energy, bar, ground, contacts)
        elif on_a_group(robot):
            fixed = method in FIXED_STEP
            out = run_on_group(robot, duration, robot.integrate(q0, np.zeros(robot.nv), 0.0),
                               qd0, inputs, method, dt=(DEFAULT_DT if dt is None else float(dt)),
                               rtol=None if fixed else (DEFAULT_RTOL if rtol is None else rtol),
                               atol=None if fixed else (DEFAULT_ATOL if atol is None else atol),
                               max_step=max_step, first_step=first_step, dissipation=dissipation,
                               output_dt=output_dt, check_energy=check_energy, bar=bar,
                               position_limits=position_limits)
        elif method in FIXED_STEP:
            if rtol is not None or atol is not None:
                raise ValueError(f"{method!r} is a fixed-step method: give dt, not rtol/atol")
            dt = DEFAULT_DT if dt is None else float(dt)
            args = (robot, duration, q0, qd0, inputs, method, dt, dissipation, output_dt,
                    check_energy, bar)
            if (method == "semi_implicit_euler" and robot.compiled_chain is not None
                    and not callable(torque) and wrenches is None and inputs.wrench is None
                    and inputs.base is None
                    and not position_limits):
                out = run_compiled(*args)           # the compiled loop has no stops
            else:
                out = run_fixed(*args, position_limits, jacobian)
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
            out = run_adaptive(robot, duration, q0, qd0, inputs, method, rtol, atol, max_step,
                               first_step, dissipation, friction_smoothing, output_dt,
                               check_energy, bar, jacobian)
    finally:
        bar.close()
    out.stats.wall_time = time.perf_counter() - start
    return out


def check_on_group(method, position_limits, base_motion, dt, rtol, atol):
    """What a floating base (q on a group, sim/group.py) cannot do, named."""
    if base_motion is not None:
        raise ValueError("base_motion is not available for a floating base (its base moves "
                         "by its own dynamics)")
    if position_limits and method not in FIXED_STEP:
        raise ValueError(f"position_limits needs a fixed-step method "
                         f"{list(FIXED_STEP)}: {method!r} has no impact events")
    if method in FIXED_STEP and (rtol is not None or atol is not None):
        raise ValueError(f"{method!r} is a fixed-step method: give dt, not rtol/atol")
    if method not in FIXED_STEP and dt is not None:
        raise ValueError(f"{method!r} is adaptive: give rtol/atol, not dt")
