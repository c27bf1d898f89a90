"""The simulator node's loop, without a node (``ros/simulator.py`` converts its parameters
and messages and makes one call here per callback).

``SimulatorLoop`` holds the ``sim.session.Session`` (made by ``simulator_parameters``) and
what the node does around it: the commands (an effort clamped is a note; servo targets
the simulation cannot take are refused), the simulation thread paced against the
wall clock (``pacing.Pacer``) and, with ``lockstep``, held back to its controller (it runs
at most ``lockstep`` steps past its latest joint state before the command that answers it
arrives -- a command stamped with that state's stamp -- or, for unstamped commands, past
the last command; it waits at most ``lockstep_timeout`` s of wall time), which steps are
due on ``joint_states`` and ``/clock``, the steps of one ``~/step`` call, the answers of
``~/reset`` and ``~/step``, a step that fails (``guarded``: the session pauses at the last
good state, the thread goes on), the /diagnostics entries and the closing line. The
node's callbacks are passed in (``step``, ``publish``, ``warn``, ``error``), so the loop is
tested with plain functions; no rclpy here.
"""
from __future__ import annotations

import threading
import time
from typing import NamedTuple

import numpy as np

from ..contacts.stepper import GroundSession
from ..model.errors import Rejected
from ..sim.session import Session
from .pacing import Pacer

MAX_LAG = 0.1   # s of wall time behind schedule before the pacing re-anchors
WAIT_AT_MOST = 0.05   # s; the longest the thread sleeps before it looks at the schedule again


def contact_names(contacts) -> list:
    """The topic name of each contact (``~/contacts/<name>``): its link, or link_<i> (i
    counting that link's contacts from 0, in their order) where a link has several;
    characters a ROS name cannot hold become '_'."""
    links = [c.link for c in contacts]
    count, out = {}, []
    for link in links:
        i = count[link] = count.get(link, -1) + 1
        name = link if links.count(link) == 1 else f"{link}_{i}"
        name = "".join(ch if (ch.isascii() and ch.isalnum()) or ch == "_" else "_"
                       for ch in name)
        out.append("_" + name if name[0].isdigit() else name)
    return out


def dt_ns(p: dict) -> int:
    """sim_dt in whole ns (the step the session takes; /clock counts steps of it)."""
    return round(p["sim_dt"] * 1e9)


class Tick(NamedTuple):
    """What one step asks of the node."""
    ok: bool                 # False: the step diverged (the session is paused)
    notes: list              # (level, text) lines to log
    clock_ns: int | None     # the /clock stamp (ns of simulated time) when one is due
    publish: bool            # joint_states (and odom) due


