"""What every node shares about parameters: declaring them (typed, described, read-only
except the payload), the robot loading rule (urdf_path, robot_description, the topic, the
embedded UR5e) with its dissipation, and the payload parameters applied at run time.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

import serial_dynamics as sd

from .throttle import Throttle

# robot_state_publisher (Jazzy) publishes robot_description reliable + transient local.
DESCRIPTION_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)


class StartupError(Exception):
    """A bad parameter or robot at start-up: the node prints one paragraph and exits."""


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
    "base_link": ("string", "", "first link of the model ('' = the URDF root)"),
    "tip_link": ("string", "", "last link of one chain ('' = every movable joint below "
                                "base_link: a chain's end, or the whole tree)"),
    "gravity": ("double[]", [0.0, 0.0, -9.81], "gravity in the URDF root frame (m/s^2)"),
    "repair_inertia": ("bool", False, "a body whose inertia is no rigid body's (links joined "
                       "by fixed joints lumped) gets the nearest physical one, with a warning "
                       "naming it (false: the robot is refused)"),
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
USE_SIM_TIME = "use_sim_time"
USE_SIM_TIME_TEXT = ("run on /clock (simulated time) instead of the system clock; "
                     "read-only: give it at start-up (-p use_sim_time:=true)")


def declare(node, spec: dict, ranges: dict | None = None) -> dict:
    """Declare every parameter of ``spec`` (with its description; read-only unless in
    ``WRITABLE``; ``ranges``: name -> (lowest, highest), inclusive, in its descriptor) and
    return their values, checked and converted. Raises StartupError naming the parameter.
    rclpy enforces a descriptor's range on a double (and an integer on an integer); a
    number of the other kind (``-p real_time_factor:=-1``) is checked here. Also makes rclpy's own ``use_sim_time`` read-only (set while
    running, a node without /clock would stop): give it at start-up."""
    node.set_descriptor(USE_SIM_TIME, ParameterDescriptor(
        description=USE_SIM_TIME_TEXT, read_only=True, type=ParameterType.PARAMETER_BOOL))
    values = {}
    for name, (kind, default, text) in spec.items():
        descriptor = ParameterDescriptor(description=text, dynamic_typing=True,
                                         read_only=name not in WRITABLE)
        lo, hi = (ranges or {}).get(name, (None, None))
        if kind == "double" and lo is not None:
            descriptor.floating_point_range = [FloatingPointRange(from_value=lo, to_value=hi)]
        elif kind == "int" and lo is not None:
            descriptor.integer_range = [IntegerRange(from_value=lo, to_value=hi, step=1)]
        node.declare_parameter(name, default, descriptor)
        values[name] = _coerce(name, kind, node.get_parameter(name).value)
        if lo is not None and not lo <= values[name] <= hi:
            raise StartupError(f"parameter {name!r} = {values[name]} is out of its range "
                               f"[{lo:g}, {hi:g}]")
    # given (-p, --params-file) but not a parameter of this node: a typo or the wrong node.
    unknown = sorted(x for x in _overrides(node) if not node.has_parameter(x))
    if unknown:
        node.get_logger().warning(
            f"ignoring unknown parameter(s) {unknown}: {node.get_name()} takes "
            f"{', '.join(spec)} (and use_sim_time)")
    return values


def _overrides(node):
    """Names of the parameters given to ``node`` (``-p``, ``--params-file``, the
    ``parameter_overrides`` argument), declared or not.

    rclpy 7.1 (Jazzy) has no public way to list them: ``Node.__init__`` reads them from its
    private C handle into the private ``_parameter_overrides``, which is read here (an empty
    dict if a later rclpy renames it: the check is then skipped, nothing else changes).
    The public options do not serve: ``allow_undeclared_parameters`` only lets *sets* of
    undeclared names through, and ``get_parameters_by_prefix`` / ``list_parameters`` see
    declared parameters only; ``automatically_declare_parameters_from_overrides`` declares
    every override at construction, writable and undescribed, so that each node's
    constructor would have to pass it and ``declare`` would have to undeclare and declare
    again every parameter of its spec (``declare_parameter`` raises
    ParameterAlreadyDeclaredException on a declared name) to give it its type, description
    and read-only flag -- and undeclare the unknown ones, which would otherwise stay settable.
    """
    return getattr(node, "_parameter_overrides", {})


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
    base_link, tip_link, gravity, repair_inertia and the dissipation overrides; raises
    StartupError (the loader's warnings, each repaired body's among them, are logged)."""
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
            robot = sd.load_urdf(source, base, tip, tuple(g),
                                 floating_base=bool(p.get("floating_base", False)),
                                 repair_inertia=bool(p.get("repair_inertia", False)))
        except (ValueError, OSError) as exc:   # URDFError and ModelError are ValueErrors
            raise StartupError(f"cannot load the robot from {where}: {exc}") from None
    for w in caught:
        node.get_logger().warning(str(w.message))
    robot.dissipation = _dissipation(robot, p)
    node.get_logger().info(f"loaded {robot!r} from {where}")     # its repr names its kind
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
                           f"joints of the model {robot.joint_names}")
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
    refused = Throttle(log.warning)        # a storm of bad sets: a few lines, with counts
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
            names = sorted(new)
            refused(("payload", *names), f"rejected payload parameters {new}: {exc}; the "
                    "payload in force stays", f"rejected {{}} more sets of {names} since")
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
