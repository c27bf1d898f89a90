"""Fixed-step integration: ``FixedStepIntegrator`` (one step at a time, for real-time use
by the simulator node) and the fixed-step run loops of ``simulate``.

Owns the frame of a step (friction modes and stops at the start, the method's step from
``STEPPERS``, a sliding joint stopping where its speed crosses zero, the state check and
the impacts at the end) and ``run_fixed`` (step by step); ``compiled_run.run_compiled`` is
semi-implicit Euler in one compiled loop.
"""
from __future__ import annotations

import numpy as np

from .equations import EnergyGuard, Equations, Inputs, StepStart
from .explicit import euler_update, rk4, semi_implicit_euler
from .group import GroupStepIntegrator
from .implicit import implicit_midpoint
from .jacobians import analytical
from .methods import FIXED_STEP, on_a_group
from .result import SolverStats, finish
from .stops import JointStops
from .servo import euler_servo
from .symplectic import lean_step, symplectic_euler

# method -> stepper(integ, s: StepStart, inputs: Inputs, energy) -> (q1, qd1, dW)
STEPPERS = {"semi_implicit_euler": semi_implicit_euler, "symplectic_euler": symplectic_euler,
            "rk4": rk4, "implicit_midpoint": implicit_midpoint}
assert tuple(STEPPERS) == FIXED_STEP
SERVO_METHODS = ("semi_implicit_euler", "symplectic_euler")   # methods with the implicit servo


class FixedStepIntegrator:
    """One fixed step at a time, for real-time use (the simulator node).

    ``step(q, qd, tau, wrench=None) -> (q, qd)`` advances (n,) states by ``dt`` seconds
    with the robot's dissipation added when ``dissipation`` is true (or a ``Dissipation``).
    Where q lives on a group (nq > nv: a floating base's quaternion) the constructor gives
    ``group.GroupStepIntegrator``, with this interface, stepping in the robot's chart.

    Methods: "semi_implicit_euler" (velocity first, then position with the new velocity;
    one dynamics call a step; symplectic only for a constant mass matrix: its energy error
    drifts on an arm), "symplectic_euler" (symplectic Euler in momentum form, p = M(q) qd,
    see ``symplectic``: symplectic for any chain, bounded energy error over long runs;
    one compiled call a step), "rk4" (classical Runge-Kutta, 4 calls),
    "implicit_midpoint" (x1 = x0 + dt f((x0 + x1)/2) in (q, qd): symmetric and A-stable,
    symplectic only for a constant mass matrix; simplified Newton with the analytical
    Jacobian, or one by differences over 2n+1 perturbed states; typically 2 calls a step).
    Coulomb friction: stick-slip, see ``Equations.modes``; a sliding
    joint whose speed crosses zero within a step stops there (no chattering).
    ``position_limits``: hard stops at the joints' finite URDF limits, see ``JointStops``.
    ``jacobian``: "analytical" (default) or "finite_differences", the Jacobian of the
    implicit midpoint rule's Newton iteration (``jacobians.py``).

    Work counters: ``stages`` (right-hand-side evaluations, a Jacobian batch counts 1),
    ``jacobians``, ``newton_iterations`` (symplectic_euler: its fixed-point iterations),
    ``newton_stalls`` (steps accepted with a
    correction between newton_tol and ``implicit.NEWTON_ACCEPT``), ``impacts``.
    """

    METHODS = FIXED_STEP
    SERVO_METHODS = SERVO_METHODS

    def __new__(cls, robot, *args, **kwargs):
        if on_a_group(robot):         # q on a group: the steps in the robot's chart (group.py)
            return GroupStepIntegrator(robot, *args, **kwargs)
        return super().__new__(cls)

    def __init__(self, robot, method="semi_implicit_euler", dt=1e-3, dissipation=True, *,
                 position_limits=False, newton_tol=1e-10, max_newton=10,
                 jacobian="analytical"):
        if method not in self.METHODS:
            raise ValueError(f"fixed-step method {method!r} unknown; use one of {self.METHODS}")
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.robot, self.method, self.dt, self.dissipation = robot, method, float(dt), dissipation
        self.stepper = STEPPERS[method]
        self.eq = Equations(robot, dissipation)
        self.newton_tol, self.max_newton = float(newton_tol), int(max_newton)
        self.newton_iterations = 0
        self.newton_stalls = 0
        self.jac_cache = None    # implicit methods: the Jacobian of the last steps
        self.jacobians = 0
        self.stages = 0
        self._lean = method in ("semi_implicit_euler", "symplectic_euler") and \
            not self.eq.coulomb_on
        self.t_now = 0.0                          # symplectic_euler: the time, for messages
        n = robot.dof
        self.sym_beta = np.ascontiguousarray(self.eq.beta if self.eq.diss_on else np.zeros(n),
                                             dtype=float)
        self.sym_held = np.zeros(n)
        self.stops = JointStops.of(self.eq) if position_limits else None
        self.servo_torque = np.zeros(n)           # the servo torque of the last step
        self.analytical = analytical(jacobian) and method == "implicit_midpoint"

    impacts = property(lambda self: 0 if self.stops is None else self.stops.impacts,
                       doc="steps in which a joint reached a stop")

    def step(self, q, qd, tau, wrench=None, t=None, servo=None):
        """Advance (q, qd) by dt under constant torques ``tau`` (n,) and ``wrench`` (6,) or
        None. Raises SimulationError on divergence (``t``, if given, names the time).
        ``servo``: a joint PD (``servo.servo(kp, kd, q_target, qd_target)``) integrated
        implicitly (semi_implicit_euler, symplectic_euler); the torque it applied over the
        step is left in ``servo_torque`` (zeros without one)."""
        eq, dt = self.eq, self.dt
        self.servo_torque = np.zeros(eq.n)
        if servo is not None and self.method not in SERVO_METHODS:
            raise ValueError(f"a servo is integrated implicitly by {SERVO_METHODS} only, not "
                             f"{self.method!r}; use one of those methods")
        if self._lean and not (self.stops and self.stops.touching(q)):
            # the real-time path: one forward-dynamics call (or one symplectic step call)
            q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
            tau = np.asarray(tau, dtype=float)
            if self.method == "symplectic_euler":
                q_new, qd_new = lean_step(self, np.ascontiguousarray(q), np.ascontiguousarray(qd),
                                          np.ascontiguousarray(tau), wrench, t, servo)
            else:
                if eq.viscous_on:
                    tau = tau - eq.beta * qd
                self.stages += 1
                qdd = eq.fd(q, qd, tau, wrench)
                if servo is not None:   # + the implicit servo: one mass matrix, one solve
                    self.servo_torque, y = euler_servo(self.robot.mass_matrix(q), q, qd, qdd,
                                                       servo, dt)
                    qdd = qdd + y
                q_new, qd_new = euler_update(q, qd, qdd, dt)
            eq.check_state(dt if t is None else t + dt, q_new, qd_new, self.method, dt)
            if self.stops:
                q_new, qd_new, _ = self.stops.impact(q_new, qd_new, False)
            return q_new, qd_new
        tau = np.asarray(tau, dtype=float)
        w = None if wrench is None else np.asarray(wrench, dtype=float)
        if servo is not None:   # stick-slip or a stop: the implicit Euler servo torque, held
            q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
            qdd = eq.accel(q, qd, tau, w)[0]
            self.servo_torque = euler_servo(self.robot.mass_matrix(q), q, qd, qdd, servo, dt)[0]
            tau = tau + self.servo_torque
        inputs = Inputs(lambda t, q, qd: tau, None if w is None else (lambda t, q, qd: w),
                        None, False)
        q_new, qd_new, _ = self.advance(0.0 if t is None else t, q, qd, inputs)
        return q_new, qd_new

    def start(self, t, q, qd, inputs):
        """The ``StepStart`` at (t, q, qd): inputs, friction modes, joints held on stops;
        the speeds of held joints set to zero."""
        tau, w = inputs(t, q, qd)
        if self.eq.coulomb_on:
            stuck, sign, qdd, delta = self.eq.modes(q, qd, tau, w)
        else:
            stuck, sign = None, None
            qdd, delta = self.eq.accel(q, qd, tau, w)
        s = StepStart(t, q, qd, tau, w, qdd, delta, stuck, sign).stuck_at_rest()
        return self.stops.hold(s).stuck_at_rest() if self.stops else s

    def advance(self, t, q, qd, inputs, energy=False):
        """One step from t under ``inputs`` (an ``Inputs``). Returns (q1, qd1, rec) with
        rec = (tau0, delta0, qdd0, dW): the torques and the acceleration at the start, and
        dW the increments of [W_act, W_diss, W_ext] over the step (only when ``energy``)."""
        eq, dt = self.eq, self.dt
        s = self.start(t, np.asarray(q, dtype=float), np.asarray(qd, dtype=float), inputs)
        self.stages += 1
        q1, qd1, dW = self.stepper(self, s, inputs, energy)
        if eq.coulomb_on:   # a sliding joint whose speed crossed zero stops (and may stick)
            moving = eq.coulomb & (s.sign != 0)
            qd1 = np.where(moving & (qd1 * s.sign <= 0.0), 0.0, qd1)
        if s.stuck is not None:
            qd1 = np.where(s.stuck, 0.0, qd1)
            q1 = np.where(s.stuck, s.q, q1)
        eq.check_state(t + dt, q1, qd1, self.method, dt)
        if self.stops:
            q1, qd1, dE = self.stops.impact(q1, qd1, energy)
            dW[1] += dE
        return q1, qd1, (s.tau, s.delta, s.qdd, dW)


