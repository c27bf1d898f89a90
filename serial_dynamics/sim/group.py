"""Simulation of a robot whose q lives on a Lie group (nq > nv: a floating base's unit
quaternion), in the robot's chart (``robot.chart``, ``robot/charts.py``).

The state is (q, v), q (nq,), v (nv,); the joints are the last ``dof`` coordinates of each,
the base's come first (nb = nv - dof of v). A quaternion integrated as four numbers leaves
the unit sphere; here it never does. Every method integrates in the chart around a
reference configuration q_ref (Munthe-Kaas' RKMK idea): q = chart.point(q_ref, phi), d phi/dt
= chart.rate(q, phi, v), with phi's joint coordinates the joints themselves. The fixed-step
methods re-centre the chart at every step (RK4: the stages in the chart of the step's
start); the adaptive solvers (scipy) integrate in one chart and are restarted in a new
one, from the step size reached, when ``chart.far(phi)`` (a floating base: the turn exceeds
1 rad, far from the chart's singularity at 2 pi). Nothing here asks what the chart is: on
R^n (``charts.Euclidean``) the same steps run, as tests check.

Methods: the adaptive ones ("RK45", "DOP853", "Radau", "BDF", "LSODA"; the implicit ones
with scipy's finite-difference Jacobian) and the fixed-step "semi_implicit_euler" (v, then
the pose with the new v: q(dt phi'(v_new)) in the chart at q; with the joint servo of
``servo.py`` integrated implicitly, its gains on the joints' rows of the whole M),
"symplectic_euler" (momentum form in the chart, ``_symplectic``), "rk4", and
"implicit_midpoint" (x1 = x0 + dt f((x0 + x1)/2) in the chart at q: symmetric, by
simplified Newton with a finite-difference Jacobian, ``_midpoint``); each with hard stops
at the joint limits (``stops.py``'s plastic impact on the whole M: the base is never
stopped, the impulse moves it; a joint resting on its stop is put back on it each step,
without ``JointStops.hold``). Joint dissipation as on R^n, with Coulomb friction smoothed
(tanh) by every method (no stick-slip). Energies and works as on R^n:
E(t) - E(0) = W_act + W_diss + W_ext.
"""
from __future__ import annotations

import numpy as np

from .equations import EnergyGuard, Equations
from ..model.errors import SimulationError
from .methods import ADAPTIVE, FIXED_STEP, advice
from .result import SolverStats, finish
from .servo import Servo, euler_servo
from .stops import JointStops

NEWTON_TOL, MAX_NEWTON = 1e-10, 10   # implicit midpoint: relative correction, iterations
SYMPLECTIC_TOL, SYMPLECTIC_ITER = 1e-14, 50   # symplectic Euler's fixed point (symplectic.py's)
ROUNDOFF = 1e-10     # a correction below this (relative) that stops shrinking is round-off
GROUP_SERVO_METHODS = ("semi_implicit_euler",)   # the joint servo, integrated implicitly


class GroupRates:
    """The right-hand side of the motion with its dissipation and inputs: (a, tau, delta,
    power) at a state; and the divergence check. ``nb``: the base's rows of v (before the
    joints'), ``nqb`` its coordinates of q."""

    def __init__(self, robot, dissipation, method, dt=None):
        self.robot, self.method, self.dt = robot, method, dt
        self.eq = Equations(robot, dissipation)
        self.n = robot.dof
        self.nb, self.nqb = robot.nv - robot.dof, robot.nq - robot.dof

    def rates(self, t, q, v, inputs):
        """(a, tau, delta, power). ``inputs`` gives joint torques (n,) or generalized forces
        (nv,) whose first nb act on the base (wrenches on links): their power is external
        work; the joints' is the torque's."""
        tau, w = inputs(t, q, v)
        nb = self.nb
        base = tau[:nb] if tau.shape[0] == v.shape[0] else None
        tau = tau if base is None else tau[nb:]
        delta = self.eq.delta(v[nb:], smooth=self.eq.coulomb_on)
        a = self.eq.fd(q, v, tau + delta if base is None else np.concatenate([base, tau + delta]), w)
        ext = (0.0 if w is None else float(self.eq.ext_power(q, v, w))) + (
            0.0 if base is None else float(base @ v[:nb]))
        p = np.array([tau @ v[nb:], delta @ v[nb:], ext])
        return a, tau, delta, p

    def check(self, t, q, v):
        if not (np.all(np.isfinite(q[:self.nqb])) and np.all(np.isfinite(v[:self.nb]))):
            raise SimulationError(f"simulation diverged at t = {t:.6g} s: the base's pose or "
                                  f"velocity is not finite. {advice(self.method, self.dt)}",
                                  t, None, "nan")
        self.eq.check_state(t, q[self.nqb:], v[self.nb:], self.method, self.dt)


