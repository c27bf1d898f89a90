"""The simulator's parameters, without a node: the table (``PARAMETERS``: name -> (type,
default, description), ``RANGES``), their checks at start-up and the ``sim.session.Session``
they make (``session``), with the lines the node logs about them.
"""
from __future__ import annotations

import numpy as np

from serial_dynamics.contacts import Contact, Ground
from serial_dynamics.contacts.stepper import GroundSession
from serial_dynamics.sim.session import TIMEOUT_ACTIONS, Session, has_base

from ..loops.simulator import dt_ns
from ..model.links import link_problem
from . import floating_state, parameters

PARAMETERS = {
    **parameters.ROBOT_PARAMETERS,
    "initial_positions": ("double[]", None, "joint positions at start and after ~/reset "
                          "(rad; m), base to tip ([] = zeros)"),
    "dissipation.enabled": ("bool", True, "add the joint dissipation (friction) torques"),
    "position_limits": ("bool", True, "hard stops at the URDF joint limits (a joint that "
                        "reaches one stops there: plastic impact)"),
    "integrator": ("string", "semi_implicit_euler", "fixed-step method of "
                   "serial_dynamics.sim.fixed_step.FixedStepIntegrator: semi_implicit_euler, "
                   "symplectic_euler, rk4 or implicit_midpoint"),
    "sim_dt": ("double", 0.001, "integration step (s)"),
    "real_time_factor": ("double", 1.0, "simulated s per wall-clock s; 0 = as fast as possible"),
    "publish_rate": ("double", 100.0, "joint_states rate (Hz of simulated time)"),
    "publish_clock": ("bool", False, "publish /clock (simulated time, starting at 0) and "
                      "stamp joint_states with it, for nodes with use_sim_time"),
    "clock_rate": ("double", 1000.0, "/clock rate (Hz of simulated time) when publish_clock"),
    "command_timeout": ("double", 0.5, "s of simulated time without a command after which "
                        "command_timeout_action acts; 0 = hold the last command forever"),
    "command_timeout_action": ("string", "brake", "what a lost command stream does: brake "
                               "(the joint servo holds the positions at the timeout, within "
                               "the effort limits, until a command comes; as a real arm) or "
                               f"limp (effort back to zero): {', '.join(TIMEOUT_ACTIONS)}"),
    "lockstep": ("int", 0, "with publish_clock and commands stamped with the joint state "
                 "they answer (joint_commands; the controller's lockstep): steps of sim_dt "
                 "the simulation runs past its latest joint_states before the answer "
                 "arrives; unstamped commands: past the last command. 0 = never waits "
                 "(free-running). From the first command on"),
    "lockstep_timeout": ("double", 2.0, "s of wall time a lockstep wait lasts at most; then "
                         "the simulation runs free until the next command (one warning)"),
    "clamp_effort": ("bool", True, "clamp commanded effort to the effort limits"),
    "effort_limits": ("double[]", None, "effort limits (N m; N), one or one per joint "
                      "([] = the URDF's <limit effort>; .inf = none)"),
    "start_paused": ("bool", False, "start paused (resume with ~/pause false)"),
    "step_count": ("int", 1, "steps advanced by one ~/step call (while paused)"),
    "external_wrench_timeout": ("double", 0.0, "s of simulated time after which an "
                                "external_wrench is dropped; 0 = held until replaced"),
    "servo.kp": ("double[]", [10000.0], "joint servo stiffness (N m/rad; N/m), one or one per "
                 "joint, for joint_commands with position targets"),
    "servo.kd": ("double[]", [200.0], "joint servo damping (N m s/rad; N s/m), one or one per "
                 "joint, for joint_commands with position and/or velocity targets"),
    **parameters.PAYLOAD_PARAMETERS,
    "floating_base": ("bool", False, "the base link floats free (FloatingRobot): the "
                      "base pose on odom (nav_msgs/Odometry), ~/set_base_state; the joint "
                      "servo with semi_implicit_euler only"),
    "initial_base_pose": ("double[]", floating_state.IDENTITY, "floating_base: the base pose "
                          "at start and after ~/reset, [x, y, z, qx, qy, qz, qw] in odom_frame "
                          "(the quaternion is normalized)"),
    "odom_frame": ("string", "odom", "floating_base: header.frame_id of odom (the world)"),
    "contacts": ("string[]", [], "points that touch the ground: link names (each link's "
                 "frame origin), or [collision] (the URDF's <collision> sphere centres and "
                 "box corners); their forces on ~/contacts/<name>. [] = none: nothing "
                 "touches the ground (a fixed-base arm's default)"),
    "ground.enabled": ("bool", True, "a ground plane under the contacts (it acts only where "
                       "contacts are given; false: they touch nothing)"),
    "ground.height": ("double", 0.0, "the plane n . p = height (m), world axes: odom_frame on "
                      "a floating base, the base link's frame on a fixed one"),
    "ground.normal": ("double[]", [0.0, 0.0, 1.0], "the plane's upward normal n (normalized; "
                      "not zero), world axes"),
    "ground.friction": ("double", 1.0, "Coulomb friction coefficient mu of the contacts on "
                        "the ground (> 0)"),
    "ground.restitution": ("double", 0.0, "share of a contact's approach speed sent back at "
                           "an impact, [0, 1] (0: plastic)"),
}
# parameter ranges (ParameterDescriptor; inclusive, so only those that include their ends)
RANGES = {"real_time_factor": (0.0, 1e6), "command_timeout": (0.0, 1e9),
          "external_wrench_timeout": (0.0, 1e9), "step_count": (1, 10 ** 9),
          "lockstep": (0, 10 ** 9), "lockstep_timeout": (0.0, 1e9),
          "ground.restitution": (0.0, 1.0)}


