"""The equations of motion of one robot with its dissipation, and the state checks.

State equations (x = [q, qd]):

    qd' = qdd = M(q)^-1 (tau + delta(qd) - b(q, qd) + J(q)^T w)

with tau the applied (actuator) torques, delta the dissipative joint torques
(``Dissipation``), b the bias torques and w a wrench on the tip. Every dynamics call goes
through the ``Robot`` facade (``forward_dynamics``, ``mass_matrix``, ``bias_torques`` ...),
so faster kernels behind it speed the simulator up unchanged.

Owns: ``Equations`` (accelerations and dissipative torques in the three friction modes:
exact sgn, smooth tanh for the adaptive solvers, stick-slip with sliding signs fixed over
a fixed step; their derivatives for the analytical Jacobians; the stick-slip active set;
the divergence check of a state), ``held`` (the
accelerations with some joints held still), ``Inputs`` (torque and wrench as functions
of (t, q, qd)), ``StepStart`` (the state at the start of a fixed step) and
``EnergyGuard`` (energy from nowhere means divergence).
"""
from __future__ import annotations

from itertools import repeat
from typing import NamedTuple

import numpy as np

from ..model.dissipation import Dissipation
from ..model.errors import SimulationError
from .methods import advice

REST_SPEED = 1e-9            # rad/s (m/s): a Coulomb joint slower than this is at rest
SPEED_BOUND_FACTOR = 1e3    # divergence: |qd| > 1000 x velocity limit (1e5 where none)
PRISMATIC_BOUND = 1e3        # m: no prismatic joint travels a kilometre


class External(NamedTuple):
    """What the environment does to the chain: the tip wrench (None, (6,) or (N, 6)) and the
    base's motion (a ``BaseMotion``, or a list of them, one per state of a batch)."""

    wrench: object
    base: object


def split(w):
    """(wrench, base motion) of an input ``w``: None, a wrench, or an ``External``."""
    return (w.wrench, w.base) if isinstance(w, External) else (w, None)


class Inputs(NamedTuple):
    """The applied torques ``torque(t, q, qd) -> (n,)``, the tip wrench
    ``wrench(t, q, qd) -> (6,)`` (None: no wrench) and the base motion ``base(t) ->
    BaseMotion`` (None: a base at rest). ``state``: the torque or the wrench may depend
    on (q, qd) (a callable given by the user); False for constants and samples."""

    torque: object
    wrench: object = None
    base: object = None
    state: bool = True

    def __call__(self, t, q, qd):
        """(tau, w) at one state; w is None without a wrench or base motion, the wrench
        without base motion, else an ``External``."""
        w = None if self.wrench is None else self.wrench(t, q, qd)
        return self.torque(t, q, qd), (w if self.base is None else External(w, self.base(t)))

    def batch(self, t, Q, V):
        """(tau, w) stacked over states (Q, V) (N, n) at the time ``t`` or times (N,)."""
        ts = repeat(t) if np.ndim(t) == 0 else t
        tau = np.array([self.torque(t, a, b) for t, a, b in zip(ts, Q, V)])
        w = (None if self.wrench is None else
             np.array([self.wrench(t, a, b) for t, a, b in zip(ts, Q, V)]))
        if self.base is None:
            return tau, w
        return tau, External(w, self.base(t) if np.ndim(t) == 0 else [self.base(x) for x in t])


class StepStart(NamedTuple):
    """The state at the start of a fixed step, with its inputs and friction modes:
    ``stuck`` joints held (None: none), ``sign`` the sliding direction of each Coulomb
    joint (None without Coulomb friction), ``qdd`` and ``delta`` (holding torques included)."""

    t: float
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    w: np.ndarray | None
    qdd: np.ndarray
    delta: np.ndarray
    stuck: np.ndarray | None
    sign: np.ndarray | None

    def stuck_at_rest(self):
        """This start with the speeds of the stuck joints set to zero."""
        return self if self.stuck is None else self._replace(qd=np.where(self.stuck, 0.0, self.qd))