class SimulatorLoop:
    """``session`` run at the rates of the parameter values ``p``
    (``simulator_parameters.PARAMETERS``); ``clock``: wall-clock seconds."""

    def __init__(self, session: Session, p: dict, clock=time.monotonic):
        self.session, self.dt_ns, self.clock = session, dt_ns(p), clock
        dt = session.dt
        self.step_count, self.rtf = p["step_count"], p["real_time_factor"]
        self.publish_every = max(1, round(1.0 / (p["publish_rate"] * dt)))
        self.clock_every = max(1, round(1.0 / (p["clock_rate"] * dt)))
        self.publish_clock = p["publish_clock"]
        self.pacer = Pacer(dt, self.rtf, MAX_LAG, clock)
        # lockstep: session.k at the last command (None: no command since the start or
        # since a wait timed out: free-running), the step of the state the last stamped
        # command answers (None: unstamped commands), the step of the latest joint_states,
        # the event a command sets, the waits so far
        self.lockstep, self.lockstep_timeout = p["lockstep"], p["lockstep_timeout"]
        self.commanded_k = self.answered_k = self.published_k = None
        self.commanded, self.lockstep_waits = threading.Event(), 0
        self.started = (clock(), session.k)    # (wall, k) at the start of the thread
        base_link = session.robot.base_link
        # odom's (frame_id, child_frame_id); external_wrench's (frame, axes)
        self.frames = (p["odom_frame"], base_link)
        self.wrench_frame = ((p["odom_frame"], "world") if session.has_base
                             else (base_link, "base"))
        # the contacts' topic names and their forces' frame_id (the world's axes)
        grounded = isinstance(session, GroundSession)
        self.contact_names = contact_names(session.contacts) if grounded else []
        self.contact_frame = self.wrench_frame[0]

    # ------------------------------------------------------------ commands and services
    def command(self, idx, effort, position=None, velocity=None, stamp_ns=0):
        """The command of the joints ``idx`` (None: every joint, model order); effort None:
        zeros; ``stamp_ns``: the stamp of the joint state it answers (0: none; read with
        publish_clock only, where stamps are simulated time). Returns the note of the first
        effort clamped to its limit, or None. Rejected: servo targets where the simulation
        has no servo."""
        session = self.session
        if not session.servo_ok and (position is not None or velocity is not None):
            raise Rejected("joint_commands servo", "joint_commands position/velocity targets "
                           "need an integrator with the implicit servo "
                           f"{session.integrator.SERVO_METHODS}; this simulator runs another "
                           "(parameter integrator); send effort only")
        idx = np.arange(session.robot.dof) if idx is None else idx
        effort = np.zeros(len(idx)) if effort is None else effort
        clamped = session.command(idx, effort, position, velocity)
        if stamp_ns and self.publish_clock:
            self.answered_k = stamp_ns // self.dt_ns
        self.commanded_k = session.k
        self.commanded.set()
        if clamped is None:
            return None
        j, asked = clamped
        return (f"effort command for {session.robot.joint_names[j]}: {asked:.4g}, beyond "
                f"its limit {session.limit[j]:.4g}; clamped to the limit (logged once)")

    def reset(self):
        """~/reset: the initial state, at rest; its answer."""
        self.session.reset()
        return ("state reset to initial_base_pose and initial_positions, at rest"
                if self.session.has_base else "state reset to initial_positions, at rest")

    def single_steps(self, step, publish, error):
        """~/step: while paused, ``step_count`` calls of ``step(force=True)`` (False: the
        step diverged, stop; an exception: as in ``run``, ``error`` says why), then
        ``publish()``. Returns (success, message)."""
        session = self.session
        if not session.paused:
            return False, "not paused: ~/step advances a paused simulation (~/pause true first)"
        k0 = session.k
        for _ in range(self.step_count):
            if not self.guarded(lambda: step(force=True), error):
                break
        publish()
        done = session.k - k0
        success = done == self.step_count
        return success, (f"advanced {done} step(s) to t = {session.time:.6f} s"
                         + ("" if success else "; stopped: the step diverged (see the log)"))

    # ------------------------------------------------------------ the simulation thread
    def run(self, stop, step, publish, warn, error=None):
        """Until the event ``stop`` is set: ``step()`` when a step is due on the wall-clock
        schedule and, with lockstep, the controller is no more than ``lockstep`` steps
        behind; while paused, ``publish()`` every publish period; ``warn(text)`` once when
        the schedule is given up (more than MAX_LAG late) and once when a lockstep wait
        times out. A step that raises pauses the session (``guarded``; ``error``, default
        ``warn``, says why) and the thread goes on: ~/reset and ~/pause false resume it."""
        error = error or warn
        session, pacer, lag_warned, lockstep_warned = self.session, self.pacer, False, False
        self.started = (self.clock(), session.k)
        pacer.anchor(session.k)
        waiting_since = None     # wall s when the current lockstep wait began
        while not stop.is_set():
            if session.paused:
                publish()
                stop.wait(self.publish_every * session.dt)
                pacer.anchor(session.k)
                waiting_since = None     # a pause is no wait for the controller
                continue
            if self.behind_controller():
                now = self.clock()
                if waiting_since is None:
                    waiting_since, self.lockstep_waits = now, self.lockstep_waits + 1
                if now - waiting_since < self.lockstep_timeout:
                    self.commanded.clear()
                    if self.behind_controller():     # a command between the look and clear
                        self.commanded.wait(min(self.lockstep_timeout - (now - waiting_since),
                                                WAIT_AT_MOST))
                    continue
                if not lockstep_warned:
                    lockstep_warned = True
                    warn(f"no command for {self.lockstep_timeout:g} s of wall time: lockstep "
                         "released until the next command (logged once; command_timeout "
                         "applies)")
                self.commanded_k = self.answered_k = None
            if waiting_since is not None:     # the wait is over: the schedule starts anew,
                waiting_since = None          # as after a pause (no burst to catch up)
                pacer.anchor(session.k)
            wait = pacer.wait(session.k)
            if wait > 0:
                stop.wait(min(wait, WAIT_AT_MOST))
                continue
            if pacer.reanchors and not lag_warned:
                lag_warned = True
                warn(f"cannot keep up with real_time_factor {self.rtf}: the simulation runs "
                     "slower (logged once)")
            self.guarded(step, error)

    def guarded(self, step, error) -> bool:
        """``step()``'s answer (False: it diverged, and the session paused itself). An
        exception from anything in it (a bug, a log call, a torque callable) pauses the
        session at the last good state, ``error(line)`` gets the reason, and the answer is
        False: nothing in one step ends the simulation thread or the node."""
        try:
            return step() is not False
        except Exception as exc:  # noqa: BLE001 -- one failed step never ends the simulation
            error(self.session.halt(f"the step failed ({type(exc).__name__}: {exc})"))
            return False

    def behind_controller(self) -> bool:
        """Lockstep: the next step would be more than ``lockstep`` steps past the latest
        joint state, whose answer has not come (stamped commands), or past the last command
        (unstamped). Never before the first command, nor without lockstep."""
        if self.lockstep == 0 or self.commanded_k is None:
            return False
        k, shown = self.session.k, self.published_k
        if self.answered_k is not None:
            return shown is not None and k - shown >= self.lockstep and self.answered_k < shown
        return k - self.commanded_k >= self.lockstep

    def step(self, force=False) -> Tick:
        """One step of the session (``force``: also while paused) and what is due."""
        ok, notes = self.session.step(force)
        k = self.session.k
        clock = ok and self.publish_clock and k % self.clock_every == 0
        publish = ok and k % self.publish_every == 0
        if publish:
            self.published_k = k
        return Tick(ok, notes, self.clock_ns(k) if clock else None, publish)

    def contact_forces(self):
        """The contacts' forces (m, 3) on the robot, world axes, N, over the step that
        reached the current state; None without contacts."""
        return self.session.contact_forces()[1] if self.contact_names else None

    def clock_ns(self, k):
        """Simulated time of step k in ns with publish_clock (the stamps), else None."""
        return k * self.dt_ns if self.publish_clock else None

    # ------------------------------------------------------------ reports
    def report(self):
        """/diagnostics entries: the real-time factor achieved since the last report
        (simulated s per wall s; WARN below 90 % of real_time_factor while running), late
        steps (started more than one step period behind the schedule), with lockstep the
        waits for a command so far, the session's."""
        session, pacer = self.session, self.pacer
        k, k0 = session.k, pacer.mark[1]     # mark: (wall, k) of the last report
        rtf = pacer.achieved(k, session.dt)
        running = not session.paused and k > k0
        slow = running and self.rtf > 0 and rtf < 0.9 * self.rtf
        lockstep = [("lockstep waits", self.lockstep_waits)] if self.lockstep else []
        return [("real-time factor", f"{rtf:.3f}" if running else "paused", slow),
                ("late steps", pacer.late_steps), *lockstep, *session.report()]

    def summary(self):
        """The closing line (simulated and wall time since ``run`` started), or None."""
        wall0, k0 = self.started
        wall, simulated = self.clock() - wall0, (self.session.k - k0) * self.session.dt
        if not (wall > 0 and simulated > 0):
            return None
        return (f"simulated {simulated:.3f} s in {wall:.3f} s of wall time (real-time factor "
                f"{simulated / wall:.3f}, pauses included)")
