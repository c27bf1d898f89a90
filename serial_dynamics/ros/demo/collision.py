"""The demo's collision scenario (``serial-dynamics demo --scenario collision``): the arm
tracks the pick-and-place task under computed torque; during the motion the simulator's
tip is pushed by a constant wrench (``external_wrench``, held ``PUSH`` s by the simulator's
``external_wrench_timeout``); the external-torque observer flags the collision; on the
first ``collision`` true this process sets the controller's ``mode`` to
``gravity_compensation`` (its SetParameters service) and the arm floats: it yields to the
push, then the joints' viscous friction brings it to rest.

The joints get viscous friction in the simulator (beta_i = M_ii(q_start) / DAMPING s, the
built-in UR5e has none: without it a floating arm would keep its speed for ever); the
observer knows it (``compensate_dissipation``), the controller does not (its feedback
rejects it while tracking; in gravity compensation it is what stops the arm).

The push starts at an exact simulated instant: the demo pauses the simulation, sends the
wrench, waits until the simulator reports it on /diagnostics, and resumes (paused, nothing
moves: the controller and the observer run on simulated time). The true external torque
is tau_ext = J(q)^T w over (t_push, t_push + PUSH]; the estimate is the observer's.
"""
from __future__ import annotations

import json
import os
import sys
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

import serial_dynamics as sd
from serial_dynamics.trajectory import pick_and_place

from .. import common
from .session import NOT_FOLLOWED, Session, robot_parameters, run_and_report

PUSH_AT = 2.6        # s into the task: 0.3 s into the lift-to-place swing (pan at 1.5 rad/s)
FORCE = 20.0         # N on the tip, against the tip's planned velocity there (an obstacle)
PUSH = 0.2           # s of simulated time the simulator holds the push
FLOAT = 1.2          # s of simulated time recorded after the push
DAMPING = 0.4        # s: viscous friction beta_i = M_ii(q_start) / DAMPING in the simulator
GAIN = 50.0          # 1/s: observer gain (time constant 20 ms)
THRESHOLD = 0.02     # collision threshold per joint: this fraction of its effort limit, >= 1 N m
STARTUP_TRANSIENT = 1.0   # s after the trajectory start before which a flag is not acted on


def push_wrench(robot, traj, at=PUSH_AT, force=FORCE):
    """[f; 0] (base frame, on the tip): ``force`` N against the tip's planned velocity at
    ``at`` s into the task (along -y of the base if the tip is at rest there)."""
    q, qd, _ = (x[0] for x in traj.sample(np.array([at])))
    v = robot.jacobian(q)[:3] @ qd
    u = -v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-6 else np.array([0.0, -1.0, 0.0])
    return np.r_[force * u, 0.0, 0.0, 0.0]


def thresholds(robot):
    return np.maximum(1.0, THRESHOLD * robot.effort_limit)