class GroupStepIntegrator:
    """What ``FixedStepIntegrator(robot, ...)`` is when q lives on a group: ``step(q, v, tau,
    wrench=None, servo=None)`` with q (nq,), v (nv,) and joint torques tau (n,);
    "semi_implicit_euler" (with the joint servo), "symplectic_euler", "rk4" or
    "implicit_midpoint"; ``position_limits``: the joints' stops. Its counters are
    ``FixedStepIntegrator``'s; its Newton iterations use differences and this module's
    tolerances (``jacobian``, ``newton_tol`` and ``max_newton`` are accepted, not read)."""

    METHODS = FIXED_STEP
    SERVO_METHODS = GROUP_SERVO_METHODS

    def __init__(self, robot, method="semi_implicit_euler", dt=1e-3, dissipation=True, *,
                 position_limits=False, **unused):
        if method not in self.METHODS:
            raise ValueError(f"fixed-step method {method!r} unknown; use one of {self.METHODS}")
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.robot, self.method, self.dt, self.dissipation = robot, method, float(dt), dissipation
        self.chart = robot.chart
        self.rhs = GroupRates(robot, dissipation, method, self.dt)
        self.eq = self.rhs.eq
        self.stages = self.jacobians = self.newton_iterations = self.newton_stalls = 0
        self.stops = JointStops.of(self.eq) if position_limits else None
        self.servo_torque = np.zeros(robot.dof)

    impacts = property(lambda self: 0 if self.stops is None else self.stops.impacts,
                       doc="steps in which a joint reached a stop")

    def step(self, q, qd, tau, wrench=None, t=None, servo=None):
        """As ``FixedStepIntegrator.step``; ``servo`` (joint gains and targets, (n,) each)
        with "semi_implicit_euler" only; its torque over the step is left in
        ``servo_torque`` (n,)."""
        if servo is not None and self.method not in self.SERVO_METHODS:
            raise ValueError(f"a servo is integrated implicitly by {self.SERVO_METHODS} only "
                             f"on a floating base (q on a group), not {self.method!r}; use "
                             "one of those")
        tau = np.asarray(tau, dtype=float)
        q1, v1, _ = self.advance(0.0 if t is None else t, np.asarray(q, dtype=float),
                                 np.asarray(qd, dtype=float), Held(tau, wrench), servo=servo)
        return q1, v1

    def advance(self, t, q, v, inputs, energy=False, servo=None):
        """(q1, v1, (tau, delta, a, dW)) one step on from (q, v) at time t."""
        dt, rhs, chart, nb = self.dt, self.rhs, self.chart, self.rhs.nb
        a, tau, delta, p = rhs.rates(t, q, v, inputs)
        self.servo_torque = np.zeros(self.robot.dof)
        if servo is not None:                       # + the implicit servo (servo.py)
            tau_s, y = euler_servo(self.robot.mass_matrix(q), joints_view(q, nb, rhs.nqb), v,
                                   a, on_joints(servo, nb), dt)
            self.servo_torque, a = tau_s[nb:], a + y
            tau = tau + self.servo_torque
        if self.method == "semi_implicit_euler":    # v1 = v + a dt; q1 = q(dt phi'(v1))
            self.stages += 1
            v1 = v + a * dt
            phi0 = chart.centre(q)
            q1 = chart.point(q, dt * chart.rate(q, phi0, v1) + phi0)
            dW = dt * np.array([tau @ v1[nb:], delta @ v1[nb:], p[2]])
        elif self.method == "symplectic_euler":     # momentum form in the chart at q
            self.stages += 1
            q1, v1, dW = self._symplectic(t, q, v, inputs)
        elif self.method == "implicit_midpoint":    # x1 = x0 + dt f((x0 + x1) / 2) in the chart
            x0 = np.concatenate([chart.centre(q), v, np.zeros(3)])
            x1 = self._midpoint(q, x0, x0 + dt * self._f(q, x0, (a, p), inputs, t), inputs, t)
            nv = self.robot.nv
            q1, v1, dW = chart.point(q, x1[:nv]), x1[nv:2 * nv], x1[2 * nv:]
        else:                                       # RK4 in the chart at q (RKMK)
            self.stages += 4
            x0 = np.concatenate([chart.centre(q), v, np.zeros(3)])
            k1 = self._f(q, x0, (a, p), inputs, t)
            k2 = self._f(q, x0 + 0.5 * dt * k1, None, inputs, t + 0.5 * dt)
            k3 = self._f(q, x0 + 0.5 * dt * k2, None, inputs, t + 0.5 * dt)
            k4 = self._f(q, x0 + dt * k3, None, inputs, t + dt)
            x1 = x0 + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            nv = self.robot.nv
            q1, v1, dW = chart.point(q, x1[:nv]), x1[nv:2 * nv], x1[2 * nv:]
        rhs.check(t + dt, q1, v1)
        if self.stops:                              # plastic impacts at the joints' stops
            q1, v1, dE = self.stops.impact(q1, v1, energy)
            dW = dW + np.array([0.0, dE, 0.0])
        return q1, v1, (tau, delta, a, dW)

    def _symplectic(self, t, q, v, inputs):
        """Symplectic Euler in momentum form (``symplectic.py``'s step) in the chart at q,
        phi = phi0 (its centre), where L(phi, phi') = T - V with phi' = C v (the chart's
        rates; a floating base: C = diag(R, J_r^-1, 1), ``charts.FreeFlyer``): pi = C^-T M v,

            pi1 = pi0 + dt (dL/dphi(phi0, vb) + C^-T Q),   vb = M^-1 C^T pi1 (at phi0)
            phi1 = phi0 + dt C vb,   M(q1) v1 = C(phi1)^T pi1

        with Q = f - g + J^T w + delta(vb) held over the step (the inputs at its start),
        vb by fixed-point iteration. dL/dphi at the centre: dT/dq at fixed v
        (``robot.kinetic_energy_gradient``: zeros on a floating base's rows) plus the
        chart's part (``chart.gradient``: a floating base's h_lin x v_lin - omega x h_ang /
        2). A re-centred chart is a change of coordinates, so the step stays symplectic;
        with no external force a floating base's world linear momentum R h_lin is kept to
        round-off. Returns (q1, v1, dW)."""
        robot, dt, eq, chart, nb = self.robot, self.dt, self.eq, self.chart, self.rhs.nb
        tau, w = inputs(t, q, v)
        f = tau if tau.shape[0] == v.shape[0] else np.concatenate([np.zeros(nb), tau])
        Q = f - eq.bias(q, np.zeros(v.shape[0]), w)            # f - g + J^T w
        M = robot.mass_matrix(q)
        C0 = chart.at_centre(q)
        pi0 = C0.covector(M @ v)

        def velocity(vb):             # (M^-1 C^T pi1, pi1, delta) for the guess vb
            force = robot.kinetic_energy_gradient(q, vb) + chart.gradient(vb, M @ vb) + Q
            delta = eq.delta(vb[nb:], smooth=eq.coulomb_on)
            force[nb:] += delta
            pi1 = pi0 + dt * C0.covector(force)
            return np.linalg.solve(M, C0.transposed(pi1)), pi1, delta

        # vb = velocity(vb) by simplified Newton, its Jacobian by forward differences at the
        # first iterate and again every 8 iterations (the plain fixed point contracts slowly
        # where a light body spins fast: 0.7 to 0.9 an iteration on the satellite's wrist)
        nv = v.shape[0]
        vb, prev, A = velocity(v)[0], np.inf, None
        for k in range(SYMPLECTIC_ITER):
            g, pi1, delta = velocity(vb)
            if k % 8 == 0:
                D = np.empty((nv, nv))
                for j in range(nv):
                    e = 1e-7 * max(1.0, abs(vb[j]))
                    x = vb.copy()
                    x[j] += e
                    D[:, j] = (velocity(x)[0] - g) / e
                A = np.eye(nv) - D
                self.jacobians += 1
            dv = np.linalg.solve(A, g - vb)
            vb, scale = vb + dv, 1.0 + np.max(np.abs(vb))
            change = np.max(np.abs(dv))
            if not np.isfinite(change):   # an overflow: the next call would see NaN
                raise SimulationError(f"symplectic Euler: the fixed-point iteration diverged "
                                      f"at t = {t:.6g} s. {advice(self.method, dt)}", t, None,
                                      "newton")
            if change <= SYMPLECTIC_TOL * scale or (change >= prev and change <= ROUNDOFF * scale):
                break                     # converged, or round-off that stops shrinking
            prev = change
        else:
            raise SimulationError(f"symplectic Euler: the fixed-point iteration did not "
                                  f"converge within {SYMPLECTIC_ITER} iterations at t = "
                                  f"{t:.6g} s. {advice(self.method, dt)}", t, None, "newton")
        _, pi1, delta = velocity(vb)
        self.newton_iterations += k + 1
        phi = dt * C0.vector(vb) + chart.centre(q)
        q1 = chart.point(q, phi)
        v1 = np.linalg.solve(robot.mass_matrix(q1), chart.transposed(q1, phi, pi1))
        ext = 0.0 if w is None else float(eq.ext_power(q, vb, w))
        dW = dt * np.array([tau[-robot.dof:] @ vb[nb:], delta @ vb[nb:],
                            ext + (f[:nb] @ vb[:nb] if tau.shape[0] == v.shape[0] else 0.0)])
        return q1, v1, dW

    def _midpoint(self, q, x0, x1, inputs, t):
        """The implicit midpoint rule's x1 in the chart at q, by simplified Newton from the
        guess x1 (explicit Euler): the Jacobian of f by forward differences at the guess's
        midpoint (2 nv + 1 calls), then x1 += (1 - dt/2 J)^-1 (x0 + dt f(xm) - x1) until the
        correction is below NEWTON_TOL (relative). The works (x's last three) follow f at
        the final midpoint; they do not feed back."""
        dt, m, tm = self.dt, 2 * self.robot.nv, t + 0.5 * self.dt

        def f(x):
            self.stages += 1
            return self._f(q, x, None, inputs, tm)

        xm = 0.5 * (x0 + x1)
        fm = f(xm)
        J = np.empty((m, m))
        for j in range(m):
            h = 1e-7 * max(1.0, abs(xm[j]))
            xp = xm.copy()
            xp[j] += h
            J[:, j] = (f(xp)[:m] - fm[:m]) / h
        self.jacobians += 1
        A = np.eye(m) - 0.5 * dt * J
        for _ in range(MAX_NEWTON):
            dx = np.linalg.solve(A, x0[:m] + dt * fm[:m] - x1[:m])
            x1[:m] += dx
            fm = f(0.5 * (x0 + x1))
            self.newton_iterations += 1
            if np.linalg.norm(dx) <= NEWTON_TOL * (1.0 + np.linalg.norm(x1[:m])):
                break
        else:
            raise SimulationError(f"implicit midpoint: Newton did not converge within "
                                  f"{MAX_NEWTON} iterations at t = {t:.6g} s. "
                                  f"{advice(self.method, dt)}", t, None, "newton")
        x1[m:] = x0[m:] + dt * fm[m:]
        return x1

    def _f(self, q_ref, x, known, inputs, t):
        """[phi'; a; power] at x = [phi; v; W] in the chart at q_ref (``known``: (a, power)
        already computed there)."""
        nv = self.robot.nv
        q = self.chart.point(q_ref, x[:nv])
        v = x[nv:2 * nv]
        a, _, _, p = self.rhs.rates(t, q, v, inputs) if known is None else (*known[:1], 0, 0, known[1])
        return np.concatenate([self.chart.rate(q, x[:nv], v), a, p])


