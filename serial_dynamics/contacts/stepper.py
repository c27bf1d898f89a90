"""Contacts with a ground one step at a time: ``GroundStepper`` (``FixedStepIntegrator``'s
interface: ``step(q, v, tau, wrench, t, servo)``, ``servo_torque``), ``GroundSession`` (a
``sim.session.Session`` stepped by it, for the simulator node, holding the contact forces
of its last step) and ``run_with_ground`` (``sd.simulate`` with a ground). The step is
``stepping.py``'s (semi-implicit Euler, velocity-level time stepping, projected
Gauss-Seidel; docs/simulation.md): in one compiled call where ``compiled_step.py`` covers
the robot and the step's inputs (``GroundStepper.advance`` chooses, once for the robot by
``CompiledGround.of`` and per step by its inputs), else in NumPy; a run whose torques are
known in advance is one compiled call for all its steps.

The joint servo (``sim/servo.py``) stays implicit with the contacts in one step: with
D = dt Kd + dt^2 Kp on the joints' rows (0 on a floating base's), semi-implicit Euler with
the servo torque at the end of the step and the contacts' impulses lambda reads

    (M + D) v1 = M v + dt (tau + delta - b) + dt (Kp (q* - q) + Kd qd*) + J^T lambda,

so the free velocity is ``euler_servo``'s and the contacts see G = J (M + D)^-1 J^T: the
servo stiffens the legs under the impulses within the step, as it does in the step. Joint
stops (``position_limits``) act after the contacts, as in ``sim/group.py``.
"""
from __future__ import annotations

import numpy as np

from ..sim.equations import EnergyGuard
from ..sim.group import GroupRates, Held, joints_view, on_joints
from ..sim.result import SolverStats, finish
from ..sim.servo import euler_servo
from ..sim.session import Session
from ..sim.stops import JointStops
from .compiled_step import DIVERGED, POWER_DELTA, POWER_TAU, WORK, CompiledGround
from .stepping import GroundContacts, check_ground

METHOD = "semi_implicit_euler"