def run_collision(urdf=None, base_link=None, tip_link=None, real_time_factor=1.0, log=print):
    """Run the scenario; returns a dict of results (raises DemoError when a node fails)."""
    robot = sd.load_urdf(urdf or sd.builtin_path(), base_link, tip_link)
    traj = pick_and_place(robot)
    beta = np.diag(robot.mass_matrix(traj.q[0])) / DAMPING
    theta = thresholds(robot)
    wrench = push_wrench(robot, traj)
    params = robot_parameters(urdf, base_link, tip_link)
    friction = {"dissipation.viscous": beta.tolist()}
    session = Session(robot, traj, params, real_time_factor, False, log,
                      simulator_params={**friction, "external_wrench_timeout": PUSH},
                      nodes=[("external_torque_observer",
                              {**friction, "compensate_dissipation": True, "gain": GAIN,
                               "collision_thresholds": theta.tolist()})])
    node, states = session.node, session.states
    estimates = []                     # (stamp s, r in model order)
    index = {name: j for j, name in enumerate(robot.joint_names)}

    def on_estimate(m):
        r = np.empty(robot.dof)
        r[[index[x] for x in m.name]] = m.effort
        estimates.append((common.stamp_seconds(m.header.stamp), r))
    node.create_subscription(JointState, "estimated_external_torques", on_estimate,
                             common.QOS_DEPTH)
    reported = []                      # the simulator's "external wrench" on /diagnostics
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: reported.extend(
        kv.value for st in m.status for kv in st.values if kv.key == "external wrench"),
        common.QOS_DEPTH)
    wrench_pub = node.create_publisher(WrenchStamped, "external_wrench", common.QOS_DEPTH)
    set_params = node.create_client(SetParameters, "computed_torque_controller/set_parameters")
    reaction = {}                      # what the demo saw and did

    def on_collision(m):
        armed = estimates and estimates[-1][0] >= reaction.get("armed", np.inf)
        if m.data and armed and "flag" not in reaction:
            reaction["flag"] = estimates[-1][0]       # the latest estimate's stamp
            value = ParameterValue(type=ParameterType.PARAMETER_STRING,
                                   string_value="gravity_compensation")
            future = set_params.call_async(SetParameters.Request(
                parameters=[Parameter(name="mode", value=value)]))
            future.add_done_callback(lambda f: reaction.update(
                reply=f.result().results[0], reply_stamp=states[-1][1]))
    node.create_subscription(Bool, "collision", on_collision, common.QOS_DEPTH)

    try:
        t0 = session.start(ready=lambda: wrench_pub.get_subscription_count() > 0
                           and node.count_publishers("collision") > 0
                           and set_params.service_is_ready())
        reaction["armed"] = t0 + STARTUP_TRANSIENT
        # pause a little before the push, put the wrench on, resume: it acts from the
        # paused instant on, for PUSH s (external_wrench_timeout)
        session.run_until(t0 + PUSH_AT - 0.015, "the push")
        session.call(session.pause, SetBool.Request(data=True), "the simulator to pause")
        session.spin_until(lambda: len(states) > 3 and states[-1][1] == states[-2][1]
                           == states[-3][1], 10.0, "a paused joint state")
        t_push = states[-1][1]
        msg = WrenchStamped()
        msg.header.frame_id = robot.base_link
        f, m = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, m.x, m.y, m.z = wrench.tolist()
        while True:      # until the simulator reports it (copies change nothing)
            wrench_pub.publish(msg)
            reported.clear()
            until = time.monotonic() + 1.5          # /diagnostics comes every 1 s
            session.spin_until(lambda: reported or time.monotonic() > until, 10.0,
                               "the simulator's report of the wrench")
            if any(x != "none" for x in reported):
                break
        session.call(session.pause, SetBool.Request(data=False), "the simulator to resume")
        session.run_until(t_push + PUSH + FLOAT, "the end of the scenario")
        session.spin_until(lambda: "reply" in reaction or "flag" not in reaction, 10.0,
                           "the controller's answer")
    finally:
        session.close()
    return analyse(robot, traj, session, estimates, reaction, t0, t_push, wrench, theta, beta)


