"""Simulation of a robot on a free-floating base: the base pose integrated on SE(3).

The state is (q, v), q (n+7) with a unit quaternion, v (n+6) (``FloatingRobot``). A
quaternion integrated as four numbers leaves the unit sphere; here it never does. Every
method integrates in a local chart around a reference pose q_ref (Munthe-Kaas' RKMK idea,
with the chart of SO(3) x R^3):

    q(phi) = [p_ref + dp, quat_ref (x) Exp(dtheta), joints]
    d(dp)/dt = R v_O,   d(dtheta)/dt = J_r(dtheta)^-1 omega,   d(joints)/dt = qd

(J_r: the right Jacobian of SO(3); Chirikjian 2011, Sec. 10.2; J_r^-1 = 1 + [x]/2 + (1/t^2 -
(1 + cos t) / (2 t sin t)) [x]^2, x = dtheta, t = |x|.) The pose comes out of the exponential
map, so the quaternion has unit length to round-off. The fixed-step methods re-center the
chart at every step (RK4: the stages in the chart of the step's start); the adaptive solvers
(scipy) integrate in one chart and are restarted in a new one, from the step size reached,
when |dtheta| exceeds CHART_LIMIT = 1 rad (far from the chart's singularity at 2 pi).

Methods: the adaptive ones ("RK45", "DOP853", "Radau", "BDF", "LSODA"; the implicit ones
with scipy's finite-difference Jacobian) and the fixed-step "semi_implicit_euler" (v, then
the pose with the new v: q(dt phi'(v_new)) in the chart at q; with the joint servo of
``servo.py`` integrated implicitly, its gains on the joints' rows of the whole M),
"symplectic_euler" (momentum form in the chart, ``_symplectic``), "rk4", and
"implicit_midpoint" (x1 = x0 + dt f((x0 + x1)/2) in the chart at q: symmetric, by
simplified Newton with a finite-difference Jacobian, ``_midpoint``); each with hard stops
at the joint limits (``stops.py``'s plastic impact on the whole M: the base is never
stopped, the impulse moves it; a joint resting on its stop is put back on it each step,
without ``JointStops.hold``). Joint dissipation as for a fixed base, with Coulomb friction
smoothed (tanh) by every method (no stick-slip). Energies and works as for a fixed base:
E(t) - E(0) = W_act + W_diss + W_ext.
"""
from __future__ import annotations

import math

import numpy as np

from ..algorithms._batch import skew
from ..algorithms.floating import quaternion_matrix
from .equations import EnergyGuard, Equations
from .fixed_step import FixedStepIntegrator
from ..model.errors import SimulationError
from .methods import ADAPTIVE, advice
from .result import SolverStats, finish
from .servo import Servo, euler_servo
from .stops import JointStops

CHART_LIMIT = 1.0          # rad: an adaptive run moves to a new chart beyond this turn
FLOATING_FIXED_STEP = ("semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint")
NEWTON_TOL, MAX_NEWTON = 1e-10, 10   # implicit midpoint: relative correction, iterations
SYMPLECTIC_TOL, SYMPLECTIC_ITER = 1e-14, 50   # symplectic Euler's fixed point (symplectic.py's)
ROUNDOFF = 1e-10     # a correction below this (relative) that stops shrinking is round-off
FLOATING_METHODS = ADAPTIVE + FLOATING_FIXED_STEP
_ZERO_CHART = np.zeros(6)                 # phi's rotation part at the chart's centre


def chart_point(q_ref, phi):
    """q(phi): the pose in the chart around ``q_ref`` (module docstring); phi (n+6,)."""
    x, y, z = phi[3:6].tolist()
    t = math.sqrt(x * x + y * y + z * z)
    k = 0.5 - t * t / 48.0 if t < 1e-4 else math.sin(0.5 * t) / t     # sin(t/2) / t
    bx, by, bz, bw = k * x, k * y, k * z, math.cos(0.5 * t)            # Exp(dtheta), [x, y, z, w]
    ax, ay, az, aw = q_ref[3:7].tolist()
    quat = [aw * bx + bw * ax + ay * bz - az * by, aw * by + bw * ay + az * bx - ax * bz,
            aw * bz + bw * az + ax * by - ay * bx, aw * bw - ax * bx - ay * by - az * bz]
    nrm = math.sqrt(sum(c * c for c in quat))
    q = np.empty(q_ref.shape[0])
    q[:3] = q_ref[:3] + phi[:3]
    q[3:7] = [c / nrm for c in quat]
    q[7:] = phi[6:]
    return q


