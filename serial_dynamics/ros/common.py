"""What every node shares about messages: validation (with bounds on what one message may
carry), logging at a severity chosen at run time (``log``), once-per-cause logging of
rejected input, the message counts on /diagnostics, and
``run`` (start-up errors, spin, shutdown). Parameters and the robot loading rule:
``parameters.py``.

The nodes only convert messages and parameters and call the library; the library never
imports rclpy.
"""
from __future__ import annotations

import ctypes
import inspect
import os
import signal
import sys
import threading

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

try:    # Jazzy's executor in C++: no wait set rebuilt in Python for every callback
    from rclpy.experimental import EventsExecutor
except ImportError:     # an rclpy without it: the nodes spin SingleThreadedExecutor
    EventsExecutor = None

from .parameters import StartupError
from .throttle import Rejected, Throttle  # noqa: F401  (Rejected: re-exported)

# Queue depth of every command, request and state topic (reliable, volatile: compatible
# with the ROS defaults of rclcpp/rclpy publishers, ros2_control and robot_state_publisher).
QOS_DEPTH = 10
# ... except the inverse-dynamics requests: a deeper queue absorbs a stall of the node (a
# busy core) of up to 0.1 s at 1 kHz instead of dropping requests. A depth is no part of
# QoS compatibility: any reliable or best-effort publisher matches.
REQUEST_DEPTH = 100
# What one message may carry. Beyond these it is refused whole, before anything else in it
# is looked at (far beyond any robot, far below what would cost the node noticeable time).
MAX_NAMES = 1000        # joint names in a JointState or JointTrajectory
MAX_POINTS = 10_000     # points in a JointTrajectory (10 s at 1 kHz)
MAX_VALUE = 1e6         # |position| (rad, m), |velocity|, |acceleration|, |wrench| (N, N m)
DIAGNOSTICS_PERIOD = 1.0   # s of wall time between two /diagnostics reports


# ------------------------------------------------------------------ logging
def log(logger, level: str, text: str):
    """``text`` at ``level`` ("error", "warning", "info" or "debug") on an rclpy logger.
    rclpy ties a severity to each call site and raises ValueError when one site logs at
    another, so a line whose severity varies (a step's notes) goes through here: one call
    site per severity."""
    if level == "error":
        logger.error(text)
    elif level == "warning":
        logger.warning(text)
    elif level == "info":
        logger.info(text)
    elif level == "debug":
        logger.debug(text)
    else:
        raise ValueError(f"log level {level!r} unknown; use error, warning, info or debug")