def analyse(robot, traj, session, estimates, reaction, t0, t_push, wrench, theta, beta):
    states = []
    for s in session.states:                      # drop the copies published while paused
        if s[1] > 0.0 and (not states or s[1] > states[-1][1]):
            states.append(s)
    stamp = np.array([s[1] for s in states])
    q, effort, qd = (np.array([s[k] for s in states]) for k in (2, 3, 4))
    est_t = np.array([e[0] for e in estimates])
    keep = np.r_[True, np.diff(est_t) > 0] & (est_t > 0)
    est_t, est = est_t[keep], np.array([e[1] for e in estimates])[keep]
    t_end = t_push + PUSH
    pushed = lambda t: (t > t_push + 1e-9) & (t <= t_end + 1e-9)     # noqa: E731
    true = np.array([robot.jacobian(x).T @ wrench for x in q]) * pushed(stamp)[:, None]
    # detection: the first estimate beyond a threshold after the start-up transient (the
    # observer's own rule, applied to what it published)
    over = np.flatnonzero((est_t >= t0 + STARTUP_TRANSIENT) & np.any(np.abs(est) > theta, axis=1))
    t_detect = float(est_t[over[0]]) if over.size else None
    # the switch as the plant felt it: the first state whose applied effort is g(q) of one
    # of the five states before it (the controller's law in gravity_compensation)
    g = np.array([robot.gravity_torques(x) for x in q])
    t_switch = None
    for k in range(5, len(stamp)):
        if t_detect is not None and stamp[k] >= t_detect and any(
                np.allclose(effort[k], g[k - i], rtol=1e-9, atol=1e-9) for i in range(6)):
            t_switch = float(stamp[k])
            break
    # the estimate and the truth at the last sample of the push
    k_end = int(np.flatnonzero(stamp <= t_end + 1e-9)[-1])
    e_end = int(np.flatnonzero(est_t <= stamp[k_end] + 1e-9)[-1])
    during = pushed(stamp)
    speed = np.array([np.linalg.norm(robot.jacobian(x)[:3] @ v) for x, v in zip(q, qd)])
    energy = np.array([robot.kinetic_energy(x, v) for x, v in zip(q, qd)])
    after = stamp > t_end + 1e-9
    before = (stamp >= t0) & (stamp < t_push)
    err = q[before] - traj.sample(stamp[before] - t0)[0]
    tip = lambda k: robot.forward_kinematics(q[k])[:3, 3]     # noqa: E731
    k_sw = int(np.searchsorted(stamp, t_switch)) if t_switch is not None else k_end
    reply = reaction.get("reply")
    return dict(
        robot=robot.model.name, joints=robot.joint_names, t0=t0, t_push=t_push, push=PUSH,
        wrench=wrench.tolist(), gain=GAIN, thresholds=theta.tolist(), viscous=beta.tolist(),
        t_detect=t_detect, t_flag=reaction.get("flag"), t_switch=t_switch,
        t_reply=reaction.get("reply_stamp"),
        switched=bool(reply is not None and reply.successful),
        detection_delay=None if t_detect is None else t_detect - t_push,
        true_max=np.max(np.abs(true[during]), axis=0).tolist(),
        estimate_max=np.max(np.abs(est[pushed(est_t)]), axis=0).tolist(),
        t_end_sample=float(stamp[k_end]), true_end=true[k_end].tolist(),
        estimate_end=est[e_end].tolist(),
        tracking_max_before=np.max(np.abs(err), axis=0).tolist(),
        tip_speed_at_switch=float(speed[k_sw]), tip_speed_max_push=float(speed[during].max()),
        tip_speed_max_after=float(speed[after].max()), tip_speed_end=float(speed[-1]),
        energy_max_after=float(energy[after].max()), energy_end=float(energy[-1]),
        tip_moved=float(np.linalg.norm(tip(-1) - tip(k_sw))),
        followed=bool(np.max(np.abs(err)) <= NOT_FOLLOWED),
        stamp=stamp.tolist(), q=q.tolist(), qd=qd.tolist(), effort=effort.tolist(),
        true=true.tolist(), estimate_stamp=est_t.tolist(), estimate=est.tolist())