class Equations:
    """The state equations of one robot with one dissipation model; counts dynamics calls."""

    def __init__(self, robot, dissipation, smoothing=1e-4):
        self.robot = robot
        self.n = robot.dof
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
        self.prismatic = np.array([t == "prismatic" for t in robot.joint_types], dtype=bool)
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

    # -- dynamics through the facade; ``w``: None, a wrench or an ``External``
    def fd(self, q, qd, tau, w=None):
        self.calls += 1
        self.states += 1 if np.ndim(q) == 1 else len(q)
        return _with_external(self.robot.forward_dynamics, (q, qd, tau), w)

    def fd_derivatives(self, q, qd, tau, w=None):
        """(dqdd/dq, dqdd/dqd, M^-1) of forward dynamics at fixed tau and w, one state
        (``Robot.forward_dynamics_derivatives``); counted as one call of one state."""
        self.calls += 1
        self.states += 1
        return _with_external(self.robot.forward_dynamics_derivatives, (q, qd, tau), w)

    def delta_derivative(self, qd, sign=None, smooth=False):
        """The diagonal of d delta/d qd (``Dissipation.torque_derivative``)."""
        if not self.diss_on:
            return np.zeros_like(qd)
        if not self.coulomb_on:
            return np.broadcast_to(-self.beta, np.shape(qd)).copy()
        return self.diss.torque_derivative(qd, smooth=smooth, v_eps=self.v_eps,
                                           **({} if smooth else {"sign": sign}))

    def bias(self, q, qd, w=None):
        """b(q, qd) - J^T w, with the base motion's torques; batches of states."""
        return _with_external(self.robot.bias_torques, (q, qd), w)

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
        r = tau + delta - self.bias(q, qd, w)
        return held(M, r, stuck, delta)

    def ext_power(self, q, qd, w):
        """The power of the environment on the chain, batches of states: (J^T w) . qd of the
        tip wrench, and -qd . (b(q, qd; base) - b(q, qd)) of the base's motion (its
        torques, moved to the right-hand side: M qdd + b = tau + delta + J^T w - beta gives
        dE/dt = qd . (tau + delta + J^T w - beta), E = T + V relative to the base)."""
        wrench, base = split(w)
        p = 0.0
        if wrench is not None:
            p = np.einsum("...i,...ij,...j->...", wrench, self.robot.jacobian(q), qd)
        if base is not None:
            beta = self.bias(q, qd, External(None, base)) - self.robot.bias_torques(q, qd)
            p = p - np.einsum("...i,...i->...", qd, beta)
        return p

    def power(self, q, qd, tau, delta, w):
        """[tau.qd, delta.qd, ext_power]: the power of the actuators, the dissipation and
        the environment (tip wrench, base motion) at one state."""
        return np.array([tau @ qd, delta @ qd,
                         0.0 if w is None else float(self.ext_power(q, qd, w))])

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
        b = self.bias(q, qd, w)
        stuck = rest.copy()
        for _ in range(int(rest.sum()) + 1):
            delta = self.delta(qd, sign)
            qdd, delta = held(M, tau + delta - b, stuck, delta)
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
            reason, value = ("nan_q", q[j]) if bad_q[j] else ("nan_qd", qd[j])
        elif np.any(np.abs(qd) > self.speed_bound):
            j = int(np.argmax(np.abs(qd) / self.speed_bound))
            reason, value = "speed", qd[j]
        else:
            j = int(np.argmax(self.prismatic * np.abs(q)))
            reason, value = "position", q[j]
        raise state_error(t, self.names[j], reason, value, self.speed_bound[j], method, dt)


def state_error(t, joint, reason, value, bound, method, dt):
    """The SimulationError of a state that left the physical bounds at time t: ``reason``
    "nan_q" or "nan_qd" (a position or speed not finite), "speed" (beyond ``bound``) or
    "position" (a prismatic joint beyond PRISMATIC_BOUND); ``value`` the joint's."""
    what = {"nan_q": f"its position is {value}", "nan_qd": f"its speed is {value}",
            "speed": (f"its speed {value:.4g} exceeds the bound {bound:.4g} "
                      f"({SPEED_BOUND_FACTOR:g} x its velocity limit, or 1e5 where none)"),
            "position": f"its position {value:.4g} m is beyond {PRISMATIC_BOUND:g} m"}[reason]
    return SimulationError(f"simulation diverged at t = {t:.6g} s: joint {joint!r}: {what}. "
                           f"{advice(method, dt)}", t, joint, "nan" if reason.startswith("nan") else reason)


def energy_error(t, excess, scale, joint, speed, method, dt):
    """The SimulationError of energy from nowhere: E - E0 - W grew by ``excess`` beyond half
    the energy ``scale`` (J); ``joint`` the fastest, at ``speed``."""
    return SimulationError(
        f"simulation diverged at t = {t:.6g} s: the energy grew by {excess:.4g} J more "
        f"than the work put in (energy scale {scale:.4g} J); the fastest joint is "
        f"{joint!r} at {speed:.4g}. {advice(method, dt)}", t, joint, "energy")


def _with_external(method, states, w):
    """``method(*states, wrench, base_motion=...)`` of a Robot for ``w`` None, a wrench or an
    ``External``; a batch of states at different times (a list of base motions, one per
    state): one call per state."""
    wrench, base = split(w)
    if not isinstance(base, list):
        return method(*states, wrench, base_motion=base)
    N = len(states[0])
    rows = [None] * N if wrench is None else np.broadcast_to(wrench, (N, 6))
    return np.array([method(*x, base_motion=bm) for *x, bm in zip(*states, rows, base)])


def held(M, r, stuck, delta):
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


def energy_scale_static(robot, mass=None, com=None):
    """An upper bound of the potential-energy swing, |g| sum m_i 2 r_i with r_i the
    largest distance of body i's center of mass from the base origin. ``mass`` (..., n) and
    ``com`` (..., n, 3) (link frames) in place of the model's: one bound per row."""
    m = robot.model
    mass = m.mass if mass is None else np.asarray(mass, float)
    com = m.com if com is None else np.asarray(com, float)
    reach = np.cumsum(np.linalg.norm(m.p_parent, axis=1)) + np.linalg.norm(com, axis=-1)
    travel = np.cumsum(np.where(m.kind == 1, np.minimum(np.abs(m.lower), PRISMATIC_BOUND)
                                + np.minimum(np.abs(m.upper), PRISMATIC_BOUND), 0.0))
    return np.linalg.norm(m.gravity) * np.sum(mass * 2 * (reach + travel), axis=-1)


class EnergyGuard:
    """Raises when E(t) - E(0) - W_act - W_ext exceeds half the energy scale: energy from
    nowhere (dissipation can only take energy out, so its work is left out of the test)."""

    def __init__(self, eq, q0, qd0, method, dt, enabled):
        self.eq, self.method, self.dt, self.enabled = eq, method, dt, enabled
        if enabled:
            r = eq.robot
            self.T0 = float(r.kinetic_energy(q0, qd0))
            self.E0 = self.T0 + float(r.potential_energy(q0))
            self.static = float(energy_scale_static(r))
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
            qd = qd[len(qd) - self.eq.n:]          # the joints' (a floating base: v's last n)
            j = int(np.argmax(np.abs(qd)))
            raise energy_error(t, excess, scale, self.eq.names[j], qd[j], self.method, self.dt)