def chart_rate(q, phi, v):
    """d phi/dt at q = q(phi) moving with v (module docstring)."""
    x1, x2, x3 = phi[3:6].tolist()
    t = math.sqrt(x1 * x1 + x2 * x2 + x3 * x3)
    k = 1.0 / 12.0 if t < 1e-4 else 1.0 / t**2 - (1.0 + math.cos(t)) / (2.0 * t * math.sin(t))
    u1, u2, u3, w1, w2, w3 = v[:6].tolist()
    c1, c2, c3 = x2 * w3 - x3 * w2, x3 * w1 - x1 * w3, x1 * w2 - x2 * w1         # x x w
    d1, d2, d3 = x2 * c3 - x3 * c2, x3 * c1 - x1 * c3, x1 * c2 - x2 * c1         # x x (x x w)
    x, y, z, s = q[3:7].tolist()
    out = np.empty(v.shape[0])
    out[0] = (1 - 2 * (y * y + z * z)) * u1 + 2 * (x * y - z * s) * u2 + 2 * (x * z + y * s) * u3
    out[1] = 2 * (x * y + z * s) * u1 + (1 - 2 * (x * x + z * z)) * u2 + 2 * (y * z - x * s) * u3
    out[2] = 2 * (x * z - y * s) * u1 + 2 * (y * z + x * s) * u2 + (1 - 2 * (x * x + y * y)) * u3
    out[3:6] = w1 + 0.5 * c1 + k * d1, w2 + 0.5 * c2 + k * d2, w3 + 0.5 * c3 + k * d3
    out[6:] = v[6:]
    return out


class FloatingStepper:
    """The right-hand side of a floating robot's motion with its dissipation and inputs:
    (a, tau, delta, power) at a state; and the divergence check."""

    def __init__(self, robot, dissipation, method, dt=None):
        self.robot, self.method, self.dt = robot, method, dt
        self.eq = Equations(robot, dissipation)
        self.n = robot.dof

    def rates(self, t, q, v, inputs):
        """(a, tau, delta, power). ``inputs`` gives joint torques (n,) or generalized forces
        (n+6,) whose first six act on the base (wrenches on links): their power is external
        work; the joints' is the torque's."""
        tau, w = inputs(t, q, v)
        base = tau[:6] if tau.shape[0] == v.shape[0] else None
        tau = tau if base is None else tau[6:]
        delta = self.eq.delta(v[6:], smooth=self.eq.coulomb_on)
        a = self.eq.fd(q, v, tau + delta if base is None else np.concatenate([base, tau + delta]), w)
        ext = (0.0 if w is None else float(self.eq.ext_power(q, v, w))) + (
            0.0 if base is None else float(base @ v[:6]))
        p = np.array([tau @ v[6:], delta @ v[6:], ext])
        return a, tau, delta, p

    def check(self, t, q, v):
        if not (np.all(np.isfinite(q[:7])) and np.all(np.isfinite(v[:6]))):
            raise SimulationError(f"simulation diverged at t = {t:.6g} s: the base's pose or "
                                  f"velocity is not finite. {advice(self.method, self.dt)}",
                                  t, None, "nan")
        self.eq.check_state(t, q[7:], v[6:], self.method, self.dt)


