"""The dynamics node's ``~/estimate_payload`` and ``~/time_parameterize``, checked and
answered in plain Python (no rclpy: the tests call these directly), and the log of
``joint_states`` the payload is estimated from.

- ``JointStateLog``: the node's recent ``sensor_msgs/JointState`` messages that carry
  positions and efforts for every joint (any order, extra joints ignored), the last
  ``BUFFER_SECONDS`` of them, in the robot's joint order; and how many it was given, and
  why it skipped the others.
- ``answer_estimate_payload(robot, log, request)``: the link checked first, then
  ``identification.estimate_payload`` on the last ``request.window`` seconds of the log
  (0: all of it); the estimate's fields, and the payload.* values to set on the node when
  ``request.apply``. No payload detected: the mass and its standard deviation, and empty
  com, inertia and their standard deviations; ``apply`` then clears the payload.
- ``answer_time_parameterize(robot, request)``: ``trajectory.time_parameterize`` of the
  request's path (a ``trajectory_msgs/JointTrajectory`` whose points' positions are read;
  at most ``MAX_WAYPOINTS`` of them, on a grid of at most ``MAX_GRID`` intervals);
  limits per joint in the path's joint order, or one for all, or empty for the robot's
  (none on acceleration); the timed trajectory in the robot's joint order with positions,
  velocities, accelerations, the efforts that produce them, and times from start.

A refusal raises ``Rejected`` (the field and the fix) or the library's ValueError.
"""
from __future__ import annotations

import time
from collections import Counter, deque

import numpy as np

from .. import identification, trajectory
from ..model.links import link_problem
from .requests import joint_order
from .throttle import Rejected

BUFFER_SECONDS = 120.0      # joint_states kept for ~/estimate_payload
DEFAULT_GRID = 200          # ~/time_parameterize's grid when the request gives 0
# ... and the most it takes: the solver's time and memory grow with the grid (a uint32 field
# reaches 4.3e9 intervals, tens of GiB); 10,000 took 0.5-1.3 s here (UR5e, three waypoints)
MAX_GRID = 10_000
# The most waypoints ~/time_parameterize takes, checked before any is read: the solver's
# time grows with the runs between corners (a corner at every waypoint: 1000 took 3.3 s
# here, 10,000 took 41 s; 10,000 on a smooth curve 2.6 s); a planner's path has tens to
# hundreds, and a straight stretch needs only its two ends
MAX_WAYPOINTS = 1000


class JointStateLog:
    """The last ``seconds`` of joint states with positions and efforts (see the module)."""

    def __init__(self, robot, seconds=BUFFER_SECONDS):
        self.names, self.seconds = list(robot.joint_names), float(seconds)
        self._rows = deque()            # (t, q (n,), tau (n,))
        self.received = 0               # messages given to add
        self.skipped = 0                # of them not used, ...
        self.reasons = Counter()        # ... by reason
        self.started = time.monotonic()

    def add(self, t, names, positions, efforts):
        """One message: its time (s) and fields; False (counted, with the reason) when it
        cannot be used."""
        self.received += 1
        where = {name: k for k, name in enumerate(names)}
        if (len(positions) != len(names) or len(efforts) != len(names)
                or any(name not in where for name in self.names)):
            return self._skip("no position and effort for every joint")
        idx = [where[name] for name in self.names]
        q = np.asarray(positions, dtype=float)[idx]
        tau = np.asarray(efforts, dtype=float)[idx]
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(tau)) and np.isfinite(t)):
            return self._skip("a NaN or Inf")
        if self._rows and t <= self._rows[-1][0]:
            return self._skip("a stamp not after the previous one's")
        self._rows.append((float(t), q, tau))
        while self._rows and self._rows[0][0] < t - self.seconds:
            self._rows.popleft()
        return True

    def _skip(self, reason):
        self.skipped += 1
        self.reasons[reason] += 1
        return False

    def __len__(self):
        return len(self._rows)

    def account(self):
        """What the node has received, in words: for a refusal that says why it has too
        few samples."""
        why = "; ".join(f"{k} {reason}" for reason, k in self.reasons.most_common())
        return (f"the node has received {self.received} joint_states in the "
                f"{time.monotonic() - self.started:.3g} s since it subscribed, kept "
                f"{len(self._rows)} (at most the last {self.seconds:g} s), skipped "
                f"{self.skipped}" + (f" ({why})" if why else ""))

    def window(self, seconds):
        """(t, q, tau) of the last ``seconds`` (0: everything kept)."""
        rows = list(self._rows)
        if seconds > 0 and rows:
            rows = [r for r in rows if r[0] >= rows[-1][0] - seconds]
        if not rows:
            return np.zeros(0), np.zeros((0, len(self.names))), np.zeros((0, len(self.names)))
        return (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                np.array([r[2] for r in rows]))