def run_fixed(robot, duration, q0, qd0, inputs, method, dt, dissipation, output_dt,
              check_energy, bar, position_limits=False, jacobian="analytical"):
    """``simulate`` with a fixed-step method, step by step."""
    integ = FixedStepIntegrator(robot, method, dt, dissipation, position_limits=position_limits,
                                jacobian=jacobian)
    eq = integ.eq
    nsteps = int(np.ceil(duration / dt - 1e-9))
    every = 1 if output_dt is None else max(1, int(round(output_dt / dt)))
    guard = EnergyGuard(eq, q0, qd0, method, dt, check_energy)
    check_every = max(1, min(200, nsteps // 50))
    q, qd, W = q0.copy(), qd0.copy(), np.zeros(3)
    ts, Q, QD, QDD, TAU, DELTA, WS = [], [], [], [], [], [], []
    for k in range(nsteps):
        t = k * dt
        q1, qd1, (tau0, delta0, qdd0, dW) = integ.advance(t, q, qd, inputs, True)
        if k % every == 0:
            ts.append(t); Q.append(q); QD.append(qd); TAU.append(tau0)   # noqa: E702
            DELTA.append(delta0); WS.append(W.copy()); QDD.append(qdd0)  # noqa: E702
        q, qd, W = q1, qd1, W + dW
        if (k + 1) % check_every == 0:
            guard((k + 1) * dt, q, qd, W)
            bar((k + 1) * dt)
    # the final state, with the torques at the final time
    t = nsteps * dt
    tau, w = inputs(t, q, qd)
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
    return finish(eq, ts, Q, QD, QDD, TAU, DELTA, WS, stats, robot.joint_names)