# ------------------------------------------------------------------ rejected input
class Rejections:
    """Log rejected input once per cause, then a count of repeats at most every
    ``period`` seconds. The node carries on; what was in force stays in force.

    Also counts, per topic, the messages the node received, refused and sent, and reports
    them on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, one status named after the
    node) every DIAGNOSTICS_PERIOD s of wall time: level WARN when something was refused
    since the last report, or a message was lost, else OK. A message dropped before the
    node saw it (replaced in a full queue, lost on the way) leaves a gap in its
    publisher's sequence numbers: counted as "lost" while the topic has one publisher;
    with several, the senders compare their own counts with "received"."""

    def __init__(self, node, period: float = 10.0, hardware_id: str = ""):
        self.logger, self.period = node.get_logger(), period
        self.once = Throttle(lambda text: self.logger.warning(text), period)
        self.counts = self.once.counts     # per cause, for the tests
        self.received, self.sent, self.refused = {}, {}, {}
        self.lost, self.skipped, self._sequence = {}, {}, {}   # sequence gaps (subscribe)
        self._lost_reported = 0
        self.topic = None           # the topic whose handler runs (subscribe), else None
        self._watched = []          # node-specific values of every report (watch)
        self._name, self._hardware_id, self._refused_reported = (
            node.get_fully_qualified_name(), hardware_id, 0)
        self._clock = node.get_clock()
        self._diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", QOS_DEPTH)
        node.create_timer(DIAGNOSTICS_PERIOD, self.report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def __call__(self, where: str, exc: Rejected, consequence: str = ""):
        """Count and log a refusal. Within a message handler it is counted under the topic
        the message came on (the key of its ``received`` count: ``refused ~/set_state``
        beside ``received ~/set_state``), whatever short name ``where`` the log uses."""
        topic = self.topic or where
        self.refused[topic] = self.refused.get(topic, 0) + 1
        self.once((where, exc.cause), f"rejected {where}: {exc}{consequence}",
                  f"rejected {{}} more {where} message(s) since: {exc.cause}")

    def got(self, topic: str):
        self.received[topic] = self.received.get(topic, 0) + 1

    def sequence(self, topic: str, number, publishers, latest_only=False):
        """The publisher's sequence number of a message taken from ``topic``: a jump
        beyond the next one means messages that never reached the node (replaced in a full
        queue, or lost on the way). Counted only while ``publishers()`` is 1 (numbers are
        per publisher and messages carry no publisher id), as ``lost`` -- or ``skipped``
        on a keep-last-1 subscription (``latest_only``), where older messages are meant to
        be replaced by newer ones. A number that goes back is a new publisher."""
        last, self._sequence[topic] = self._sequence.get(topic), number
        if number is None or last is None or number <= last + 1 or publishers() != 1:
            return
        into = self.skipped if latest_only else self.lost
        into[topic] = into.get(topic, 0) + number - last - 1

    def put(self, topic: str):
        self.sent[topic] = self.sent.get(topic, 0) + 1

    def watch(self, values):
        """Add node-specific values to every report: ``values()`` returns a list of
        ``(key, value)`` or ``(key, value, warn)``; a true ``warn`` raises the report's level
        to WARN (e.g. a real-time factor below target, a saturated joint). Called from the
        report timer: it must be quick and must not raise."""
        self._watched.append(values)

    def report(self):
        # copies: the simulator counts from its stepping thread (a dict copy is atomic)
        received, sent, refused = dict(self.received), dict(self.sent), dict(self.refused)
        total, lost = sum(refused.values()), dict(self.lost)
        values = ([KeyValue(key=f"received {t}", value=str(n)) for t, n in received.items()]
                  + [KeyValue(key=f"sent {t}", value=str(n)) for t, n in sent.items()]
                  + [KeyValue(key=f"refused {t}", value=str(n)) for t, n in refused.items()]
                  + [KeyValue(key=f"lost {t}", value=str(n)) for t, n in lost.items()]
                  + [KeyValue(key=f"skipped {t}", value=str(n))
                     for t, n in dict(self.skipped).items()])
        warn = False
        for watched in self._watched:
            for key, value, *flag in watched():
                values.append(KeyValue(key=key, value=str(value)))
                warn = warn or bool(flag and flag[0])
        text = "; ".join(f"{k.key}: {k.value}" for k in values) or "no messages yet"
        lost_total = sum(lost.values())
        level = (DiagnosticStatus.WARN if total > self._refused_reported or warn
                 or lost_total > self._lost_reported else DiagnosticStatus.OK)
        self._refused_reported, self._lost_reported = total, lost_total
        msg = DiagnosticArray(status=[DiagnosticStatus(
            level=level, name=self._name, message=text, hardware_id=self._hardware_id,
            values=values)])
        msg.header.stamp = self._clock.now().to_msg()
        self._diagnostics.publish(msg)


def subscribe(node, rejections, msg_type, topic, handler, depth=QOS_DEPTH):
    """A subscription whose messages are counted (``received`` on /diagnostics) before
    ``handler`` takes them, and whose gaps in the publisher's sequence numbers are counted
    as ``lost`` (``skipped`` with ``depth`` 1, where only the latest message matters). The
    handler refuses bad input itself; an exception that escapes it anyway (a bug) is
    logged once per type and the node carries on."""
    subscription = []

    def publishers():
        return node.count_publishers(subscription[0].topic_name)

    def callback(msg, info=None):
        if info is None:        # EventsExecutor passes (message, info) as one argument
            msg, info = msg
        rejections.got(topic)
        rejections.sequence(topic, info.get("publication_sequence_number"), publishers,
                            latest_only=depth == 1)
        rejections.topic = topic
        try:
            handler(msg)
        except Exception as exc:  # noqa: BLE001 -- a node never dies on a message
            rejections.once(("bug", topic, type(exc).__name__),
                            f"internal error on a {topic} message (please report): "
                            f"{type(exc).__name__}: {exc}; the node carries on",
                            f"internal error on {{}} more {topic} message(s)")
        finally:
            rejections.topic = None
    # rclpy's executors call a callback that takes two arguments as callback(msg, info);
    # the EventsExecutor of the Jazzy wheels calls it as callback((msg, info)). This one
    # takes both, and its signature says two so that rclpy passes the info to either.
    callback.__signature__ = _MESSAGE_AND_INFO
    subscription.append(node.create_subscription(msg_type, topic, callback, depth))
    return subscription[0]


_MESSAGE_AND_INFO = inspect.Signature(
    [inspect.Parameter(name, inspect.Parameter.POSITIONAL_ONLY) for name in ("msg", "info")])


def _show(values, at_most=8):
    """A list for a log line, shortened when long."""
    values = list(values)
    if len(values) <= at_most:
        return str(values)
    return f"[{', '.join(map(repr, values[:at_most]))}, ... ({len(values)} in all)]"


def finite_vector(values, n, what, cause, bound=MAX_VALUE):
    """values as a float array of length n, all finite and (unless bound is None) within
    +-bound, else Rejected."""
    if len(values) != n:
        raise Rejected(f"{cause} length", f"{what} has {len(values)} values; expected {n}")
    a = np.asarray(values, dtype=float).reshape(-1)
    if not np.all(np.isfinite(a)):
        raise Rejected(f"{cause} NaN/Inf", f"{what} contains NaN or Inf: {_show(a.tolist())}")
    if bound is not None and np.any(np.abs(a) > bound):
        raise Rejected(f"{cause} out of range", f"{what} has values beyond +-{bound:g} (the "
                       f"bound of every message value): {_show(a.tolist())}")
    return a


def name_index(names, robot, what, require_all=True, allow_extra=False):
    """For message joint names: (positions in the message, matching model indices).
    Rejects more than MAX_NAMES (before looking at them), empty, duplicate, unknown (unless
    allow_extra) and missing (if require_all). Linear in the number of names."""
    if len(names) > MAX_NAMES:
        raise Rejected("too many joint names", f"{what} names {len(names)} joints; at most "
                       f"{MAX_NAMES} are accepted (the model has {robot.dof} joints)")
    names = list(names)
    if not names:
        raise Rejected("no joint names", f"{what} names no joints")
    first, dup = {}, []
    for i, x in enumerate(names):
        if first.setdefault(x, i) != i and x not in dup:
            dup.append(x)
    if dup:
        raise Rejected("duplicate joint names", f"{what} names joints {_show(sorted(dup))} "
                       "more than once")
    model = {x: j for j, x in enumerate(robot.joint_names)}
    unknown = [x for x in names if x not in model]
    if unknown and not allow_extra:
        raise Rejected("unknown joint names", f"{what} names joints {_show(unknown)} that are "
                       f"not joints of the model {_show(robot.joint_names)}")
    missing = [x for x in model if x not in first]
    if missing and require_all:
        raise Rejected("missing joints", f"{what} lacks joints {missing}")
    msg_idx = [i for i, x in enumerate(names) if x in model]
    return np.array(msg_idx, dtype=int), np.array([model[names[i]] for i in msg_idx], dtype=int)


def joint_state_arrays(msg, robot, fields, allow_extra=False):
    """sensor_msgs/JointState -> one float array per field of ``fields`` ("position",
    "velocity", "effort"), of length robot.dof in model order. Every joint of the robot must
    be named; others (a gripper, another arm) are refused, or ignored with ``allow_extra``.
    Values must be finite and within +-MAX_VALUE; Rejected otherwise."""
    msg_idx, idx = name_index(msg.name, robot, "joint_states", allow_extra=allow_extra)
    out = []
    for field in fields:
        what = f"joint_states {field}"
        x = np.empty(robot.dof)
        x[idx] = finite_vector(getattr(msg, field), len(msg.name), what, what)[msg_idx]
        out.append(x)
    return out


FIELDS = ("positions", "velocities", "accelerations")


def trajectory_arrays(msg, robot, what, need_increasing_time=False):
    """trajectory_msgs/JointTrajectory -> (t (N,), q, qd, qdd (N, n) in model order,
    have_velocities, have_accelerations). Missing velocities/accelerations are zeros.
    Rejects more than MAX_POINTS points, values beyond +-MAX_VALUE and NaN/Inf.

    The fields (array.array of float64) are read through the buffer protocol, one NumPy
    array per field; joint names equal to the robot's (the usual case of a stream) skip the
    name checks; one comparison per field finds both NaN/Inf and values out of range."""
    names = msg.joint_names
    in_model_order = names == robot.joint_names
    if not in_model_order:
        msg_idx, model_idx = name_index(names, robot, what)
    points = msg.points
    m, n, N = len(names), robot.dof, len(points)
    if N == 0:
        raise Rejected("no points", f"{what} has no points")
    if N > MAX_POINTS:
        raise Rejected("too many points", f"{what} has {N} points; at most {MAX_POINTS} are "
                       "accepted (send a longer trajectory in parts)")
    out = np.zeros((3, N, n))
    have = [True, True, True]
    for k, field in enumerate(FIELDS):
        if N == 1:
            row = getattr(points[0], field)
            sizes = {len(row)}
        else:
            sizes = {len(getattr(pt, field)) for pt in points}
        if k > 0 and sizes == {0}:
            have[k] = False
            continue
        if sizes != {m}:
            raise Rejected(f"{field} length", f"{what}: every point needs {m} {field} (one per "
                           f"joint name){'' if k == 0 else ' or none'}; got lengths "
                           f"{_show(sorted(sizes))}")
        vals = (np.asarray(row, dtype=float)[None] if N == 1 else
                np.array([getattr(pt, field) for pt in points], dtype=float))
        if not (np.abs(vals) <= MAX_VALUE).all():       # False for NaN too
            if not np.isfinite(vals).all():
                raise Rejected(f"{field} NaN/Inf", f"{what}: {field} contain NaN or Inf")
            raise Rejected(f"{field} out of range", f"{what}: {field} beyond +-{MAX_VALUE:g} "
                           f"(the bound of every message value): up to "
                           f"{np.max(np.abs(vals)):.3g}")
        if in_model_order:
            out[k] = vals
        else:
            out[k][:, model_idx] = vals[:, msg_idx]
    if N == 1:
        d = points[0].time_from_start
        t = np.array([d.sec + 1e-9 * d.nanosec])
    else:
        t = np.array([pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec
                      for pt in points])
    if need_increasing_time and (np.any(np.diff(t) <= 0) or t[0] < 0):
        raise Rejected("time_from_start", f"{what}: time_from_start must increase strictly "
                       f"from point to point; got {t.tolist()}")
    return t, out[0], out[1], out[2], have[1], have[2]


def stamp_seconds(stamp) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


# ------------------------------------------------------------------ running a node
SPIN_PERIOD = 0.1   # s; the longest a stop request waits for the spin loop to see it


# s from a signal to the exit at the latest: the orderly stop below takes tens of ms, but
# rclpy's teardown (the executor's shutdown, destroy_node, try_shutdown) has been seen to
# hang for over 10 s once in a run of the whole suite (a busy controller, eight nodes and two
# compiles on two cores); a launch file or systemd would then escalate to SIGKILL.
STOP_DEADLINE = 1.5


class _StopRequest:
    """SIGINT and SIGTERM handler of ``run``: it only notes the signal. rclpy's own handler
    (not installed: SignalHandlerOptions.NO) shuts the context down at once, under the
    callbacks still running -- the source of "publisher's context is invalid" in a timer,
    "the given context is not valid" in the executor's wait set and the errors of
    ``take_message``. Noted here, the spin loop ends between two callbacks and the node is
    taken down in order (its threads, its timers and publishers, then the context).
    Before the node spins (loading the robot, compiling), a signal stops the start-up.

    The first signal also starts a deadline: ``deadline`` s later the process exits with
    status 0 whatever the teardown is doing, after the ``stopped`` line if the stop had not
    said it yet (``said_stopped``: once, from either thread); the step it cut short is
    logged at DEBUG (``--log-level debug``)."""

    def __init__(self, deadline: float = STOP_DEADLINE, exit=None):
        self.signal, self.spinning, self.logger = None, False, None
        self.step = "spinning"                  # the teardown step under way
        self.deadline, self.exit = deadline, exit or _exit_now
        self._said, self._lock = False, threading.Lock()

    def __call__(self, signum, frame):
        if self.signal is None:                 # the first signal: its name, the deadline
            self.signal = signal.Signals(signum).name
            timer = threading.Timer(self.deadline, self.expire)
            timer.daemon = True
            timer.start()
        if not self.spinning:
            raise KeyboardInterrupt

    def said_stopped(self):
        """Log ``stopped (SIGINT)`` (or the signal's name, or shutdown) unless it was."""
        with self._lock:
            if not self._said and self.logger is not None:
                self.logger.info(f"stopped ({self.signal or 'shutdown'})")
            self._said = True

    def expire(self):
        """The deadline: say what the stop was doing, say ``stopped``, exit."""
        if self.logger is not None:
            self.logger.debug(f"the stop was still {self.step} {self.deadline} s after "
                              f"{self.signal}: exiting without it")
        self.said_stopped()
        self.exit(0)

    def install(self):
        if threading.current_thread() is threading.main_thread():   # signal's own rule
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, self)


