"""What every node shares: parameters, the robot loading rule, message validation (with
bounds on what one message may carry), once-per-cause logging of rejected input, the
message counts on /diagnostics, and ``run`` (start-up errors, spin, shutdown).

The nodes only convert messages and parameters and call the library; the library never
imports rclpy.
"""
from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

import serial_dynamics as sd

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
# robot_state_publisher (Jazzy) publishes robot_description reliable + transient local.
DESCRIPTION_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)


class StartupError(Exception):
    """A bad parameter or robot at start-up: the node prints one paragraph and exits."""


class Rejected(ValueError):
    """A message that the node refuses; ``cause`` groups repeats for throttled logging."""

    def __init__(self, cause: str, text: str):
        super().__init__(text)
        self.cause = cause


# ------------------------------------------------------------------ parameters
# A spec maps a parameter name to (kind, default, description). Kinds: "bool", "int",
# "double", "string", "double[]", "string[]". A "double[]" default of None means "not set"
# (the node then uses what the robot says). Numbers are accepted as integers or doubles
# (-p kp:=[400, 400] and -p kp:=[400.0, 400.0] both work).

ROBOT_PARAMETERS = {
    "urdf_path": ("string", "", "URDF file of the robot. First in the loading order: "
                  "urdf_path, then the robot_description parameter, then the "
                  "robot_description topic, then the embedded UR5e"),
    "robot_description": ("string", "", "URDF XML of the robot (used when urdf_path is empty)"),
    "robot_description_timeout": ("double", 2.0, "s to wait for a robot_description message "
                                  "(std_msgs/String, transient local) when neither parameter "
                                  "is set; 0 skips the topic"),
    "base_link": ("string", "", "first link of the modelled chain ('' = the URDF root)"),
    "tip_link": ("string", "", "last link of the chain ('' = the end of the single chain)"),
    "gravity": ("double[]", [0.0, 0.0, -9.81], "gravity in the URDF root frame (m/s^2)"),
    "dissipation.joints": ("string[]", [], "joints the dissipation.* arrays refer to, in "
                           "their order ([] = every joint, base to tip)"),
    "dissipation.viscous": ("double[]", None, "viscous coefficient beta (N m s/rad; N s/m) "
                            "per listed joint, or one for all ([] = URDF damping)"),
    "dissipation.coulomb": ("double[]", None, "Coulomb torque tau_c (N m; N) per listed joint, "
                            "or one for all ([] = URDF friction)"),
    "dissipation.stribeck": ("double[]", None, "extra static torque eps at rest (N m; N) "
                             "([] = 0)"),
    "dissipation.stribeck_rate": ("double[]", None, "decay rate gamma of the low-speed rise "
                                  "(s/rad) ([] = 0)"),
}


