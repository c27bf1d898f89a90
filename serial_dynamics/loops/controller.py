"""The computed-torque controller node's loop, without ROS (``ros/computed_torque_controller.py``
converts its parameters and messages and makes one call here per callback).

``Controller`` holds the latest joint state, the reference in force (a ``Waypoints`` from
its start time), the control law (``control.MODES``, switchable while running) and what
the node reports. The laws and the stability bound are ``control.py``'s.

- The error e = q_d - q is taken at the stamp of the state it uses (a state is a few ms
  old when it arrives; comparing it with the reference of the same instant removes the
  lag bias), the feed-forward qdd_d at the time the torque is computed; continuous joints
  take the shortest way round.
- A state stamp of 0, or more than ``MAX_STATE_AGE`` from the clock, is taken as "now"
  (a clock mismatch).
- Before any trajectory the reference holds the first state's positions; in
  gravity_compensation it follows the measured positions (trajectories are refused), so
  leaving that mode holds where the arm was left.
- A trajectory starts at its start time from the current reference (a first point is
  added at t = 0 when its first point is later), and its last point holds at the end.

Times are seconds of the caller's clock (the node's: simulated time with use_sim_time).
Refusals raise ``Rejected`` (``cause``: what repeats are grouped by); what was in force
stays. Notes to log once (a gain beyond the bound) come back as ``(key, text)`` pairs.
"""
from __future__ import annotations

import numpy as np

from .. import control
from ..model.errors import Rejected
from ..trajectory import Waypoints

MAX_STATE_AGE = 0.5   # s; an older (or future) state stamp is taken as "now" (clock mismatch)


def check_mode(mode):
    """None if ``mode`` is a law of the controller (``control.MODES``), else the reason."""
    if mode not in control.MODES:
        return f"parameter 'mode' must be one of {', '.join(control.MODES)}; got {mode!r}"
    return None


