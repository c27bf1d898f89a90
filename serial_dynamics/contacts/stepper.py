"""Contacts with a ground one step at a time, for the simulator node: ``GroundStepper``
(``FixedStepIntegrator``'s interface: ``step(q, v, tau, wrench, t, servo)``,
``servo_torque``) and ``GroundSession`` (a ``sim.session.Session`` stepped by it, holding
the contact forces of its last step). The step is ``stepping.py``'s (semi-implicit Euler,
velocity-level time stepping, projected Gauss-Seidel; docs/simulation.md).

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

from ..sim.group import GroupRates, Held, joints_view, on_joints
from ..sim.servo import euler_servo
from ..sim.session import Session
from ..sim.stops import JointStops
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

    def step(self, q, qd, tau, wrench=None, t=None, servo=None):
        """(q1, v1) one step on from (q, v) under the joint torques ``tau`` (dof,), the tip
        ``wrench`` (6,) or None and the joint ``servo`` (``sim.servo.Servo``) or None."""
        dt, rhs, chart, nb = self.dt, self.rhs, self.chart, self.rhs.nb
        q, v = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        t = 0.0 if t is None else t
        a, _, _, _ = rhs.rates(t, q, v, Held(np.asarray(tau, dtype=float), wrench))
        M = self.robot.mass_matrix(q)
        self.servo_torque = np.zeros(self.robot.dof)
        if servo is not None:        # the implicit servo on the joints' rows (module docstring)
            s, qj = on_joints(servo, nb), joints_view(q, nb, rhs.nqb)
            a = a + euler_servo(M, qj, v, a, s, dt)[1]
            M = M + np.diag(dt * s.kd + dt * dt * s.kp)
        v1, self.forces, self.active, _ = self.solver.step(q, v, v + dt * a, M)
        if servo is not None:        # tau_s = Kp (q* - q1) + Kd (qd* - v1), at the step's end
            self.servo_torque = (s.kp * (s.q_target - qj - dt * v1)
                                 + s.kd * (s.qd_target - v1))[nb:]
        phi0 = chart.centre(q)
        q1 = chart.point(q, dt * chart.rate(q, phi0, v1) + phi0)
        rhs.check(t + dt, q1, v1)
        if self.stops:               # plastic impacts at the joints' stops
            q1, v1, _ = self.stops.impact(q1, v1, False)
        return q1, v1


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