class FloatingStepIntegrator(FixedStepIntegrator):
    """``FixedStepIntegrator`` for a floating robot: ``step(q, v, tau, wrench=None,
    servo=None)`` with q (n+7), v (n+6) and joint torques tau (n,); "semi_implicit_euler"
    (with the joint servo), "symplectic_euler", "rk4" or "implicit_midpoint"."""

    METHODS = FLOATING_FIXED_STEP
    SERVO_METHODS = ("semi_implicit_euler",)

    def __init__(self, robot, method="semi_implicit_euler", dt=1e-3, dissipation=True, **kw):
        if method not in self.METHODS:
            raise ValueError(f"fixed-step method {method!r} is not available for a floating "
                             f"base; use one of {self.METHODS}")
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.robot, self.method, self.dt, self.dissipation = robot, method, float(dt), dissipation
        self.rhs = FloatingStepper(robot, dissipation, method, self.dt)
        self.eq = self.rhs.eq
        self.stages = self.jacobians = self.newton_iterations = self.newton_stalls = 0
        self.stops = JointStops.of(self.eq) if kw.get("position_limits") else None
        self.servo_torque = np.zeros(robot.dof)

    def step(self, q, qd, tau, wrench=None, t=None, servo=None):
        """As ``FixedStepIntegrator.step``; ``servo`` (joint gains and targets, (n,) each)
        with "semi_implicit_euler" only; its torque over the step is left in
        ``servo_torque`` (n,)."""
        if servo is not None and self.method not in self.SERVO_METHODS:
            raise ValueError(f"a servo is integrated implicitly by {self.SERVO_METHODS} only "
                             f"on a floating base, not {self.method!r}; use one of those")
        tau = np.asarray(tau, dtype=float)
        q1, v1, _ = self.advance(0.0 if t is None else t, np.asarray(q, dtype=float),
                                 np.asarray(qd, dtype=float), _Constant(tau, wrench), servo=servo)
        return q1, v1

    def advance(self, t, q, v, inputs, energy=False, servo=None):
        """(q1, v1, (tau, delta, a, dW)) one step on from (q, v) at time t."""
        dt, rhs = self.dt, self.rhs
        a, tau, delta, p = rhs.rates(t, q, v, inputs)
        self.servo_torque = np.zeros(self.robot.dof)
        if servo is not None:                       # + the implicit servo (servo.py)
            tau_s, y = euler_servo(self.robot.mass_matrix(q), _joints_view(q, 6), v, a,
                                   _on_joints(servo), dt)
            self.servo_torque, a = tau_s[6:], a + y
            tau = tau + self.servo_torque
        if self.method == "semi_implicit_euler":    # v1 = v + a dt; q1 = q (+) v1 dt on SE(3)
            self.stages += 1
            v1 = v + a * dt
            phi = dt * chart_rate(q, _ZERO_CHART, v1)
            phi[6:] += q[7:]                        # the chart holds the joints themselves
            q1 = chart_point(q, phi)
            dW = dt * np.array([tau @ v1[6:], delta @ v1[6:], p[2]])
        elif self.method == "symplectic_euler":     # momentum form in the chart at q
            self.stages += 1
            q1, v1, dW = self._symplectic(t, q, v, inputs)
        elif self.method == "implicit_midpoint":    # x1 = x0 + dt f((x0 + x1) / 2) in the chart
            x0 = np.concatenate([np.zeros(6), q[7:], v, np.zeros(3)])
            x1 = self._midpoint(q, x0, x0 + dt * self._f(q, x0, (a, p), inputs, t), inputs, t)
            nv = self.robot.nv
            q1, v1, dW = chart_point(q, x1[:nv]), x1[nv:2 * nv], x1[2 * nv:]
        else:                                       # RK4 in the chart at q (RKMK)
            self.stages += 4
            x0 = np.concatenate([np.zeros(6), q[7:], v, np.zeros(3)])
            k1 = self._f(q, x0, (a, p), inputs, t)
            k2 = self._f(q, x0 + 0.5 * dt * k1, None, inputs, t + 0.5 * dt)
            k3 = self._f(q, x0 + 0.5 * dt * k2, None, inputs, t + 0.5 * dt)
            k4 = self._f(q, x0 + dt * k3, None, inputs, t + dt)
            x1 = x0 + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            nv = self.robot.nv
            q1, v1, dW = chart_point(q, x1[:nv]), x1[nv:2 * nv], x1[2 * nv:]
        rhs.check(t + dt, q1, v1)
        if self.stops:                              # plastic impacts at the joints' stops
            q1, v1, dE = self.stops.impact(q1, v1, energy)
            dW = dW + np.array([0.0, dE, 0.0])
        return q1, v1, (tau, delta, a, dW)

    def _symplectic(self, t, q, v, inputs):
        """Symplectic Euler in momentum form (``symplectic.py``'s step) in the chart at q,
        phi = 0, where L(phi, phi') = T - V with phi' = C v, C = diag(R, J_r^-1, 1) (the
        chart's rates, module docstring): pi = C^-T M v, and

            pi1 = pi0 + dt (dL/dphi(0, vb) + C^-T Q),   vb = M^-1 C^T pi1 (at phi = 0)
            phi1 = dt C vb,   M(q1) v1 = C(phi1)^T pi1

        with Q = f - g + J^T w + delta(vb) held over the step (the inputs at its start),
        vb by fixed-point iteration. dL/dphi at phi = 0: nothing for the translation (T
        does not depend on it), h_lin x v_lin - omega x h_ang / 2 for the rotation (from
        R(phi) = R0 Exp(phi) and J_r = 1 - [phi]/2 + O(phi^2); h = M v), dT/dq for the
        joints (``robot.kinetic_energy_gradient``). A re-centred chart is a change of
        coordinates, so the step stays symplectic; with no external force the world's
        linear momentum R h_lin is kept to round-off. Returns (q1, v1, dW)."""
        robot, dt, eq = self.robot, self.dt, self.eq
        tau, w = inputs(t, q, v)
        f = tau if tau.shape[0] == v.shape[0] else np.concatenate([np.zeros(6), tau])
        Q = f - eq.bias(q, np.zeros(v.shape[0]), w)            # f - g + J^T w
        M = robot.mass_matrix(q)
        R0 = _rotation(q)
        h0 = M @ v
        pi0 = np.concatenate([R0 @ h0[:3], h0[3:]])

        def velocity(vb):             # (M^-1 C^T pi1, pi1, delta) for the guess vb
            h = M @ vb
            grad = robot.kinetic_energy_gradient(q, vb)          # zeros on the base
            grad[3:6] = np.cross(h[:3], vb[:3]) - 0.5 * np.cross(vb[3:6], h[3:6])
            delta = eq.delta(vb[6:], smooth=eq.coulomb_on)
            force = grad + Q
            force[6:] += delta
            pi1 = pi0 + dt * np.concatenate([R0 @ force[:3], force[3:]])
            return np.linalg.solve(M, np.concatenate([R0.T @ pi1[:3], pi1[3:]])), pi1, delta

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
            if change <= SYMPLECTIC_TOL * scale or (change >= prev and change <= ROUNDOFF * scale):
                break                     # converged, or round-off that stops shrinking
            prev = change
        else:
            raise SimulationError(f"symplectic Euler: the fixed-point iteration did not "
                                  f"converge within {SYMPLECTIC_ITER} iterations at t = "
                                  f"{t:.6g} s. {advice(self.method, dt)}", t, None, "newton")
        _, pi1, delta = velocity(vb)
        self.newton_iterations += k + 1
        phi = dt * np.concatenate([R0 @ vb[:3], vb[3:]])
        phi[6:] += q[7:]                                        # the chart holds the joints
        q1 = chart_point(q, phi)
        h1 = np.concatenate([_rotation(q1).T @ pi1[:3],
                             np.linalg.solve(_right_jacobian(phi[3:6]).T, pi1[3:6]), pi1[6:]])
        v1 = np.linalg.solve(robot.mass_matrix(q1), h1)
        ext = 0.0 if w is None else float(eq.ext_power(q, vb, w))
        dW = dt * np.array([tau[-robot.dof:] @ vb[6:], delta @ vb[6:],
                            ext + (f[:6] @ vb[:6] if tau.shape[0] == v.shape[0] else 0.0)])
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
        nv = self.robot.nv
        q = chart_point(q_ref, x[:nv])
        v = x[nv:2 * nv]
        a, _, _, p = self.rhs.rates(t, q, v, inputs) if known is None else (*known[:1], 0, 0, known[1])
        return np.concatenate([chart_rate(q, x[:nv], v), a, p])