def report(r) -> str:
    names = [j.removesuffix("_joint") for j in r["joints"]]
    w = max(12, *(len(x) + 2 for x in names))
    row = lambda label, vals, fmt: f"  {label:<30}" + "".join(f"{fmt(v):>{w}}" for v in vals)  # noqa: E731
    f = r["wrench"][:3]
    t = lambda x: "never" if x is None else f"{x - r['t0']:.3f} s"     # noqa: E731
    lines = [f"collision during the pick-and-place task on {r['robot']}: a push of "
             f"{np.linalg.norm(f):.0f} N on the tip (base frame [{f[0]:.1f}, {f[1]:.1f}, "
             f"{f[2]:.1f}] N) from {t(r['t_push'])} to {t(r['t_push'] + r['push'])} of the task "
             "(simulated time)",
             f"  observer: gain {r['gain']:g} 1/s, thresholds "
             + ", ".join(f"{x:g}" for x in r["thresholds"]) + " N m",
             "  no collision detected" if r["t_detect"] is None else
             f"  collision detected at {t(r['t_detect'])}: "
             f"{1e3 * r['detection_delay']:.0f} ms after the push started",
             f"  controller in gravity_compensation from {t(r['t_switch'])} (the first command "
             f"that is g(q)); mode set {'successfully' if r['switched'] else 'WITHOUT success'}",
             row("joint", names, str),
             row("largest true tau_ext (N m)", r["true_max"], lambda v: f"{v:.2f}"),
             row("largest estimate (N m)", r["estimate_max"], lambda v: f"{v:.2f}"),
             row("true at the push's end", r["true_end"], lambda v: f"{v:.2f}"),
             row("estimate at the push's end", r["estimate_end"], lambda v: f"{v:.2f}"),
             row("tracking error before (mrad)", r["tracking_max_before"],
                 lambda v: f"{1e3 * v:.1f}"),
             f"  the arm floats: tip speed {r['tip_speed_at_switch']:.2f} m/s at the switch, "
             f"up to {r['tip_speed_max_push']:.2f} under the push, at most "
             f"{r['tip_speed_max_after']:.2f} after it and {r['tip_speed_end']:.3f} at the end "
             f"({r['tip_moved'] * 100:.0f} cm from where it was at the switch);",
             f"  kinetic energy at most {r['energy_max_after']:.3f} J after the push, "
             f"{r['energy_end']:.4f} J at the end: the joints' friction stops it, nothing "
             "pulls it back to the task"]
    return "\n".join(lines)


def plot(r, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = np.array(r["stamp"]) - r["t0"]
    te = np.array(r["estimate_stamp"]) - r["t0"]
    true, est = np.array(r["true"]), np.array(r["estimate"])
    n = len(r["joints"])
    cols = 3 if n > 4 else 2
    fig, axes = plt.subplots(-(-n // cols), cols, figsize=(11, 6), sharex=True, squeeze=False)
    lo, hi = r["t_push"] - r["t0"] - 0.2, t[-1]
    for j, ax in enumerate(axes.flat):
        if j >= n:
            ax.axis("off")
            continue
        sel, sel_e = (t >= lo) & (t <= hi), (te >= lo) & (te <= hi)
        ax.step(t[sel], true[sel, j], where="pre", color="k", label="true Jᵀw")
        ax.plot(te[sel_e], est[sel_e, j], color="C1", label="observer estimate")
        ax.axvspan(r["t_push"] - r["t0"], r["t_push"] + r["push"] - r["t0"], color="0.9", zorder=0)
        for x, style, label in ((r["t_detect"], "C3--", "detected"), (r["t_switch"], "C2:", "switched")):
            if x is not None:
                ax.axvline(x - r["t0"], color=style[:2], linestyle=style[2:], label=label)
        ax.set_title(r["joints"][j], fontsize=9)
        ax.set_ylabel("N m")
    axes.flat[0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time into the task (s, simulated); grey: the push")
    fig.suptitle(f"collision on {r['robot']}: external joint torque, true and estimated")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args) -> int:
    """``serial-dynamics demo --scenario collision`` (from ``demo.run``, which has checked
    the real-time factor and chosen the ROS domain)."""
    if getattr(args, "attach", False):
        print("serial-dynamics demo: error: --scenario collision starts its own nodes (the "
              "simulator needs friction, the observer its thresholds); drop --attach",
              file=sys.stderr)
        return 2
    print(f"serial_dynamics demo, collision scenario (ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}):"
          " simulator + computed-torque controller + external-torque observer as separate "
          "processes", flush=True)
    r, failed = run_and_report(
        lambda: run_collision(args.urdf, args.base_link, args.tip_link,
                              getattr(args, "real_time_factor", 1.0),
                              log=lambda s: print(s, flush=True)),
        report, plot, args)
    if failed:
        return failed
    if getattr(args, "json", None):
        with open(args.json, "w") as fh:
            json.dump(r, fh, indent=None)
    ok = r["followed"] and r["switched"] and r["detection_delay"] is not None \
        and r["detection_delay"] > 0
    if not ok:
        print("serial-dynamics demo: the collision was not " + ("detected" if r["t_detect"] is
              None else "reacted to as planned (see above)"), file=sys.stderr)
    return 0 if ok else 1