def answer_estimate_payload(robot, log, req):
    """(response fields, payload parameters to set or None)."""
    window = float(req.window)
    if not np.isfinite(window) or window < 0:
        raise Rejected("window", f"window is {window}: give the seconds of joint_states to fit "
                       "(> 0), or 0 for all the node keeps")
    if robot.is_floating:
        raise Rejected("robot", "~/estimate_payload is for a fixed base: start the node "
                       "with floating_base false to estimate what the arm holds")
    link = req.link or robot.tip_link
    problem = link_problem(robot.model, link, moving=True)
    if problem is not None:
        raise Rejected("link", f"{problem}; or leave link empty for the tip")
    t, q, tau = log.window(window)
    if t.size < 100:
        span = f"in the last {window:g} s" if window else "kept"
        raise Rejected("window", f"{t.size} joint_states with positions and efforts for every "
                       f"joint {robot.joint_names} {span}, 100 needed: {log.account()}. Move "
                       "the arm along an excitation trajectory while joint_states carry "
                       "efforts, then ask again")
    est = identification.estimate_payload(robot, t, q, tau, link=link)
    listed = lambda x: [] if x is None else x.tolist()       # noqa: E731 -- None: no payload
    fields = {"link": est.link, "mass": est.mass, "com": listed(est.com),
              "inertia": listed(est.inertia), "mass_std": est.mass_std,
              "com_std": listed(est.com_std), "inertia_std": listed(est.inertia_std),
              "condition_number": est.condition_number, "samples": int(t.size),
              "message": est.summary()}
    apply = None
    if req.apply:               # no payload detected: none (mass 0 and no inertia)
        held = est.detected
        apply = {"payload.mass": est.mass if held else 0.0,
                 "payload.com": est.com.tolist() if held else [0.0] * 3,
                 "payload.inertia": est.inertia.tolist() if held else [0.0] * 6,
                 "payload.link": "" if link == robot.tip_link and not req.link else link}
    return fields, apply


def _limits(robot, index, values, field):
    """None (the default), or a limit per joint in the model's order."""
    if len(values) == 0:
        return None
    a = np.asarray(values, dtype=float)
    if a.size == 1:
        return np.full(robot.dof, a[0])
    if a.size != robot.dof:
        raise Rejected(field, f"{field} has {a.size} values: give one per joint ({robot.dof}, "
                       "in the path's joint order), one for all, or none for the default")
    if index is None:
        return a
    out = np.empty(robot.dof)
    out[index] = a
    return out


def answer_time_parameterize(robot, req, compensate=False):
    """{"trajectory": JointTrajectory} timed within the limits (module docstring); the
    efforts include the dissipation torques when the node compensates them."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    path = req.path
    index = joint_order(robot, path.joint_names)
    if len(path.points) > MAX_WAYPOINTS:
        raise Rejected("path", f"path has {len(path.points)} points; at most {MAX_WAYPOINTS} "
                       "waypoints are accepted: give the corners and enough points to follow "
                       "the curves (the timing follows the path's geometry, not its sampling)")
    if len(path.points) < 2:
        raise Rejected("path", f"path has {len(path.points)} points: give at least two "
                       "waypoints' positions")
    q = np.empty((len(path.points), robot.dof))
    for k, point in enumerate(path.points):
        if len(point.positions) != robot.dof:
            raise Rejected("path", f"path point {k} has {len(point.positions)} positions: give "
                           f"one per joint ({robot.dof})")
        x = np.asarray(point.positions, dtype=float)
        if index is None:
            q[k] = x
        else:
            q[k, index] = x
    limits = {name: _limits(robot, index, getattr(req, field), field) for name, field in (
        ("velocity_limit", "velocity_limits"), ("acceleration_limit", "acceleration_limits"),
        ("effort_limit", "effort_limits"))}
    grid = int(req.grid) or DEFAULT_GRID
    if grid > MAX_GRID:
        raise Rejected("grid", f"grid = {grid} intervals; at most {MAX_GRID} are accepted (0: "
                       f"{DEFAULT_GRID}, a few hundred is typical)")
    w = trajectory.time_parameterize(robot, q, grid=grid, **limits)
    tau = robot.inverse_dynamics(w.q, w.qd, w.qdd)
    if compensate:
        tau = tau - robot.dissipation_torques(w.qd)
    out = JointTrajectory(header=path.header, joint_names=robot.joint_names)
    for k in range(len(w.t)):
        sec = int(np.floor(w.t[k]))
        out.points.append(JointTrajectoryPoint(
            positions=w.q[k].tolist(), velocities=w.qd[k].tolist(),
            accelerations=w.qdd[k].tolist(), effort=tau[k].tolist(),
            time_from_start=Duration(sec=sec, nanosec=min(int(round((w.t[k] - sec) * 1e9)),
                                                          999_999_999))))
    return {"trajectory": out, "duration": w.duration,
            "message": f"{len(w.t)} points, {w.duration:.4g} s"}