def _rotation(q):
    """R (3, 3) of q's unit quaternion: base axes to world axes."""
    return quaternion_matrix(q[None, 3:7])[0]


def _right_jacobian(x):
    """J_r(x) of SO(3) = 1 - (1 - cos t)/t^2 [x] + (t - sin t)/t^3 [x]^2, t = |x|
    (Chirikjian 2011, Sec. 10.2): omega = J_r(dtheta) d(dtheta)/dt."""
    t = math.sqrt(float(x @ x))
    a, b = (0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0) if t < 1e-4 else (
        (1.0 - math.cos(t)) / t**2, (t - math.sin(t)) / t**3)
    X = skew(x)
    return np.eye(3) - a * X + b * (X @ X)


def _on_joints(s):
    """The joint servo ``s`` on the whole v: no gains, no targets on the base's six rows."""
    z = np.zeros(6)
    return Servo(*(np.concatenate([z, x]) for x in s))


def _joints_view(q, nb):
    """q's joint positions after ``nb`` zeros (the base's rows of v, where the servo has no
    gain): the positions the servo reads, aligned with v."""
    return np.concatenate([np.zeros(nb), q[7:]])


class _Constant:
    """Inputs held over one step of the node's integrator."""

    def __init__(self, tau, wrench):
        self.tau, self.wrench = tau, wrench

    def __call__(self, t, q, v):
        return self.tau, self.wrench