class GroundStepper:
    """One semi-implicit Euler step of ``robot`` with its point ``contacts`` on ``ground``
    (both checked by ``stepping.check_ground``). After each ``step``: ``forces`` (k, 3) on
    the robot, world axes, N, over the step; ``active`` (k,) which contacts pushed;
    ``servo_torque`` (dof,) the servo's torque over the step."""

    METHODS = SERVO_METHODS = (METHOD,)

    def __init__(self, robot, ground, contacts, dt=1e-3, dissipation=True, *,
                 position_limits=False):
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.ground, self.contacts = check_ground(robot, ground, contacts, METHOD)
        self.robot, self.method, self.dt, self.dissipation = robot, METHOD, float(dt), dissipation
        self.rhs = GroupRates(robot, dissipation, METHOD, self.dt)
        self.eq, self.chart = self.rhs.eq, robot.chart
        self.solver = GroundContacts(robot, self.ground, self.contacts, self.dt)
        self.stops = JointStops.of(self.eq) if position_limits else None
        k = len(self.contacts)
        self.forces, self.active = np.zeros((k, 3)), np.zeros(k, dtype=bool)
        self.servo_torque = np.zeros(robot.dof)
        self.fast = CompiledGround.of(robot, self.eq, self.solver)   # None: NumPy's step

    def step(self, q, qd, tau, wrench=None, t=None, servo=None):
        """(q1, v1) one step on from (q, v) under the joint torques ``tau`` (dof,), the tip
        ``wrench`` (6,) or None and the joint ``servo`` (``sim.servo.Servo``) or None."""
        q1, v1, _ = self.advance(0.0 if t is None else t, np.asarray(q, dtype=float),
                                 np.asarray(qd, dtype=float), np.asarray(tau, dtype=float),
                                 wrench, servo)
        return q1, v1

    def advance(self, t, q, v, tau, w=None, servo=None, energy=False, check=True):
        """(q1, v1, (tau, delta, dW)): one step from (q, v) at time t under ``tau`` (the
        joints' torques, or generalized forces (nv,) whose first nb act on the base) and
        ``w`` (a tip wrench or None); tau the joints' torques, delta their dissipation and
        dW the works of the actuators, the dissipation and the environment over the step
        (with ``energy``, else None). ``check``: the new state's divergence check. The
        compiled step where it applies (joint torques, no wrench), else NumPy's."""
        dt, rhs, compiled = self.dt, self.rhs, self.fast
        step = (compiled.step(q, v, tau, servo)
                if compiled is not None and w is None and tau.shape[0] == rhs.n else None)
        if step is not None:
            q1, v1, self.forces, status = step
            out = compiled.out
            self.active = compiled.active(out)
            self.servo_torque = (compiled.servo_torque() if servo is not None
                                 else np.zeros(rhs.n))
            if check and status == DIVERGED:
                rhs.check(t + dt, q1, v1)                # raises, naming the joint
            delta, dW = None, None
            if energy:
                delta = self.eq.delta(v[rhs.nb:])
                dW = np.array([dt * out[POWER_TAU], dt * out[POWER_DELTA], out[WORK]])
        else:
            q1, v1, tau, delta, dW = self._numpy_step(t, q, v, tau, w, servo, energy)
            if check:
                rhs.check(t + dt, q1, v1)
        if self.stops:               # plastic impacts at the joints' stops
            q1, v1, dE = self.stops.impact(q1, v1, energy)
            dW = dW + np.array([0.0, dE, 0.0]) if energy else None
        return q1, v1, (tau, delta, dW)

    def _numpy_step(self, t, q, v, tau, w, servo, energy):
        """``advance``'s step in NumPy (stepping.GroundContacts): (q1, v1, tau, delta, dW)."""
        dt, rhs, chart, nb = self.dt, self.rhs, self.chart, self.rhs.nb
        a, tau, delta, p = rhs.rates(t, q, v, Held(tau, w))
        M = self.robot.mass_matrix(q)
        self.servo_torque = np.zeros(self.robot.dof)
        if servo is not None:        # the implicit servo on the joints' rows (module docstring)
            s, qj = on_joints(servo, nb), joints_view(q, nb, rhs.nqb)
            a = a + euler_servo(M, qj, v, a, s, dt)[1]
            M = M + np.diag(dt * s.kd + dt * dt * s.kp)
        v1, self.forces, self.active, work = self.solver.step(q, v, v + dt * a, M)
        if servo is not None:        # tau_s = Kp (q* - q1) + Kd (qd* - v1), at the step's end
            self.servo_torque = (s.kp * (s.q_target - qj - dt * v1)
                                 + s.kd * (s.qd_target - v1))[nb:]
        phi0 = chart.centre(q)
        q1 = chart.point(q, dt * chart.rate(q, phi0, v1) + phi0)
        dW = (np.array([dt * tau @ v1[nb:], dt * delta @ v1[nb:], dt * p[2] + work])
              if energy else None)
        return q1, v1, tau, delta, dW


class GroundSession(Session):
    """A ``Session`` (its arguments) whose steps touch ``ground`` with ``contacts``
    (``GroundStepper``, semi-implicit Euler). ``contact_forces()``: the forces of the step
    that reached the current state."""

    def __init__(self, robot, q0, *, ground, contacts, dt=1e-3, dissipation=True,
                 position_limits=False, **kwargs):
        def stepper_for(robot):      # the session's robot, or one swapped in (a payload)
            return GroundStepper(robot, ground, contacts, dt, dissipation,
                                 position_limits=position_limits)

        stepper = stepper_for(robot)
        self.forces, self.active = stepper.forces, stepper.active
        super().__init__(robot, q0, integrator=METHOD, dt=dt, dissipation=dissipation,
                         position_limits=position_limits, **kwargs)
        self.contacts = stepper.contacts
        self._integrator_for = stepper_for
        self.integrator = stepper

    def reset(self):
        super().reset()
        with self.lock:
            self.forces, self.active = np.zeros_like(self.forces), np.zeros_like(self.active)

    def _advance(self, integrator, hold):
        q, qd = super()._advance(integrator, hold)
        self.forces, self.active = integrator.forces, integrator.active
        return q, qd

    def report(self):
        """``Session.report`` and the contacts that pushed in the last step."""
        return [*super().report(), ("contacts touching",
                                    f"{int(np.count_nonzero(self.active))} of {len(self.active)}")]

    def contact_forces(self):
        """(k, forces (m, 3), active (m,)): the step count and the contacts' forces on the
        robot (world axes, N) over the step that reached it (zeros before the first)."""
        with self.lock:
            return self.k, self.forces, self.active


