"""The demo: the simulator and the computed-torque controller, started as separate
processes, track a built-in pick-and-place trajectory; prints the tracking error and the
real-time factor achieved.

    serial-dynamics demo [URDF] [--plot out.png] [--json out.json]
    serial-dynamics demo --scenario collision   # a push during the task: detect, float
                                                # (serial_dynamics.ros.demo_collision)
    python -m serial_dynamics.ros.demo [--attach]    # --attach: use nodes already running
                                                     # (launch/demo.launch.py does this)

The simulator publishes /clock and the controller runs on it (use_sim_time), so the
control loop stays at its rate in simulated time even when the simulation runs slower
than real time; and both run in lockstep (docs/ros.md, "Lockstep"), so that a controller
starved of CPU holds the simulation back instead of falling behind it. The simulation
resumes once the controller has answered its paused state, and the trajectory starts
``session.LEAD`` = 1.5 s (simulated) later.
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

import serial_dynamics as sd
from serial_dynamics.trajectory import pick_and_place

from . import collision as demo_collision
from .session import NOT_FOLLOWED, SETTLE, Session, robot_parameters, run_and_report

SCENARIOS = ("pick_and_place", "collision")
MIN_SPAN = 0.2    # rad (or m): the least height of a joint's position panel in the plot


def run_demo(urdf=None, base_link=None, tip_link=None, real_time_factor=1.0, attach=False,
             log=print):
    """Run the demo; returns a dict of results (raises DemoError when a node fails)."""
    robot = sd.load_urdf(urdf or sd.builtin_path(), base_link, tip_link)
    traj = pick_and_place(robot)
    session = Session(robot, traj, robot_parameters(urdf, base_link, tip_link),
                      real_time_factor, attach, log)
    try:
        t0 = session.start()
        t_end = t0 + traj.duration + SETTLE
        session.run_until(t_end, "the end of the trajectory")
    finally:
        session.close()
    states, procs = session.states, session.procs

    run = [s for s in states if s[1] > 0.0]
    wall = np.array([s[0] for s in run])
    stamp = np.array([s[1] for s in run])
    q = np.array([s[2] for s in run])
    effort = np.array([s[3] for s in run])
    on = (stamp >= t0) & (stamp <= t_end)
    q_ref = traj.sample(stamp - t0)[0]
    err = q - q_ref
    rtf = (stamp[-1] - stamp[0]) / (wall[-1] - wall[0])
    worst = np.max(np.abs(err[on]), axis=0)
    followed = bool(worst.max() <= NOT_FOLLOWED)
    if not followed:
        j = int(np.argmax(worst))
        tails = [(p.module, p.output().strip().splitlines()[-5:]) for p in procs[:2]]
        log(f"warning: the arm did not follow the trajectory ({worst[j]:.3f} rad off on "
            f"{robot.joint_names[j]})" + "".join(
                f"; the {module}'s log ends:" + "".join("\n  " + x for x in tail)
                for module, tail in tails))
    return dict(robot=robot.model.name, joints=robot.joint_names, t0=t0,
                stamp=stamp.tolist(), q=q.tolist(), q_ref=q_ref.tolist(),
                rms=np.sqrt(np.mean(err[on] ** 2, axis=0)).tolist(),
                max=worst.tolist(),
                peak_effort=np.max(np.abs(effort[on]), axis=0).tolist(),
                effort_limit=robot.effort_limit.tolist(), samples=int(on.sum()),
                simulated=float(stamp[-1] - stamp[0]), wall=float(wall[-1] - wall[0]),
                real_time_factor=float(rtf), target_real_time_factor=real_time_factor,
                followed=followed)


def report(r) -> str:
    names = [j.removesuffix("_joint") for j in r["joints"]]
    w = max(12, *(len(x) + 2 for x in names))
    row = lambda label, vals, fmt: f"  {label:<24}" + "".join(f"{fmt(v):>{w}}" for v in vals)  # noqa: E731
    lines = [f"computed-torque tracking of the pick-and-place trajectory on {r['robot']} "
             f"({r['samples']} joint states from the trajectory's start to {SETTLE:g} s after "
             "its end; the hold before it is not counted):",
             row("joint", names, str),
             row("RMS error (mrad)", r["rms"], lambda v: f"{1e3 * v:.3f}"),
             row("max error (mrad)", r["max"], lambda v: f"{1e3 * v:.3f}"),
             row("peak effort (N m)", r["peak_effort"], lambda v: f"{v:.1f}"),
             row("effort limit (N m)", r["effort_limit"], lambda v: f"{v:.0f}"),
             f"real-time factor achieved: {r['real_time_factor']:.2f} (asked "
             f"{r['target_real_time_factor']:g}): {r['simulated']:.2f} s simulated in "
             f"{r['wall']:.2f} s of wall time at sim_dt = 1 ms"]
    return "\n".join(lines)


def plot(r, path):
    """The tracking, one panel per joint (position over its error), written to ``path``:
    desired a wide pale band, actual a thin line on it (about a mrad apart: drawn alike,
    they would hide each other)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch
    t = np.array(r["stamp"]) - r["t0"]
    q, q_ref = np.array(r["q"]), np.array(r["q_ref"])
    n, cols = len(r["joints"]), 2
    rows = -(-n // cols)
    height = 2.9 * rows + 1.0         # inches: the panels, then the title and legend
    fig = plt.figure(figsize=(11, height))
    cells = fig.add_gridspec(rows, cols, hspace=0.35, wspace=0.22)
    first = None
    for j, name in enumerate(r["joints"]):
        cell = cells[j // cols, j % cols].subgridspec(2, 1, height_ratios=(2, 1), hspace=0.08)
        ax = fig.add_subplot(cell[0], sharex=first)
        first = first or ax
        err = fig.add_subplot(cell[1], sharex=first)
        ax.plot(t, q_ref[:, j], color="C1", linewidth=6, alpha=0.35, solid_capstyle="butt")
        ax.plot(t, q[:, j], color="C0", linewidth=1.2)
        lo, hi = ax.get_ylim()        # at least MIN_SPAN: a joint held still looks still
        mid, half = (lo + hi) / 2, max(hi - lo, MIN_SPAN) / 2
        ax.set_ylim(mid - half, mid + half)
        err.axhline(0.0, color="0.6", linewidth=0.6)
        err.plot(t, 1e3 * (q[:, j] - q_ref[:, j]), color="C3", linewidth=1.0)
        for a in (ax, err):
            a.axvspan(t[0], 0.0, color="0.9", zorder=0)       # the hold before the start
        ax.set_title(f"{name}: RMS {1e3 * r['rms'][j]:.2f} mrad, max "
                     f"{1e3 * r['max'][j]:.2f} mrad", fontsize=9)
        ax.set_ylabel("position (rad)", fontsize=8)
        err.set_ylabel("error (mrad)", fontsize=8)
        ax.tick_params(labelbottom=False, labelsize=8)
        err.tick_params(labelsize=8)
        if j + cols >= n:                                       # the bottom of its column
            err.set_xlabel("time from the trajectory start (s, simulated)", fontsize=8)
    fig.legend(handles=[
        plt.Line2D([], [], color="C1", linewidth=6, alpha=0.35, label="desired (the trajectory)"),
        plt.Line2D([], [], color="C0", linewidth=1.2, label="actual (joint_states)"),
        plt.Line2D([], [], color="C3", linewidth=1.0, label="error = actual - desired"),
        Patch(color="0.9", label="hold before the start (not in the table's errors)")],
        loc="upper center", bbox_to_anchor=(0.5, 1 - 0.55 / height), ncol=4,
        fontsize=8, frameon=False)
    fig.suptitle(f"computed-torque control, {r['robot']}: real-time factor "
                 f"{r['real_time_factor']:.2f}", y=1 - 0.2 / height)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.6 / height, top=1 - 1.0 / height)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(args) -> int:
    """Entry point of ``serial-dynamics demo`` (args: urdf, base_link, tip_link and
    optionally plot, json, real_time_factor, attach)."""
    rtf = getattr(args, "real_time_factor", 1.0)
    if not rtf > 0:
        print("serial-dynamics demo: error: the real-time factor must be > 0: the controller "
              "runs in its own process and cannot keep pace with an unpaced simulation",
              file=sys.stderr)
        return 2
    if "ROS_DOMAIN_ID" not in os.environ and not getattr(args, "attach", False):
        # keep the demo's /clock off other ROS graphs on this network
        os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
    if getattr(args, "scenario", "pick_and_place") == "collision":
        return demo_collision.run(args)
    print(f"serial_dynamics demo (ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}): simulator + "
          "computed-torque controller as separate processes", flush=True)
    r, failed = run_and_report(
        lambda: run_demo(args.urdf, args.base_link, args.tip_link, rtf,
                         getattr(args, "attach", False), log=lambda s: print(s, flush=True)),
        report, plot, args)
    if failed:
        return failed
    if getattr(args, "json", None):
        with open(args.json, "w") as fh:
            json.dump({k: v for k, v in r.items() if k not in ("stamp", "q", "q_ref")}, fh,
                      indent=1)
    return 0 if r["followed"] else 1


def add_arguments(p):
    p.add_argument("urdf", nargs="?", default=None, help="URDF path (default: built-in UR5e)")
    p.add_argument("--base-link", default=None)
    p.add_argument("--tip-link", default=None)
    p.add_argument("--plot", metavar="PNG", default=None, help="write a plot of the tracking")
    p.add_argument("--json", metavar="PATH", default=None, help="write the numbers as JSON")
    p.add_argument("--real-time-factor", type=float, default=1.0,
                   help="simulated s per wall s (> 0; default 1)")
    p.add_argument("--scenario", choices=SCENARIOS, default=SCENARIOS[0],
                   help="pick_and_place: track the task (default); collision: push the arm "
                        "during the task, detect it with the observer, float")
    p.add_argument("--attach", action="store_true",
                   help="do not start nodes: use the simulator and controller already running")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m serial_dynamics.ros.demo",
                                     description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