FixedStepIntegrator._kinds["floating"] = FloatingStepIntegrator


def run_floating(robot, duration, q0, v0, inputs, method, *, rtol, atol, dt, max_step,
                 first_step, dissipation, output_dt, check_energy, bar, position_limits=False):
    """``simulate`` for a floating robot (module docstring)."""
    if method in ADAPTIVE:
        return _run_adaptive(robot, duration, q0, v0, inputs, method, rtol, atol, max_step,
                             first_step, dissipation, output_dt, check_energy, bar)
    integ = FloatingStepIntegrator(robot, method, dt, dissipation,
                                   position_limits=position_limits)
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
    rhs = FloatingStepper(robot, dissipation, method)
    eq, nv = rhs.eq, robot.nv
    counter = [0]

    def solver_at(t0, q_ref, v, W, h):
        def fun(t, x):
            counter[0] += 1
            if not np.all(np.isfinite(x)):
                return np.full_like(x, np.nan)              # the solver rejects the step
            q = chart_point(q_ref, x[:nv])
            a, _, _, p = rhs.rates(t, q, x[nv:2 * nv], inputs)
            return np.concatenate([chart_rate(q, x[:nv], x[nv:2 * nv]), a, p])
        x0 = np.concatenate([np.zeros(6), q_ref[7:], v, W])
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
        q, v, W = chart_point(q_ref, x[:nv]), x[nv:2 * nv], x[2 * nv:]
        rhs.check(solver.t, q, v)
        if grid is None:
            samples.append((solver.t, q, v.copy(), W.copy()))
        else:
            dense = solver.dense_output() if gi < grid.size and grid[gi] < solver.t else None
            while gi < grid.size and grid[gi] <= solver.t + 1e-12 * max(1.0, duration):
                xg = x if dense is None or grid[gi] >= solver.t else dense(grid[gi])
                samples.append((grid[gi], chart_point(q_ref, xg[:nv]),
                                xg[nv:2 * nv].copy(), xg[2 * nv:].copy()))
                gi += 1
        if steps % 20 == 0:
            guard(solver.t, q, v, W)
        bar(solver.t)
        if solver.status == "running" and np.linalg.norm(x[3:6]) > CHART_LIMIT:
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
                        message=f"ok; {charts} chart{'s' if charts > 1 else ''} of SE(3)")
    return _finish(eq, rows, stats, robot)


def _finish(eq, rows, stats, robot):
    t, Q, V, A, TAU, DELTA, W = (np.array(c) for c in zip(*rows))
    return finish(eq, t, Q, V, A, TAU, DELTA, W, stats, robot.joint_names)