COARSE_DT = 0.01   # s; a larger sim_dt is warned about (an arm needs steps of about 1 ms)


def check_initial_positions(robot, q0, given):
    """ValueError when a joint of ``q0`` is outside its limits, with positions that fit."""
    outside = np.flatnonzero((q0 < robot.lower) | (q0 > robot.upper))
    if outside.size:
        j, lo, hi = outside[0], robot.lower, robot.upper
        middle, bounded = np.clip(0.0, lo, hi), np.isfinite(lo) & np.isfinite(hi)
        middle[bounded] = (lo[bounded] + hi[bounded]) / 2
        example = ", ".join(f"{x:.4f}" for x in middle)
        raise ValueError(
            f"initial_positions{'' if given else ' (not set: zeros)'}: {robot.joint_names[j]} = "
            f"{q0[j]} is outside its limits [{lo[j]}, {hi[j]}]; give positions within the "
            f"limits, e.g. the middle of each range: -p initial_positions:=[{example}]")


def ground_contacts(robot, p: dict):
    """(``sd.Ground``, [``sd.Contact``], notes) of the ``ground.*`` and ``contacts``
    parameters; (None, [], notes) when nothing touches the ground. ValueError naming the
    parameter and the fix."""
    names = p["contacts"]
    if not names:
        return None, [], []
    if not p["ground.enabled"]:
        return None, [], [("warning", f"contacts {names} given but ground.enabled is false: "
                           "they touch nothing (the robot falls freely)")]
    if "collision" in names:
        if names != ["collision"]:
            raise ValueError(f"parameter 'contacts' = {names}: give [collision] alone (the "
                             "URDF's <collision> spheres and boxes) or link names")
        contacts = robot.contact_points()
        if not contacts:
            raise ValueError("parameter 'contacts' = [collision], but the URDF has no "
                             "<collision> sphere or box on a link of the model (meshes are "
                             "not read); name the links that touch the ground instead, e.g. "
                             "-p contacts:=[FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT]")
    else:
        for i, name in enumerate(names):
            problem = link_problem(robot.model, name)
            if problem is not None:
                raise ValueError(f"parameter 'contacts' [{i}]: {problem}; name links of the "
                                 "model (or give [collision])")
            if name in names[:i]:
                raise ValueError(f"parameter 'contacts' names {name!r} twice; name each "
                                 "link once")
        contacts = [Contact(name) for name in names]
    if not 0 < p["ground.friction"] < np.inf:
        raise ValueError(f"parameter 'ground.friction' must be > 0 (Coulomb's coefficient, "
                         f"e.g. 1.0), got {p['ground.friction']}")
    normal = np.array(p["ground.normal"] or [], dtype=float)
    if normal.shape != (3,) or not np.all(np.isfinite(normal)) or not np.any(normal):
        raise ValueError(f"parameter 'ground.normal' must be 3 numbers, not all zero (the "
                         f"plane's upward direction, world axes), e.g. [0.0, 0.0, 1.0]; got "
                         f"{p['ground.normal']}")
    if p["integrator"] != "semi_implicit_euler":
        raise ValueError(f"parameter 'integrator' is {p['integrator']!r}: contacts with the "
                         "ground are stepped by semi-implicit Euler; give "
                         "-p integrator:=semi_implicit_euler (or no contacts)")
    ground = Ground(p["ground.height"], tuple(normal), p["ground.friction"],
                    p["ground.restitution"])
    return ground, contacts, [("info", f"{len(contacts)} contacts on the ground (height "
                               f"{ground.height:g} m, normal {list(ground.normal)}, friction "
                               f"{ground.friction:g}): their forces on ~/contacts/<name>")]