def _number(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise StartupError(f"parameter {name!r} must be a number, got {v!r}")
    return float(v)


def _coerce(name, kind, value):
    if kind == "bool":
        if not isinstance(value, bool):
            raise StartupError(f"parameter {name!r} must be true or false, got {value!r}")
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise StartupError(f"parameter {name!r} must be an integer, got {value!r}")
        return value
    if kind == "double":
        v = _number(name, value)
        if math.isnan(v):
            raise StartupError(f"parameter {name!r} is NaN")
        return v
    if kind == "string":
        if not isinstance(value, str):
            raise StartupError(f"parameter {name!r} must be a string, got {value!r}")
        return value
    if kind == "double[]":
        if value is None:
            return None
        values = [value] if isinstance(value, (int, float)) else value
        if isinstance(values, str) or not hasattr(values, "__iter__"):
            raise StartupError(f"parameter {name!r} must be a list of numbers, got {value!r}")
        out = [_number(name, v) for v in values]
        if any(math.isnan(v) for v in out):
            raise StartupError(f"parameter {name!r} contains NaN: {out}")
        return out or None
    if kind == "string[]":
        values = [] if value is None else ([value] if isinstance(value, str) else list(value))
        if not all(isinstance(v, str) for v in values):
            raise StartupError(f"parameter {name!r} must be a list of strings, got {value!r}")
        return values
    raise AssertionError(kind)


# Parameters that may be set while the node runs (ros2 param set, SetParameters[Atomically]):
# a payload picked up or put down. All the others are read-only.
PAYLOAD_PARAMETERS = {
    "payload.mass": ("double", 0.0, "mass (kg) of a payload rigidly attached to payload.link; "
                     "0 with zero inertia = no payload. Settable while running"),
    "payload.com": ("double[]", [0.0, 0.0, 0.0], "center of mass (x, y, z) of the payload in "
                    "payload.link's frame (m). Settable while running"),
    "payload.inertia": ("double[]", [0.0] * 6, "inertia of the payload about its center of "
                        "mass, in payload.link's axes: ixx iyy izz ixy ixz iyz (kg m^2). "
                        "Settable while running"),
    "payload.link": ("string", "", "link that carries the payload ('' = the tip link). "
                     "Settable while running"),
}
WRITABLE = frozenset(PAYLOAD_PARAMETERS)


def declare(node, spec: dict) -> dict:
    """Declare every parameter of ``spec`` (with its description; read-only unless in
    ``WRITABLE``) and return their values, checked and converted. Raises StartupError
    naming the parameter."""
    values = {}
    for name, (kind, default, text) in spec.items():
        descriptor = ParameterDescriptor(description=text, dynamic_typing=True,
                                         read_only=name not in WRITABLE)
        node.declare_parameter(name, default, descriptor)
        values[name] = _coerce(name, kind, node.get_parameter(name).value)
    # given (-p, --params-file) but not a parameter of this node: a typo or the wrong node.
    # rclpy keeps the overrides of the command line and parameter files in this attribute.
    unknown = sorted(x for x in getattr(node, "_parameter_overrides", {})
                     if not node.has_parameter(x))
    if unknown:
        node.get_logger().warning(
            f"ignoring unknown parameter(s) {unknown}: {node.get_name()} takes "
            f"{', '.join(spec)} (and use_sim_time)")
    return values


def defaults(spec: dict) -> dict:
    """Default values of a spec (the config/*.yaml files list these)."""
    return {name: default for name, (_, default, _) in spec.items()}


def per_joint(name, values, robot, default, positive=False):
    """A per-joint parameter: None -> default; one value -> every joint; n values."""
    if values is None:
        return np.array(default, dtype=float)
    a = np.asarray(values, dtype=float)
    if a.size == 1:
        a = np.full(robot.dof, a[0])
    if a.size != robot.dof:
        raise StartupError(f"parameter {name!r} has {a.size} values; give one, or one per "
                           f"joint ({robot.dof}: {robot.joint_names})")
    if positive and np.any(a < 0):
        raise StartupError(f"parameter {name!r} must be >= 0, got {a.tolist()}")
    return a


# ------------------------------------------------------------------ robot loading rule
def load_robot(node, p: dict, gravity=None):
    """The robot every node uses, from (in this order) the ``urdf_path`` parameter, the
    ``robot_description`` parameter, the ``robot_description`` topic (waiting at most
    ``robot_description_timeout`` s), else the embedded default robot (UR5e). Applies
    base_link, tip_link, gravity and the dissipation overrides; raises StartupError."""
    base, tip = p["base_link"] or None, p["tip_link"] or None
    g = p["gravity"] if gravity is None else gravity
    if g is None or len(g) != 3:
        raise StartupError(f"parameter 'gravity' must have 3 values (x, y, z in m/s^2), got {g}")
    if p["urdf_path"]:
        source, where = p["urdf_path"], f"urdf_path {p['urdf_path']!r}"
    elif p["robot_description"].strip():
        source, where = p["robot_description"], "the robot_description parameter"
    else:
        source = _wait_for_description(node, p["robot_description_timeout"])
        where = "the robot_description topic"
        if source is None:
            source, where = sd.builtin_path(), "the embedded default robot (UR5e)"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            robot = sd.load_urdf(source, base, tip, tuple(g))
        except (ValueError, OSError) as exc:   # URDFError and ModelError are ValueErrors
            raise StartupError(f"cannot load the robot from {where}: {exc}") from None
    for w in caught:
        node.get_logger().warning(str(w.message))
    robot.dissipation = _dissipation(robot, p)
    node.get_logger().info(f"robot {robot.model.name!r} from {where}: {robot.dof} joints "
                           f"{robot.joint_names}, {robot.base_link} -> {robot.tip_link}")
    return robot


def _wait_for_description(node, timeout):
    if not timeout > 0:
        return None
    node.get_logger().info(f"waiting up to {timeout} s for a robot_description message "
                           "(neither urdf_path nor robot_description is set; "
                           "robot_description_timeout:=0 skips the wait)")
    got = []
    sub = node.create_subscription(String, "robot_description", lambda m: got.append(m.data),
                                   DESCRIPTION_QOS)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    deadline = time.monotonic() + timeout
    try:
        while not got and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=min(0.05, max(0.0, deadline - time.monotonic())))
    finally:
        executor.remove_node(node)
        node.destroy_subscription(sub)
    if not got:
        node.get_logger().info(f"no robot_description message within {timeout} s")
    return got[-1] if got else None


