"""The compiled whole-run fixed-step loop: semi-implicit Euler over the compiled core.

Owns ``simulate_fixed_step`` (checks the inputs, then runs the loop, or, for a robot the
compiled loop cannot run -- mimic joints, a floating base, the NumPy backend --
``FixedStepIntegrator`` step by step as ``sd.simulate`` does) and the loop itself,
``semi_implicit_euler_loop``: per step, forward dynamics by the core's Cholesky or
articulated-body route, then THE semi-implicit Euler step of ``steps.py`` -- the one the
step-by-step integrator calls too, so both give the same numbers. Compiled on first use
(``sd.simulate`` with a fixed-step method and no per-step Python input); the nodes never
call it.
"""
from __future__ import annotations

import numpy as np
from numba import types

from ..algorithms.aba import CROSSOVER
from ..core import flags as F
from ..core.aba import aba_core
from ..core.cache import njit_in
from ..core.data import heap_empty, new_art, new_chol, new_kin, stack_empty
from ..core.forward import cholesky_core
from ..core.signatures import In1, In2, Out2, Pm, compile_internal, f8, i8
from .equations import SimulationError
from .fixed_step import FixedStepIntegrator
from .steps import semi_implicit_euler_step


def semi_implicit_euler_loop(P, q0, qd0, tau, dt, nsteps, viscous, w, flags):
    """(q, qd) over ``nsteps`` steps, each (nsteps + 1, n), the initial state first, NaN
    from the first step whose state is not finite on. Per step k:
    qdd = FD(q, qd, tau_k - viscous qd [, w_k]); with flag DAMPING the damping acts on the
    new velocity, (M + dt diag(viscous)) qdd = tau_k - viscous qd - b (as MuJoCo's Euler),
    which is stable for any step; then qd += dt qdd, q += dt qd."""
    n = P.shape[0] - 1
    qs, qds = heap_empty((nsteps + 1, n)), heap_empty((nsteps + 1, n))
    qs[:, :] = np.nan                   # rows after a divergence stay NaN
    qds[:, :] = np.nan
    d, c, a = new_kin(n), new_chol(n), new_art(n)
    t, qdd, damping = stack_empty((n,)), stack_empty((n,)), stack_empty((n,))
    q, qd = stack_empty((n,)), stack_empty((n,))
    for i in range(n):                  # element loops: numba compiles array-slice assignment slowly
        q[i], qd[i] = q0[i], qd0[i]
        qs[0, i], qds[0, i] = q[i], qd[i]
        damping[i] = dt * viscous[i]
    ntau, nw = tau.shape[0] > 1, w.shape[0] > 1
    use_w = w.shape[0] > 0
    flags = F.QD | (flags & (F.ABA | F.DAMPING)) | (F.WRENCH if use_w else 0)
    for k in range(nsteps):
        tk = tau[k if ntau else 0]
        for i in range(n):
            t[i] = tk[i] - viscous[i] * qd[i]
        wk = w[k if nw else 0] if use_w else t      # t stands in, unread, without a wrench
        if (flags & F.ABA) != 0:
            chk = aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y,
                           q, qd, t, wk, damping, flags, qdd)
        else:
            chk = cholesky_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, q, qd, t, wk, damping, flags, qdd)
        semi_implicit_euler_step(q, qd, qdd, dt)
        ok = chk == 0.0
        for i in range(n):
            ok = ok and q[i] - q[i] == 0.0 and qd[i] - qd[i] == 0.0
        if not ok:
            break
        for i in range(n):
            qs[k + 1, i], qds[k + 1, i] = q[i], qd[i]
    return qs, qds


_SIGNATURE = types.Tuple((Out2, Out2))(Pm, In1, In1, In2, f8, i8, In1, In2, i8)
_compiled = []


def _loop():
    """The loop, compiled (or loaded from the numba cache) on first use."""
    if not _compiled:
        compile_internal(("aba_core", "cholesky_core"))
        _compiled.append(njit_in("sim", [_SIGNATURE])(semi_implicit_euler_loop))
    return _compiled[0]


