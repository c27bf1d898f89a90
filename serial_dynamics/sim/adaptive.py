"""The adaptive run loop of ``simulate``: scipy.integrate's OdeSolver classes ("RK45",
"DOP853", "Radau", "BDF", "LSODA") stepped one step at a time, with the state checks,
the output grid by dense output, and the work statistics (rejected steps included).

The state is y = [q, qd, W_act, W_diss, W_ext]: the works are integrated alongside.
Coulomb friction is regularized (``Dissipation.smooth_torque``). The implicit solvers get
the analytical Jacobian (``jacobians.py``), or with ``jacobian="finite_differences"``
forward differences from one batched forward-dynamics call over perturbed states. Only public
solver attributes are read.
"""
from __future__ import annotations

import numpy as np

from .equations import EnergyGuard, Equations
from .jacobians import accel_jacobian, analytical, perturbed
from ..model.errors import SimulationError
from .methods import IMPLICIT, advice
from .result import SolverStats, finish


def run_adaptive(robot, duration, q0, qd0, inputs, method, rtol, atol, max_step, first_step,
                 dissipation, smoothing, output_dt, check_energy, bar, jacobian="analytical"):
    """``simulate`` with an adaptive method."""
    import scipy.integrate as si
    eq = Equations(robot, dissipation, smoothing)
    n = eq.n
    smooth = eq.coulomb_on
    has_w = inputs.wrench is not None or inputs.base is not None
    counter = [0]

    def fun(t, y):
        counter[0] += 1
        q, qd = y[:n], y[n:2 * n]
        if not np.isfinite(y[:2 * n]).all():
            return np.full_like(y, np.nan)      # the solver rejects the step
        tau, w = inputs(t, q, qd)
        qdd, delta = eq.accel(q, qd, tau, w, smooth=smooth)
        out = np.empty(2 * n + 3)
        out[:n], out[n:2 * n] = qd, qdd
        out[2 * n], out[2 * n + 1] = tau @ qd, delta @ qd
        out[2 * n + 2] = float(eq.ext_power(q, qd, w)) if has_w else 0.0
        return out

    y0 = np.concatenate([q0, qd0, np.zeros(3)])
    Solver = getattr(si, method)
    kw = dict(rtol=rtol, atol=atol, max_step=max_step)
    if first_step is not None:
        kw["first_step"] = first_step
    if method in IMPLICIT:
        kw["jac"] = jacobians(eq, inputs, smooth)[0 if analytical(jacobian) else 1]
    solver = Solver(fun, 0.0, y0, duration, **kw)
    per_attempt = getattr(solver, "n_stages", None)   # RK: evaluations per attempted step
    guard = EnergyGuard(eq, q0, qd0, method, None, check_energy)
    grid = None if output_dt is None else np.append(np.arange(0.0, duration, output_dt), duration)
    ts, Ys = [0.0], [y0]
    gi = 1
    steps = rejected = 0
    while solver.status == "running":
        t_old = solver.t
        proposed = proposed_step(solver, max_step, duration)
        before = counter[0]
        message = solver.step()
        if solver.status == "failed":
            y = solver.y
            j = int(np.argmax(np.abs(y[n:2 * n]))) if np.all(np.isfinite(y)) else 0
            raise SimulationError(
                f"{method} failed at t = {solver.t:.6g} s ({message}); the fastest joint is "
                f"{eq.names[j]!r}. {advice(method)}", solver.t, eq.names[j], "solver")
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
    calls, states = eq.calls, eq.states
    TAU, WR = inputs.batch(ts, Q, QD)
    QDD, DELTA = eq.accel(Q, QD, TAU, WR, smooth=smooth)
    eq.calls, eq.states = calls, states          # output evaluation is not solver work
    stats = SolverStats(method, steps=steps, nfev=counter[0], njev=solver.njev, nlu=solver.nlu,
                        rejected=rejected, message="ok")
    return finish(eq, ts, Q, QD, QDD, TAU, DELTA, Y[:, 2 * n:], stats, robot.joint_names)


def jacobians(eq, inputs, smooth):
    """(analytical, finite differences): two functions (t, y) -> the Jacobian (2n+3, 2n+3)
    of the state equations of ``run_adaptive`` (y = [q, qd, W_act, W_diss, W_ext])."""
    n = eq.n
    has_w = inputs.wrench is not None or inputs.base is not None

    def jac_analytical(t, y):
        """The analytical Jacobian (``jacobians.accel_jacobian``): one call of the
        derivatives of forward dynamics; the row of W_ext by differences of the external
        power (kinematics, and with a moving base its bias torques)."""
        q, qd = y[:n], y[n:2 * n]
        tau, w = inputs(t, q, qd)
        delta = eq.delta(qd, smooth=smooth)
        dd = eq.delta_derivative(qd, smooth=smooth)
        Aq, Av, Tq, Tv = accel_jacobian(eq, inputs, t, q, qd, tau + delta, w, dd)
        J = np.zeros((2 * n + 3, 2 * n + 3))
        J[:n, n:2 * n] = np.eye(n)
        J[n:2 * n, :n], J[n:2 * n, n:2 * n] = Aq, Av
        # d(tau.qd) = qd^T dtau + tau dqd; d(delta.qd)/dqd = delta + qd ddelta
        J[2 * n, n:2 * n] = tau
        if Tq is not None:
            J[2 * n, :n] += qd @ Tq
            J[2 * n, n:2 * n] += qd @ Tv
        J[2 * n + 1, n:2 * n] = delta + qd * dd
        if has_w:
            X, h = perturbed(y[:2 * n])
            _, W = inputs.batch(t, X[:, :n], X[:, n:])
            p = eq.ext_power(X[:, :n], X[:, n:], W)
            J[2 * n + 2, :2 * n] = (p[1:] - p[0]) / h
        return J

    def jac(t, y):
        """Forward differences of the state equations: one batched dynamics call over the
        state and its 2n perturbations (instead of scipy's column-by-column differences)."""
        X, h = perturbed(y[:2 * n])
        Q, V = X[:, :n], X[:, n:]
        tau, w = inputs.batch(t, Q, V)
        A, D = eq.accel(Q, V, tau, w, smooth=smooth)
        P = np.column_stack([np.einsum("ij,ij->i", tau, V), np.einsum("ij,ij->i", D, V),
                             eq.ext_power(Q, V, w) if has_w else np.zeros(len(V))])
        J = np.zeros((2 * n + 3, 2 * n + 3))
        J[:n, n:2 * n] = np.eye(n)
        J[n:2 * n, :2 * n] = ((A[1:] - A[0]) / h[:, None]).T
        J[2 * n:, :2 * n] = ((P[1:] - P[0]) / h[:, None]).T
        return J

    return jac_analytical, jac


def proposed_step(solver, max_step, t_bound):
    """The step the solver will try next (clipped as scipy does), or None if unknown:
    ``h_abs`` of scipy's RK, Radau and BDF; for LSODA, the step its dense output (the
    Nordsieck history of the last step) is scaled with, which is the step it tries next
    (unknown before the first step)."""
    from scipy.integrate import LSODA
    if not isinstance(solver, LSODA):
        h = min(solver.h_abs, max_step)
    elif solver.t_old is None or solver.t == solver.t_old:
        return None
    else:
        h = float(solver.dense_output().h)
        if not h > 0:
            return None
    return min(h, t_bound - solver.t)