def run_with_ground(robot, duration, q0, v0, inputs, dt, dissipation, output_dt, check_energy,
                    bar, ground, contacts):
    """``simulate`` with contacts on a ground: ``GroundStepper.advance`` step by step, or,
    for torques known in advance (no state feedback, no wrench) where the compiled step
    applies, all steps in one compiled call (``CompiledGround.run``), the same steps; from
    a step it refuses on, step by step."""
    stepper = GroundStepper(robot, ground, contacts, dt, dissipation)
    eq, nb, fast, solver = stepper.eq, stepper.rhs.nb, stepper.fast, stepper.solver
    method = stepper.method
    nsteps = int(np.ceil(duration / dt - 1e-9))
    every = 1 if output_dt is None else max(1, int(round(output_dt / dt)))
    guard = EnergyGuard(eq, q0, v0, method, dt, check_energy)
    q, v, W = q0.copy(), v0.copy(), np.zeros(3)
    rows, F, A = [], [], []
    start = 0
    if fast is not None and not inputs.state and inputs.wrench is None and inputs.base is None:
        start, q, v, W = _compiled_run(stepper, nsteps, every, guard, inputs, q0, v0, rows,
                                       F, A)
        bar(min(start, nsteps) * dt)
    for k in range(start, nsteps + 1):
        t = k * dt
        tau_in, w = inputs(t, q, v)
        q1, v1, (tau, delta, dW) = stepper.advance(t, q, v, tau_in, w, energy=True,
                                                   check=k < nsteps)
        if k % every == 0 or k == nsteps:      # the last sample: the forces it would feel
            rows.append((t, q, v, (v1 - v) / dt, tau, delta, W.copy()))
            F.append(stepper.forces)
            A.append(stepper.active)
        if k == nsteps:
            break
        q, v, W = q1, v1, W + dW
        if (k + 1) % 50 == 0:
            guard((k + 1) * dt, q, v, W)
            bar((k + 1) * dt)
    guard(nsteps * dt, q, v, W)
    stats = SolverStats(method, steps=nsteps, nfev=nsteps,
                        message=f"fixed step dt = {dt:g} s; contacts: {solver.solves} solves, "
                        f"{solver.iterations} PGS sweeps"
                        + (f", {solver.unconverged} at the iteration limit"
                           if solver.unconverged else "")
                        + (" (compiled loop)" if start == nsteps + 1 else ""))
    t, Q, V, Acc, TAU, DELTA, Ws = (np.array(c) for c in zip(*rows))
    out = finish(eq, t, Q, V, Acc, TAU, DELTA, Ws, stats, robot.joint_names)
    out.contact_forces, out.contact_active = np.array(F), np.array(A)
    return out


def _compiled_run(stepper, nsteps, every, guard, inputs, q0, v0, rows, F, A):
    """The steps 0 .. nsteps of ``run_with_ground`` in one compiled call, recorded into
    ``rows``, ``F``, ``A`` as the step-by-step loop records them (its checks too, in its
    order). Returns (the first step not taken, nsteps + 1 when all were, and q, v, W at
    that step, or at the run's end)."""
    dt, eq, fast, nb = stepper.dt, stepper.eq, stepper.fast, stepper.rhs.nb
    TAU = np.array([inputs.torque(k * dt, None, None) for k in range(nsteps + 1)])
    TAU = TAU.reshape(nsteps + 1, eq.n)
    done, Q, V, Fs, OUT = fast.run(q0, v0, TAU)
    if done == 0:
        return 0, q0.copy(), v0.copy(), np.zeros(3)
    eq.calls, eq.states = eq.calls + done, eq.states + done
    dW = np.stack([dt * OUT[:done, POWER_TAU], dt * OUT[:done, POWER_DELTA],
                   OUT[:done, WORK]], axis=1)
    Ws = np.vstack([np.zeros(3), np.cumsum(dW, axis=0)])       # W before each step, and after
    for k in range(49, min(done, nsteps), 50):                  # the step loop's checks
        guard((k + 1) * dt, Q[k + 1], V[k + 1], Ws[k + 1])
    keep = [k for k in range(done) if k % every == 0 or k == nsteps]
    delta = eq.delta(V[:done, nb:])
    active = fast.active(OUT)
    for k in keep:
        rows.append((k * dt, Q[k], V[k], (V[k + 1] - V[k]) / dt, TAU[k], delta[k], Ws[k]))
        F.append(Fs[k])
        A.append(active[k])
    last = min(done, nsteps)                  # the run's end: nsteps (its last step's state
    return done, Q[last], V[last], Ws[last]   # served only the last sample's forces)