def simulate_fixed_step(robot, q0, qd0, tau, dt, nsteps, viscous=None, wrench=None,
                        method="auto", implicit_damping=True):
    """The whole run of semi-implicit Euler steps from (q0, qd0), in the robot's own
    coordinates: qdd = FD(q, qd, tau_k - viscous * qd, wrench_k), then qd += dt qdd,
    q += dt qd (on a floating base, q moves on SE(3) x R^n).

    Arguments: ``q0`` (nq,), ``qd0`` (nv,); ``tau`` (dof,) constant or (nsteps, dof) one
    row per step (the joints' torques); ``viscous`` (dof,) N m s/rad or None; ``wrench``
    None, (6,) or (nsteps, 6) on the tip in base coordinates; ``method`` "auto",
    "cholesky" or "aba" (forward dynamics of the compiled loop); ``implicit_damping``:
    True solves (M + dt diag(viscous)) qdd = tau - viscous qd - b (stable at any step),
    False applies the damping explicitly (stable only while dt viscous / M_ii < 2).
    Returns (q, qd), (nsteps + 1, nq) and (nsteps + 1, nv) with the initial state first,
    NaN from the first non-finite (or diverged) state on.

    Runs the compiled loop on ``robot.compiled_chain``; a robot without one (mimic joints,
    a floating base, the NumPy backend) runs ``FixedStepIntegrator`` step by step, as
    ``sd.simulate`` does, so both give the same bits.
    """
    n, nq, nv = robot.dof, robot.nq, robot.nv
    q0 = _checked(np.ascontiguousarray(q0, dtype=float), (nq,), "q0")
    qd0 = _checked(np.ascontiguousarray(qd0, dtype=float), (nv,), "qd0")
    viscous = (np.zeros(n) if viscous is None
               else _checked(np.ascontiguousarray(viscous, dtype=float), (n,), "viscous"))
    tau = np.ascontiguousarray(np.atleast_2d(np.asarray(tau, dtype=float)))
    _checked(tau, ((1, n), (nsteps, n)), "tau")
    w = (np.zeros((0, 6)) if wrench is None
         else np.ascontiguousarray(np.atleast_2d(np.asarray(wrench, dtype=float))))
    _checked(w, ((0, 6), (1, 6), (nsteps, 6)), "wrench")
    if method == "auto":
        method = "aba" if n >= CROSSOVER else "cholesky"
    if method not in ("cholesky", "aba"):
        raise ValueError(f"method {method!r} unknown; use 'auto', 'cholesky' or 'aba'")
    if not dt > 0 or int(nsteps) != nsteps or nsteps < 0:
        raise ValueError(f"dt = {dt}, nsteps = {nsteps}: need dt > 0 and an integer nsteps >= 0")
    P = robot.compiled_chain
    if P is None:
        return _stepped(robot, q0, qd0, tau, float(dt), int(nsteps), viscous, w,
                        implicit_damping)
    flags = (F.ABA if method == "aba" else 0) | (F.DAMPING if implicit_damping else 0)
    return _loop()(P, q0, qd0, tau, float(dt), int(nsteps), viscous, w, flags)


def _stepped(robot, q0, qd0, tau, dt, nsteps, viscous, w, implicit_damping):
    """``simulate_fixed_step`` by ``FixedStepIntegrator`` (semi-implicit Euler, no other
    dissipation), one step at a time; implicit damping is its implicit servo with Kp = 0,
    Kd = viscous, qd* = 0: (M + dt Kd) qd1 = M qd0 + dt (tau - b), the same equations."""
    from .servo import Servo
    n, nq, nv = robot.dof, robot.nq, robot.nv
    implicit = implicit_damping and np.any(viscous != 0.0)
    if implicit and nv != n:
        raise ValueError("implicit damping on a floating base is not available (the implicit "
                         "servo acts on joints only); pass implicit_damping=False")
    damper = Servo(np.zeros(n), viscous, np.zeros(n), np.zeros(n)) if implicit else None
    integ = FixedStepIntegrator(robot, "semi_implicit_euler", dt, dissipation=False)
    qs, qds = np.full((nsteps + 1, nq), np.nan), np.full((nsteps + 1, nv), np.nan)
    q, qd = q0, qd0
    qs[0], qds[0] = q, qd
    for k in range(nsteps):
        tk = tau[k if tau.shape[0] > 1 else 0]
        if not implicit and np.any(viscous != 0.0):
            tk = tk - viscous * qd[nv - n:]          # the joints' rates: the last n of v
        wk = w[k if w.shape[0] > 1 else 0] if w.shape[0] else None
        try:
            q, qd = integ.step(q, qd, tk, wk, t=k * dt, servo=damper)
        except SimulationError:
            break
        qs[k + 1], qds[k + 1] = q, qd
    return qs, qds


def _checked(a, shapes, name):
    shapes = shapes if isinstance(shapes[0], tuple) else (shapes,)
    if a.shape not in shapes:
        raise ValueError(f"{name} has shape {a.shape}; expected one of {list(shapes)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has a NaN or Inf entry; give finite numbers")
    return a