def _dissipation(robot, p):
    joints = p["dissipation.joints"] or robot.joint_names
    unknown = [j for j in joints if j not in robot.joint_names]
    if unknown or len(set(joints)) != len(joints):
        raise StartupError(f"parameter 'dissipation.joints' = {joints} must name distinct "
                           f"joints of the chain {robot.joint_names}")
    changes = {}
    for field in robot.dissipation.FIELDS:
        values = p[f"dissipation.{field}"]
        if values is None:
            continue
        if len(values) == 1:
            values = values * len(joints)
        if len(values) != len(joints):
            raise StartupError(f"parameter 'dissipation.{field}' has {len(values)} values for "
                               f"{len(joints)} joints {joints}; give one, or one per joint")
        changes[field] = dict(zip(joints, values))
    try:
        return robot.dissipation.override(**changes) if changes else robot.dissipation
    except ValueError as exc:
        raise StartupError(f"dissipation parameters: {exc}") from None


# ------------------------------------------------------------------ payload at run time
def _payload_robot(loaded, values: dict):
    """(``loaded`` with the payload of the payload.* ``values``, a description of it).
    Raises ValueError naming the parameter or the physical reason."""
    try:
        v = {name: _coerce(name, kind, values[name])
             for name, (kind, _, _) in PAYLOAD_PARAMETERS.items()}
    except StartupError as exc:
        raise ValueError(str(exc)) from None
    mass, com, inertia, link = (v[f"payload.{k}"] for k in ("mass", "com", "inertia", "link"))
    for name, x, size, what in (("payload.com", com, 3, "x, y, z in m"),
                                ("payload.inertia", inertia, 6, "ixx iyy izz ixy ixz iyz in kg m^2")):
        if x is None or len(x) != size:
            raise ValueError(f"parameter {name!r} must have {size} values ({what}), got {x or []}")
    robot = loaded.with_payload(mass, com, inertia, link or None)   # validates (ValueError)
    if mass == 0.0 and not any(inertia):
        return loaded, "no payload"
    return robot, (f"payload {mass:g} kg on {robot.payload.link}, center of mass {com} m, "
                   f"inertia {inertia} kg m^2")


def with_payload_parameters(node, loaded, p: dict, apply):
    """The payload.* parameters (``PAYLOAD_PARAMETERS``) of ``node``.

    Returns ``loaded`` (the robot as loaded) with the payload of the start-up values ``p``
    (StartupError if they are bad). From then on every set of payload.* parameters is
    validated before it takes effect (a bad one is refused, with the reason, and the payload
    in force stays) and, once set, ``apply(robot)`` gets the new model -- a Robot built
    here, off the node's hot path; ``apply`` only swaps a reference. The parameters of one
    SetParametersAtomically call apply together (one ``apply``); a parameter not named
    keeps its value. Mass 0 with zero inertia is ``loaded`` itself (no payload).
    """
    log = node.get_logger()
    current = lambda: {name: node.get_parameter(name).value for name in PAYLOAD_PARAMETERS}  # noqa: E731
    try:
        robot, text = _payload_robot(loaded, {name: p[name] for name in PAYLOAD_PARAMETERS})
    except ValueError as exc:
        raise StartupError(f"payload parameters: {exc}") from None
    if robot is not loaded:
        log.info(text)

    def validate(parameters):
        new = {x.name: x.value.tolist() if hasattr(x.value, "tolist") else x.value
               for x in parameters if x.name in PAYLOAD_PARAMETERS}     # array('d') -> list
        if not new:
            return SetParametersResult(successful=True)
        try:
            _payload_robot(loaded, {**current(), **new})
        except ValueError as exc:
            log.warning(f"rejected payload parameters {new}: {exc}; the payload in force stays")
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def applied(parameters):   # after rclpy has stored the (validated) values
        if any(x.name in PAYLOAD_PARAMETERS for x in parameters):
            try:
                robot, text = _payload_robot(loaded, current())
                apply(robot)
            except Exception as exc:  # noqa: BLE001 -- validated above; never kill the node
                log.error(f"payload parameters set but not applied: {exc}")
                return
            log.info(f"{text} (applied)")

    node.add_on_set_parameters_callback(validate)
    node.add_post_set_parameters_callback(applied)
    return robot