def on_joints(s, nb):
    """The joint servo ``s`` on the whole v: no gains, no targets on the base's nb rows."""
    z = np.zeros(nb)
    return Servo(*(np.concatenate([z, x]) for x in s))


def joints_view(q, nb, nqb):
    """q's joint positions (after its nqb base coordinates) after ``nb`` zeros (the base's
    rows of v, where the servo has no gain): the positions the servo reads, aligned with v."""
    return np.concatenate([np.zeros(nb), q[nqb:]])


class Held:
    """Inputs (joint torques, tip wrench) held over one step of the node's integrator."""

    def __init__(self, tau, wrench):
        self.tau, self.wrench = tau, wrench

    def __call__(self, t, q, v):
        return self.tau, self.wrench


def run_on_group(robot, duration, q0, v0, inputs, method, *, rtol, atol, dt, max_step,
                 first_step, dissipation, output_dt, check_energy, bar, position_limits=False):
    """``simulate`` when q lives on a group, in the robot's chart (module docstring)."""
    if method in ADAPTIVE:
        return _run_adaptive(robot, duration, q0, v0, inputs, method, rtol, atol, max_step,
                             first_step, dissipation, output_dt, check_energy, bar)
    integ = GroupStepIntegrator(robot, method, dt, dissipation, position_limits=position_limits)
    eq = integ.eq
    nsteps = int(np.ceil(duration / dt - 1e-9))
    every = 1 if output_dt is None else max(1, int(round(output_dt / dt)))
    guard = EnergyGuard(eq, q0, v0, method, dt, check_energy)
    q, v, W = q0.copy(), v0.copy(), np.zeros(3)
    rows = []
    for k in range(nsteps):
        q1, v1, (tau, delta, a, dW) = integ.advance(k * dt, q, v, inputs, True)
        if k % every == 0:
            rows.append((k * dt, q, v, a, tau, delta, W.copy()))
        q, v, W = q1, v1, W + dW
        if (k + 1) % 50 == 0:
            guard((k + 1) * dt, q, v, W)
            bar((k + 1) * dt)
    a, tau, delta, _ = integ.rhs.rates(nsteps * dt, q, v, inputs)
    rows.append((nsteps * dt, q, v, a, tau, delta, W))
    guard(nsteps * dt, q, v, W)
    stats = SolverStats(method, steps=nsteps, nfev=integ.stages,
                        message=f"fixed step dt = {dt:g} s" + (
                            f"; a joint reached a stop in {integ.impacts} steps"
                            if integ.impacts else ""))
    return _finish(eq, rows, stats, robot)