class Controller:
    """The controller of ``robot`` (settable: a payload swapped in between two torques) at
    the control period ``period`` (s): computed-torque gains ``kp`` (1/s^2) and ``kd`` (1/s)
    per joint; pd_gravity's ``pd_kp``, ``pd_kd`` (N m/rad, N m s/rad; None: from kp, kd and
    the effective inertia at the state used, ``control.pd_gains``); ``compensate``: subtract
    the joint dissipation at the measured velocity; ``mode``: the law in force."""

    def __init__(self, robot, period, kp, kd, pd_kp=None, pd_kd=None, compensate=False,
                 mode="computed_torque"):
        if check_mode(mode):
            raise ValueError(check_mode(mode))
        if not 0 < period < np.inf:
            raise ValueError(f"the control period must be > 0 and finite, got {period}")
        self.robot, self.period, self.mode, self.compensate = robot, period, mode, compensate
        self.kp, self.kd = np.asarray(kp, float), np.asarray(kd, float)
        self.pd_kp = None if pd_kp is None else np.asarray(pd_kp, float)
        self.pd_kd = None if pd_kd is None else np.asarray(pd_kd, float)
        self.wrap = np.array([k == "continuous" for k in robot.joint_types])
        self.state = None            # (t, q, qd) of the latest state
        self.reference = None        # (t0, Waypoints) in force
        self.error_max, self.saturated = None, set()      # since the last report
        # joints beyond the stability bound: computed_torque's (its loop has unit inertia),
        # pd_gravity's at the latest state (check_bound)
        self.beyond_ct = set(control.beyond(self.kp, self.kd, np.ones(robot.dof),
                                            period).tolist())
        self.beyond_pd = set()

    # ------------------------------------------------------------------ inputs
    def set_state(self, stamp, now, q, qd):
        """The latest joint state (model order), stamped ``stamp`` (0: none) at clock time
        ``now``. Returns the notes to log (the first state checks pd_gravity's bound)."""
        t = now if stamp == 0.0 or abs(now - stamp) > MAX_STATE_AGE else stamp
        first, self.state = self.state is None, (t, np.asarray(q, float), np.asarray(qd, float))
        notes = self.check_bound() if first else []
        if self.reference is None or self.mode == "gravity_compensation":
            self.hold()
        return notes

    def hold(self):
        """The reference: at rest where the latest state is."""
        t, q, _ = self.state
        self.reference = (t, Waypoints([0.0], q[None]))

    def set_trajectory(self, start, t, q, qd=None, qdd=None):
        """A new reference from clock time ``start``: points at times ``t`` (N,) after it,
        positions ``q`` (N, n), velocities and accelerations (N, n) or None."""
        if qdd is not None and qd is None:
            raise Rejected("accelerations without velocities", "desired_trajectory gives "
                           "accelerations but no velocities")
        if self.reference is None:
            raise Rejected("no joint state yet", "desired_trajectory arrived before any "
                           "joint_states message")
        if self.mode == "gravity_compensation":
            raise Rejected("gravity_compensation", "desired_trajectory arrived in mode "
                           "gravity_compensation, which follows no reference; set mode "
                           "to computed_torque or pd_gravity first")
        t, q = np.asarray(t, float), np.asarray(q, float)
        if t[0] > 0:                                 # start from the current reference
            q0, qd0, qdd0 = self.desired(start)
            t, q = np.r_[0.0, t], np.vstack([q0, q])
            qd = None if qd is None else np.vstack([qd0, qd])
            qdd = None if qdd is None else np.vstack([qdd0, qdd])
        try:
            waypoints = Waypoints(t, q, qd, qdd)
        except ValueError as exc:                    # e.g. times too close to tell apart
            raise Rejected("waypoints", str(exc)) from None
        self.reference = (start, waypoints)

    def set_mode(self, mode):
        """Switch the law (checked with ``check_mode`` first); True if it changed."""
        if check_mode(mode):
            raise ValueError(check_mode(mode))
        if mode == self.mode:
            return False
        self.mode = mode
        if mode == "gravity_compensation" and self.state is not None:
            self.hold()             # and from now on at every state
        return True

    # ------------------------------------------------------------------ the law
    def desired(self, t):
        t0, traj = self.reference
        return traj.sample(t - t0)

    def torque(self, now):
        """The command at clock time ``now`` from the latest state, or None before any state.
        Rejected (cause "not finite") if it comes out non-finite: no command then."""
        if self.state is None:
            return None
        ts, q, qd = self.state
        q_ref, qd_ref, _ = self.desired(ts)            # reference at the state's instant
        qdd_ff = self.desired(now)[2]                  # feed-forward for the torque applied now
        e = q_ref - q
        e[self.wrap] = np.angle(np.exp(1j * e[self.wrap]))     # shortest way round
        ed, robot, mode = qd_ref - qd, self.robot, self.mode
        try:
            with np.errstate(over="ignore", invalid="ignore"):    # checked below
                kp, kd = self.pd_gains(robot, q) if mode == "pd_gravity" else (self.kp, self.kd)
                tau = control.torque(robot, mode, q, qd, e, ed, qdd_ff, kp, kd, self.compensate)
            if not np.all(np.isfinite(tau)):
                raise ValueError("the torque came out non-finite")
        except (ValueError, ArithmeticError) as exc:   # e.g. gains times error overflow
            raise Rejected("not finite", f"{exc} (mode {mode}, q = {q}, q_ref = {q_ref}, "
                           f"qd = {qd})") from None
        self.error_max = max(self.error_max or 0.0, float(np.max(np.abs(e))))
        self.saturated.update(np.flatnonzero(np.abs(tau) > robot.effort_limit).tolist())
        return tau

    def pd_gains(self, robot, q):
        """pd_gravity's gains at q: pd_kp, pd_kd as given, or kp, kd scaled by the effective
        inertias at q and the joints' coupling (control.pd_gains): every mode of the arm held
        at q is then no faster than e'' + kd e' + kp e = 0, within the bound whenever kp, kd
        are."""
        if self.pd_kp is not None and self.pd_kd is not None:
            return self.pd_kp, self.pd_kd
        kp, kd = control.pd_gains(robot, q, self.kp, self.kd)
        return (kp if self.pd_kp is None else self.pd_kp,
                kd if self.pd_kd is None else self.pd_kd)

    # ------------------------------------------------------------------ what is reported
    def bound_notes(self, joints, kp, kd, m, what):
        return [(("bound", what, j), control.explain(self.robot.joint_names[j], kp[j], kd[j],
                                                      m[j], self.period, what))
                for j in sorted(joints)]

    def startup_notes(self):
        """computed_torque's gains beyond the bound (the loop it makes has unit inertia)."""
        n = self.robot.dof
        return self.bound_notes(self.beyond_ct, self.kp, self.kd, np.ones(n),
                                "kp, kd (computed_torque)")

    def check_bound(self):
        """pd_gravity's gains against the explicit-PD stability bound at the control rate
        with the effective inertia at the latest state: the notes of the joints beyond it."""
        if self.state is None:
            return []
        robot, q = self.robot, self.state[1]
        m = control.effective_inertia(robot, q)
        kp, kd = self.pd_gains(robot, q)
        self.beyond_pd = set(control.beyond(kp, kd, m, self.period).tolist())
        return self.bound_notes(self.beyond_pd, kp, kd, m, "pd.kp, pd.kd (pd_gravity)")

    def report(self):
        """(values, notes): the mode, the joints beyond the bound, max |e| and the joints
        beyond their effort limit since the last report (``(key, value[, warn])`` as
        /diagnostics takes them); the notes of check_bound."""
        err = self.error_max
        names = [self.robot.joint_names[j] for j in sorted(self.saturated)]
        self.error_max, self.saturated = None, set()
        notes = self.check_bound()
        beyond = [self.robot.joint_names[j] for j in sorted(self.beyond_ct | self.beyond_pd)]
        return [("mode", self.mode),
                ("gains beyond the stability bound", ", ".join(beyond) or "none", bool(beyond)),
                ("tracking error max (rad)", "no command" if err is None else f"{err:.6g}"),
                ("saturated joints", ", ".join(names) or "none", bool(names))], notes