# ------------------------------------------------------------------ rejected input
class Rejections:
    """Log rejected input once per cause, then a count of repeats at most every
    ``period`` seconds. The node carries on; what was in force stays in force.

    Also counts, per topic, the messages the node received, refused and sent, and reports
    them on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, one status named after the
    node) every DIAGNOSTICS_PERIOD s of wall time: level WARN when something was refused
    since the last report, else OK. A message dropped before the node saw it (a full
    queue) is in no count: the sender compares its own count with "received"."""

    def __init__(self, node, period: float = 10.0, hardware_id: str = ""):
        self.logger, self.period = node.get_logger(), period
        self.counts, self._logged_at, self._logged_count = {}, {}, {}
        self.received, self.sent, self.refused = {}, {}, {}
        self._name, self._hardware_id, self._refused_reported = (
            node.get_fully_qualified_name(), hardware_id, 0)
        self._clock = node.get_clock()
        self._diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", QOS_DEPTH)
        node.create_timer(DIAGNOSTICS_PERIOD, self.report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def __call__(self, where: str, exc: Rejected, consequence: str = ""):
        self.refused[where] = self.refused.get(where, 0) + 1
        self.once((where, exc.cause), f"rejected {where}: {exc}{consequence}",
                  f"rejected {{}} more {where} message(s) since: {exc.cause}")

    def once(self, key, text: str, repeats: str | None = None):
        """Log ``text`` the first time ``key`` comes up; later, ``repeats`` (formatted with
        the count) at most every ``period`` s."""
        n = self.counts[key] = self.counts.get(key, 0) + 1
        now = time.monotonic()
        if n == 1:
            self.logger.warning(text)
        elif repeats and now - self._logged_at[key] >= self.period:
            self.logger.warning(repeats.format(n - self._logged_count[key]))
        else:
            return
        self._logged_at[key], self._logged_count[key] = now, n

    def got(self, topic: str):
        self.received[topic] = self.received.get(topic, 0) + 1

    def put(self, topic: str):
        self.sent[topic] = self.sent.get(topic, 0) + 1

    def report(self):
        # copies: the simulator counts from its stepping thread (a dict copy is atomic)
        received, sent, refused = dict(self.received), dict(self.sent), dict(self.refused)
        total = sum(refused.values())
        values = ([KeyValue(key=f"received {t}", value=str(n)) for t, n in received.items()]
                  + [KeyValue(key=f"sent {t}", value=str(n)) for t, n in sent.items()]
                  + [KeyValue(key=f"refused {t}", value=str(n)) for t, n in refused.items()])
        text = "; ".join(f"{k.key}: {k.value}" for k in values) or "no messages yet"
        level = DiagnosticStatus.WARN if total > self._refused_reported else DiagnosticStatus.OK
        self._refused_reported = total
        msg = DiagnosticArray(status=[DiagnosticStatus(
            level=level, name=self._name, message=text, hardware_id=self._hardware_id,
            values=values)])
        msg.header.stamp = self._clock.now().to_msg()
        self._diagnostics.publish(msg)


def subscribe(node, rejections, msg_type, topic, handler, depth=QOS_DEPTH):
    """A subscription whose messages are counted (``received`` on /diagnostics) before
    ``handler`` takes them. The handler refuses bad input itself; an exception that
    escapes it anyway (a bug) is logged once per type and the node carries on."""
    def callback(msg):
        rejections.got(topic)
        try:
            handler(msg)
        except Exception as exc:  # noqa: BLE001 -- a node never dies on a message
            rejections.once(("bug", topic, type(exc).__name__),
                            f"internal error on a {topic} message (please report): "
                            f"{type(exc).__name__}: {exc}; the node carries on",
                            f"internal error on {{}} more {topic} message(s)")
    return node.create_subscription(msg_type, topic, callback, depth)


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
                       f"{MAX_NAMES} are accepted (the chain has {robot.dof})")
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
                       f"not in the chain {robot.joint_names}")
    missing = [x for x in model if x not in first]
    if missing and require_all:
        raise Rejected("missing joints", f"{what} lacks joints {missing}")
    msg_idx = [i for i, x in enumerate(names) if x in model]
    return np.array(msg_idx, dtype=int), np.array([model[names[i]] for i in msg_idx], dtype=int)