def _run_adaptive(robot, duration, q0, v0, inputs, method, rtol, atol, max_step, first_step,
                  dissipation, output_dt, check_energy, bar):
    import scipy.integrate as si
    rhs = GroupRates(robot, dissipation, method)
    eq, nv, chart = rhs.eq, robot.nv, robot.chart
    counter = [0]

    def solver_at(t0, q_ref, v, W, h):
        def fun(t, x):
            counter[0] += 1
            if not np.all(np.isfinite(x)):
                return np.full_like(x, np.nan)              # the solver rejects the step
            q = chart.point(q_ref, x[:nv])
            a, _, _, p = rhs.rates(t, q, x[nv:2 * nv], inputs)
            return np.concatenate([chart.rate(q, x[:nv], x[nv:2 * nv]), a, p])
        x0 = np.concatenate([chart.centre(q_ref), v, W])
        kw = dict(rtol=rtol, atol=atol, max_step=max_step)
        if h is not None:
            kw["first_step"] = min(h, duration - t0)
        return getattr(si, method)(fun, t0, x0, duration, **kw)

    guard = EnergyGuard(eq, q0, v0, method, None, check_energy)
    grid = None if output_dt is None else np.append(np.arange(0.0, duration, output_dt), duration)
    q_ref, solver = q0.copy(), solver_at(0.0, q0, v0, np.zeros(3), first_step)
    samples = [(0.0, q0, v0, np.zeros(3))]
    gi, steps, charts = 1, 0, 1
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            raise SimulationError(f"{method} failed at t = {solver.t:.6g} s ({message}). "
                                  f"{advice(method)}", solver.t, None, "solver")
        steps += 1
        x = solver.y
        q, v, W = chart.point(q_ref, x[:nv]), x[nv:2 * nv], x[2 * nv:]
        rhs.check(solver.t, q, v)
        if grid is None:
            samples.append((solver.t, q, v.copy(), W.copy()))
        else:
            dense = solver.dense_output() if gi < grid.size and grid[gi] < solver.t else None
            while gi < grid.size and grid[gi] <= solver.t + 1e-12 * max(1.0, duration):
                xg = x if dense is None or grid[gi] >= solver.t else dense(grid[gi])
                samples.append((grid[gi], chart.point(q_ref, xg[:nv]),
                                xg[nv:2 * nv].copy(), xg[2 * nv:].copy()))
                gi += 1
        if steps % 20 == 0:
            guard(solver.t, q, v, W)
        bar(solver.t)
        if solver.status == "running" and chart.far(x[:nv]):
            q_ref, charts = q, charts + 1                 # a new chart around the pose reached
            solver = solver_at(solver.t, q, v.copy(), W.copy(), solver.step_size)
    guard(samples[-1][0], *samples[-1][1:])
    calls, states = eq.calls, eq.states
    rows = []
    for t, q, v, W in samples:
        a, tau, delta, _ = rhs.rates(t, q, v, inputs)
        rows.append((t, q, v, a, tau, delta, W))
    eq.calls, eq.states = calls, states                  # output evaluation is not solver work
    stats = SolverStats(method, steps=steps, nfev=counter[0],
                        message=f"ok; {charts} chart{'s' if charts > 1 else ''} of "
                        f"{chart.group}")
    return _finish(eq, rows, stats, robot)


def _finish(eq, rows, stats, robot):
    t, Q, V, A, TAU, DELTA, W = (np.array(c) for c in zip(*rows))
    return finish(eq, t, Q, V, A, TAU, DELTA, W, stats, robot.joint_names)