def session(robot, p: dict):
    """(the ``Session`` of ``robot`` under the parameter values ``p``, the notes to log as
    (level, text)). ``StartupError`` or ``ValueError`` naming a bad parameter."""
    q0 = parameters.per_joint("initial_positions", p["initial_positions"], robot,
                              np.zeros(robot.dof))
    check_initial_positions(robot, q0, p["initial_positions"])
    limit = parameters.per_joint("effort_limits", p["effort_limits"], robot,
                                 robot.effort_limit, positive=True)
    for name in ("sim_dt", "publish_rate", "clock_rate"):
        if not 0 < p[name] < np.inf:
            raise ValueError(f"parameter {name!r} must be > 0, got {p[name]}")
    kp, kd = (parameters.per_joint(f"servo.{x}", p[f"servo.{x}"], robot, None, positive=True)
              for x in ("kp", "kd"))
    if not (np.all(np.isfinite(kp)) and np.all(np.isfinite(kd))):
        raise ValueError("parameters 'servo.kp' and 'servo.kd' must be finite")
    notes = []
    if p["sim_dt"] > COARSE_DT:
        notes.append(("warning", f"sim_dt = {p['sim_dt']} s is a coarse step (above "
                      f"{COARSE_DT} s): an arm needs about 0.001 s (the default) to be "
                      "simulated faithfully; was sim_dt:=0.001 meant?"))
    floating = has_base(robot)
    pose = floating_state.initial_pose(p["initial_base_pose"]) if floating else None
    ground, contacts, ground_notes = ground_contacts(robot, p)
    notes += ground_notes
    kind, more = ((GroundSession, dict(ground=ground, contacts=contacts)) if contacts
                  else (Session, dict(integrator=p["integrator"])))
    out = kind(robot, q0, base_pose=pose, dt=dt_ns(p) * 1e-9,
               dissipation=p["dissipation.enabled"], position_limits=p["position_limits"],
               effort_limits=limit if p["clamp_effort"] else None, servo_kp=kp,
               servo_kd=kd, command_timeout=p["command_timeout"],
               command_timeout_action=p["command_timeout_action"],
               wrench_timeout=p["external_wrench_timeout"], paused=p["start_paused"], **more)
    if out.timeout_action != p["command_timeout_action"]:
        notes.append(("warning", "command_timeout_action 'brake' needs the joint servo "
                      f"(integrator {' or '.join(out.integrator.SERVO_METHODS)}): the arm "
                      "goes limp at the timeout"))
    return out, notes
