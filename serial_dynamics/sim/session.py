"""A running simulation, free of ROS: what the simulator node steps and edits.

Owns ``Session``: the state and the time (in steps), the fixed-step integrator, the
commands held (``command_hold.CommandHold``: efforts, the joint servo's targets, the push
on the tip, each with its timeout), what a lost command stream does
(``command_timeout_action``), the ``set_state``/``set_base_state`` edits applied at the next
step, reset, pause and single steps, divergence (the session pauses at the last good state
and says why; ``halt`` does the same for a step that failed in its caller), and a new
plant (a payload, a new model) swapped in between two steps.

Written in terms of ``robot.nq``, ``robot.nv``, ``robot.dof`` and ``robot.joint_names``:
the joints are the last ``dof`` coordinates of q and v (a floating base's pose and twist
come first), so a caller never indexes q or v nor asks the kind of robot: it reads
``joint_state()`` (every joint, mimic joints too, and a floating base's pose and twist) and
``report()``. Thread-safe: every change and every step holds ``lock``.
"""
from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np

from ..model.errors import SimulationError
from .command_hold import CommandHold
from .fixed_step import FixedStepIntegrator

TIMEOUT_ACTIONS = ("brake", "limp")


def has_base(robot) -> bool:
    """Whether q and v start with a floating base's pose (7) and twist (6)."""
    return robot.nq != robot.dof


class Reading(NamedTuple):
    """Every joint at one instant (``Session.joint_names`` order, mimic joints included)."""
    k: int                   # steps since the start
    position: np.ndarray     # rad; m
    velocity: np.ndarray
    effort: np.ndarray       # the actuator torque of the last step; 0 at a mimic joint
    base: tuple | None       # a floating base's (pose (7,), twist (6,)), else None