def trajectory_arrays(msg, robot, what, need_increasing_time=False):
    """trajectory_msgs/JointTrajectory -> (t (N,), q, qd, qdd (N, n) in model order,
    have_velocities, have_accelerations). Missing velocities/accelerations are zeros.
    Rejects more than MAX_POINTS points, values beyond +-MAX_VALUE and NaN/Inf."""
    msg_idx, model_idx = name_index(msg.joint_names, robot, what)
    m, n, N = len(msg.joint_names), robot.dof, len(msg.points)
    if N == 0:
        raise Rejected("no points", f"{what} has no points")
    if N > MAX_POINTS:
        raise Rejected("too many points", f"{what} has {N} points; at most {MAX_POINTS} are "
                       "accepted (send a longer trajectory in parts)")
    out = np.zeros((3, N, n))
    have = [True, True, True]
    for k, field in enumerate(("positions", "velocities", "accelerations")):
        sizes = {len(getattr(pt, field)) for pt in msg.points}
        if k > 0 and sizes == {0}:
            have[k] = False
            continue
        if sizes != {m}:
            raise Rejected(f"{field} length", f"{what}: every point needs {m} {field} (one per "
                           f"joint name){'' if k == 0 else ' or none'}; got lengths "
                           f"{_show(sorted(sizes))}")
        vals = np.array([getattr(pt, field) for pt in msg.points], dtype=float)
        if not np.all(np.isfinite(vals)):
            raise Rejected(f"{field} NaN/Inf", f"{what}: {field} contain NaN or Inf")
        if np.any(np.abs(vals) > MAX_VALUE):
            raise Rejected(f"{field} out of range", f"{what}: {field} beyond +-{MAX_VALUE:g} "
                           f"(the bound of every message value): up to "
                           f"{np.max(np.abs(vals)):.3g}")
        out[k][:, model_idx] = vals[:, msg_idx]
    t = np.array([pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec
                  for pt in msg.points])
    if need_increasing_time and (np.any(np.diff(t) <= 0) or t[0] < 0):
        raise Rejected("time_from_start", f"{what}: time_from_start must increase strictly "
                       f"from point to point; got {t.tolist()}")
    return t, out[0], out[1], out[2], have[1], have[2]


def stamp_seconds(stamp) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


# ------------------------------------------------------------------ running a node
def run(node_class, args=None) -> int:
    """Start ``node_class`` and spin it until shutdown (Ctrl-C, SIGTERM). A bad parameter
    or robot prints one paragraph to stderr and returns 2 -- no traceback."""
    name = node_class.NAME
    try:
        rclpy.init(args=sys.argv if args is None else args)
    except Exception as exc:   # e.g. malformed --ros-args
        text = " ".join(str(exc).split())
        print(f"{name}: cannot start: the ROS arguments are not valid: {text}", file=sys.stderr)
        return 2
    node = None
    try:
        node = node_class()
        node.get_logger().info("ready")
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (StartupError, rclpy.exceptions.ParameterException) as exc:
        text = " ".join(str(exc).split())
        print(f"{name}: cannot start: {text}. See docs/ros.md for the parameters.",
              file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