def executor(events: bool):
    """The executor a node spins: rclpy's ``EventsExecutor`` (``events``, where this rclpy
    has it) or ``SingleThreadedExecutor``. The events executor takes each message as the
    middleware announces it, in C++, where ``SingleThreadedExecutor`` rebuilds its wait set
    in Python before every callback (two thirds of the dynamics node's CPU time per request
    at 1 kHz: bench/bench_ros_throughput.py). It supports no guard conditions and installs
    its own SIGINT/SIGTERM handlers, which ``run`` replaces by its own again."""
    if events and EventsExecutor is not None:
        return EventsExecutor()
    return SingleThreadedExecutor()


def run(node_class, args=None, events: bool = False) -> int:
    """Start ``node_class`` and spin it until SIGINT (Ctrl-C) or SIGTERM, then stop it in
    order and log ``stopped (SIGINT)`` (or SIGTERM) as its last line; returns 0. A bad
    parameter or robot prints one paragraph to stderr and returns 2 -- no traceback.
    ``events``: spin rclpy's EventsExecutor (``executor``)."""
    name = node_class.NAME
    stop = _StopRequest()
    try:
        rclpy.init(args=sys.argv if args is None else args,
                   signal_handler_options=SignalHandlerOptions.NO)
    except Exception as exc:   # e.g. malformed --ros-args
        text = " ".join(str(exc).split())
        print(f"{name}: cannot start: the ROS arguments are not valid: {text}", file=sys.stderr)
        return 2
    stop.install()
    node = spinner = None
    try:
        node = node_class()
        stop.logger = node.get_logger()
        node.get_logger().info("ready")
        spinner = executor(events)
        stop.install()                         # again: the events executor took the signals
        spinner.add_node(node)
        stop.spinning = True
        while stop.signal is None:
            spinner.spin_once(timeout_sec=SPIN_PERIOD)
    except (StartupError, rclpy.exceptions.ParameterException) as exc:
        text = " ".join(str(exc).split())
        print(f"{name}: cannot start: {text}. See docs/ros.md for the parameters.",
              file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop.spinning = True                   # a second signal no longer interrupts
        if node is not None:
            stop.step = "closing the node's threads"
            node.close()                       # the node's own threads first
            stop.said_stopped()
            stop.step = "shutting the executor down"
            if spinner is not None:            # lets go of the node's entities: the events
                spinner.shutdown()             # executor holds them in use until then
            stop.step = "destroying the node"
            node.destroy_node()                # timers, publishers, subscriptions
        stop.step = "shutting rclpy down"
        rclpy.try_shutdown()
    if stop.signal is not None:
        _exit_now(0)
    return 0


def _exit_now(code):
    """End the process once the node has stopped. Python's own finalization would next
    free every compiled numba kernel of the process (about 1 s for a node's ~100 kernels,
    measured here; several seconds on a loaded machine), which nothing of a stopped node
    needs and which would put the exit beyond a launch system's grace period."""
    sys.stdout.flush()
    sys.stderr.flush()
    ctypes.CDLL(None).fflush(None)      # C stdio too (rcutils logs through it)
    os._exit(code)