class Session:
    """One simulation of ``robot`` from the joint positions ``q0`` (dof,) at rest (a floating
    base from ``base_pose`` [x, y, z, qx, qy, qz, qw]).

    ``integrator``, ``dt``, ``dissipation``, ``position_limits``: the ``FixedStepIntegrator``;
    ``effort_limits`` (dof,): efforts are clamped to them (inf: none); ``servo_kp``,
    ``servo_kd`` (dof,): the joint servo's gains; ``command_timeout`` (s of simulated time,
    0: never) and ``command_timeout_action``: "limp" (effort back to zero, targets cleared)
    or "brake" (the servo holds the positions at the timeout, its torque within the effort
    limits, until a command comes; an integrator or base without the servo goes limp);
    ``wrench_timeout`` (s, 0: never)."""

    def __init__(self, robot, q0, *, base_pose=None, integrator="semi_implicit_euler",
                 dt=1e-3, dissipation=True, position_limits=False, effort_limits=None,
                 servo_kp=None, servo_kd=None, command_timeout=0.0,
                 command_timeout_action="brake", wrench_timeout=0.0, paused=False):
        if command_timeout_action not in TIMEOUT_ACTIONS:
            raise ValueError(f"command_timeout_action {command_timeout_action!r} unknown; use "
                             f"one of {', '.join(TIMEOUT_ACTIONS)}")
        n = robot.dof
        self.base_dims = (robot.nq - n, robot.nv - n)     # the base's coordinates before the joints
        base = np.zeros(self.base_dims[0]) if base_pose is None else np.asarray(base_pose, float)
        self.q0 = np.concatenate((base, np.asarray(q0, dtype=float)))
        self.has_base = has_base(robot)
        if self.q0.shape != (robot.nq,):
            raise ValueError(f"the initial state has {self.q0.size} coordinates; "
                             f"{robot.model.name} has {robot.nq}")
        self._integrator_for = lambda robot: FixedStepIntegrator(
            robot, integrator, dt, dissipation, position_limits=position_limits)
        self.robot, self.integrator = robot, self._integrator_for(robot)
        self.dt = self.integrator.dt
        self.servo_ok = integrator in self.integrator.SERVO_METHODS
        self.limit = np.full(n, np.inf) if effort_limits is None else np.asarray(effort_limits, float)
        kp = np.full(n, 1e4) if servo_kp is None else np.asarray(servo_kp, float)
        kd = np.full(n, 200.0) if servo_kd is None else np.asarray(servo_kd, float)
        self.timeout_action = command_timeout_action if self.servo_ok else "limp"
        self.hold = CommandHold(n, kp, kd, round(command_timeout / self.dt),
                                round(wrench_timeout / self.dt))
        self.lock = threading.Lock()
        self.paused, self.k, self.divergences = paused, 0, 0
        self.braking = False
        self.integrator.step(self.q0, np.zeros(robot.nv), np.zeros(n))   # compile the step too
        self.reset()

    # ------------------------------------------------------------------ edits
    def reset(self):
        """The initial state, at rest; no command, no pending edit."""
        with self.lock:
            self.q, self.qd = self.q0.copy(), np.zeros(self.robot.nv)
            self.hold.clear(self.k)
            self.pending = self.pending_base = None
            self.braking = False

    def command(self, idx, effort, position=None, velocity=None):
        """The command of the joints ``idx`` (model order): effort, clamped to the limits,
        and servo targets (None: none at the joints named; NaN entries: none there).
        Returns the first clamped joint's index and the effort asked there, or None."""
        idx = np.asarray(idx)
        effort = np.asarray(effort, dtype=float)
        clamped = np.clip(effort, -self.limit[idx], self.limit[idx])
        over = np.flatnonzero(clamped != effort)
        with self.lock:
            self.hold.command(self.k, idx, clamped, position, velocity)
            self.braking = False
        return None if over.size == 0 else (int(idx[over[0]]), float(effort[over[0]]))

    def push(self, wrench):
        """The wrench on the tip from the next step ((6,), or None: none)."""
        with self.lock:
            self.hold.push(self.k, wrench)

    def set_state(self, idx, positions, velocities):
        """Joints ``idx`` jump to ``positions`` (None: keep) and ``velocities`` at the next step."""
        with self.lock:
            self.pending = (np.asarray(idx), positions, velocities)

    def set_base_state(self, pose, twist):
        """A floating base jumps to ``pose`` (7,) and ``twist`` (6,) at the next step."""
        with self.lock:
            self.pending_base = (pose, twist)

    def pause(self, paused: bool):
        with self.lock:
            self.paused = bool(paused)

    def set_robot(self, robot):
        """A new plant (a payload, a new model of the same joints): its integrator is built
        here, outside the lock, then swapped in between two steps."""
        integrator = self._integrator_for(robot)
        with self.lock:
            self.robot, self.integrator = robot, integrator

    # ------------------------------------------------------------------ steps
    def step(self, force=False):
        """One step (``force``: also while paused). Returns (ok, notes): ok False when the
        step diverged (the session is then paused at the last good state); notes, lines to
        log as (level, text)."""
        notes = []
        with self.lock:
            if self.paused and not force:
                return True, notes
            integrator, hold = self.integrator, self.hold
            for event in hold.expire(self.k):
                notes.append(self._expired(event))
            self._apply_edits()
            try:
                q, qd = self._advance(integrator, hold)
            except (SimulationError, ValueError) as exc:
                notes.append(("error", self._halt(str(exc))))
                return False, notes
            self.q, self.qd, self.k = q, qd, self.k + 1
        return True, notes

    def halt(self, reason: str) -> str:
        """Pause at the last good state after a step that failed for ``reason`` (what the
        step was to change was not kept); returns the line to log, with the way back."""
        with self.lock:
            return self._halt(reason)

    def _halt(self, reason):
        self.paused = True
        self.divergences += 1
        return (f"{reason} -- paused at the last good state (t = {self.k * self.dt:.3f} s); "
                "call ~/reset, then ~/pause false")

    def _expired(self, event):
        if event == "wrench":
            return ("info", "external_wrench_timeout: the external wrench is dropped")
        seconds = self.hold.timeout_steps * self.dt
        if self.timeout_action == "brake":     # hold the joints where they are now
            n = self.robot.dof
            self.hold.command(self.k, np.arange(n), np.zeros(n), self.joint_positions(self.q),
                              np.zeros(n))
            self.hold.timed_out, self.braking = True, True
            return ("warning", f"no command for {seconds} s (command_timeout): braking, the "
                    "joint servo holds the positions (within the effort limits) until a "
                    "command comes")
        return ("warning", f"no command for {seconds} s (command_timeout): applied effort "
                "back to zero, servo targets cleared")

    def _apply_edits(self):
        nb, vb = self.base_dims
        if self.pending is not None:      # set_state, applied at this step
            (idx, q_set, qd_set), self.pending = self.pending, None
            self.q, self.qd = self.q.copy(), self.qd.copy()
            if q_set is not None:
                self.q[nb + idx] = q_set
            self.qd[vb + idx] = qd_set
        if self.pending_base is not None:   # set_base_state, applied at this step
            (pose, twist), self.pending_base = self.pending_base, None
            self.q, self.qd = self.q.copy(), self.qd.copy()
            self.q[:nb], self.qd[:vb] = pose, twist

    def _advance(self, integrator, hold):
        t = self.k * integrator.dt
        q, qd = integrator.step(self.q, self.qd, hold.tau, hold.wrench, t=t, servo=hold.servo)
        if hold.servo is not None:
            hold.tau_servo = integrator.servo_torque
            if self.braking and np.any(np.abs(hold.tau_servo) > self.limit):
                # the brake saturates: the step again with its torque clamped, no servo
                hold.tau_servo = np.clip(hold.tau_servo, -self.limit, self.limit)
                q, qd = integrator.step(self.q, self.qd, hold.tau + hold.tau_servo,
                                        hold.wrench, t=t)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise SimulationError("the state is no longer finite")
        return q, qd

    # ------------------------------------------------------------------ reading
    def joint_positions(self, q):
        return q[self.base_dims[0]:]

    def snapshot(self):
        """(k, joint positions, joint velocities, applied joint torques, base pose or None,
        base twist or None) at the same instant."""
        with self.lock:
            q, qd, tau, k = self.q, self.qd, self.hold.tau + self.hold.tau_servo, self.k
        nb, vb = self.base_dims
        return (k, q[nb:], qd[vb:], tau, q[:nb] if nb else None, qd[:vb] if vb else None)

    joint_names = property(lambda self: self.robot.all_joint_names,
                           doc="every joint, base to tip, mimic joints included")

    def joint_state(self) -> Reading:
        """``snapshot()`` for every joint (mimic joints follow their leaders, no actuator)."""
        k, q, qd, tau, pose, twist = self.snapshot()
        robot = self.robot
        effort = np.zeros(len(robot.all_joint_names))
        effort[robot.model.independent] = tau
        return Reading(k, robot.all_joint_positions(q), robot.all_joint_velocities(qd), effort,
                       None if pose is None else (pose, twist))

    def report(self):
        """/diagnostics entries (name, value): divergence events (steps that diverged or
        failed: the pauses at the last good state), the push in force, the joints the servo
        acts on."""
        wrench, servo = self.hold.wrench, self.hold.servo
        return [("divergence events", self.divergences),
                ("external wrench", "none" if wrench is None else
                 " ".join(f"{x:.4g}" for x in wrench)),
                ("servoed joints", 0 if servo is None else
                 int(np.count_nonzero((servo.kp > 0) | (servo.kd > 0))))]

    @property
    def time(self):
        """Simulated seconds since the start."""
        return self.k * self.dt
