"""``simulate`` with semi-implicit Euler in one compiled loop
(``compiled_euler.simulate_fixed_step``): ``run_compiled``, for torques known in advance.
Apart from ``fixed_step`` so that ``compiled_euler`` (whose robots without a compiled chain
run ``FixedStepIntegrator``) imports no module that imports it back.
"""
from __future__ import annotations

import numpy as np

from .equations import EnergyGuard, Equations
from .fixed_step import run_fixed
from .compiled_euler import simulate_fixed_step
from .result import SolverStats, finish


def run_compiled(robot, duration, q0, qd0, inputs, method, dt, dissipation, output_dt,
                 check_energy, bar):
    """Semi-implicit Euler in one compiled loop (``compiled_euler.simulate_fixed_step``), for torques
    known in advance (not state feedback), no tip wrench and no Coulomb friction; the same
    steps, explicit damping and work quadrature as FixedStepIntegrator. Falls back to the
    step-by-step loop otherwise."""
    eq = Equations(robot, dissipation)
    if eq.coulomb_on:   # stick-slip needs the step-by-step integrator
        return run_fixed(robot, duration, q0, qd0, inputs, method, dt, dissipation,
                         output_dt, check_energy, bar)
    nsteps = int(np.ceil(duration / dt - 1e-9))
    ts = np.arange(nsteps + 1) * dt
    tau = np.array([inputs.torque(t, None, None) for t in ts])   # (nsteps + 1, n)
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
    guard = EnergyGuard(eq, q0, qd0, method, dt, check_energy)
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
    return finish(eq, ts[keep], Q[keep], QD[keep], QDD[keep], tau[keep], delta[keep], W[keep],
                  stats, robot.joint_names)
