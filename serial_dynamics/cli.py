"""Command line: serial-dynamics {info,demo,simulate,excite,identify} [URDF] [options];
serial-dynamics sweep SPEC.yaml --out results.parquet."""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np


def _load(args):
    import serial_dynamics as sd
    if args.urdf is None:
        return sd.default_robot()
    return sd.load_urdf(args.urdf, args.base_link, args.tip_link)


def cmd_info(args):
    robot = _load(args)
    q = np.zeros(robot.dof)
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    print(robot)
    if np.any(robot.armature):
        print("armature (reflected rotor inertia, kg m^2):", robot.armature)
    if robot.all_joint_names != robot.joint_names:
        print("every joint (mimic joints follow the independent ones):", robot.all_joint_names)
    if robot.is_planar:
        print("planar chain: computed on the planar fast path")
    print("gravity torques at q = 0 (N m):", robot.gravity_torques(q))
    print("mass matrix at q = 0 (kg m^2):\n", robot.mass_matrix(q))
    return 0


def cmd_demo(args):
    """The main job. With rclpy available: the ROS demo (serial_dynamics.ros.demo.run);
    otherwise an offline look at the robot."""
    try:
        from .ros import demo
    except ImportError:
        demo = None
    if demo is not None and hasattr(demo, "run"):
        return demo.run(args)
    return cmd_offline_demo(args)


def cmd_offline_demo(args):
    from .sim.driver import simulate
    robot = _load(args)
    cmd_info(args)
    res = simulate(robot, 1.0, method="DOP853", rtol=1e-10, atol=1e-10)
    print(f"1 s free swing from q = 0: q(1 s) = {res.q[-1]}")
    print(f"energy drift over the swing: {abs(res.energy[-1] - res.energy[0]):.2e} J "
          f"({res.stats.nfev} evaluations)")
    return 0


def _vector(text, n, name):
    """'0.1,0.2,...' (n values) or a single value for every joint."""
    if text is None:
        return None
    vals = [float(v) for v in text.replace(" ", ",").split(",") if v]
    if len(vals) == 1:
        vals = vals * n
    if len(vals) != n:
        raise ValueError(f"--{name} has {len(vals)} values; give one per joint ({n}) "
                         "or one for all")
    return np.array(vals)


def cmd_simulate(args):
    """Simulate a run, print its statistics and energy balance; --plot, --csv."""
    from .sim.driver import FIXED_STEP, SimulationError, simulate
    robot = _load(args)
    n = robot.dof
    q0 = _vector(args.q0, n, "q0")
    qd0 = _vector(args.qd0, n, "qd0")
    torque = _vector(args.torque, n, "torque")
    kw = dict(method=args.method, dissipation=not args.no_dissipation,
              output_dt=args.output_dt, progress=not args.quiet,
              position_limits=args.position_limits)
    if args.method in FIXED_STEP:
        if args.rtol is not None or args.atol is not None:
            raise ValueError(f"--rtol/--atol are for the adaptive methods; {args.method} "
                             "takes --dt")
        kw["dt"] = args.dt
    else:
        if args.dt is not None:
            raise ValueError(f"--dt is for the fixed-step methods {list(FIXED_STEP)}; "
                             f"{args.method} takes --rtol/--atol")
        kw.update(rtol=args.rtol, atol=args.atol)
    if kw["output_dt"] is None and (args.plot or args.csv):
        kw["output_dt"] = min(0.01, args.duration / 200)
    print(f"{robot}\nsimulating {args.duration:g} s with {args.method}", flush=True)
    try:
        res = simulate(robot, args.duration, q0, qd0, torque, **kw)
    except SimulationError as exc:
        print(f"serial-dynamics: {exc}", file=sys.stderr)
        return 3
    s = res.stats
    np.set_printoptions(precision=5, suppress=True, linewidth=120)
    print(f"{s.steps} steps, {s.nfev} right-hand-side evaluations, {s.njev} Jacobians, "
          f"{s.rejected} rejected, {s.dynamics_states} dynamics states, {s.wall_time:.3f} s wall")
    print(f"q({res.t[-1]:g} s)  = {res.q[-1]}")
    print(f"qd({res.t[-1]:g} s) = {res.qd[-1]}")
    e = res.energy
    print(f"energy: E(0) = {e[0]:.6g} J, E(end) = {e[-1]:.6g} J, actuator work "
          f"{res.work_actuators[-1] + 0.0:.6g} J, dissipated "
          f"{res.energy_dissipated[-1] + 0.0:.6g} J; "
          f"balance error {np.max(np.abs(res.energy_balance_error)):.3g} J "
          f"({res.relative_energy_error():.2e} relative)")
    if args.csv:
        res.to_csv(args.csv)
        print(f"wrote {args.csv}")
    if args.plot:
        res.plot(args.plot, title=f"{robot.model.name}: {args.method}, {args.duration:g} s "
                 f"({s.steps} steps, {s.nfev} evaluations, {s.wall_time:.2f} s wall)")
        print(f"wrote {args.plot}")
    return 0


def _simulate_options(p):
    from .sim.methods import DEFAULT_DT, METHODS
    p.add_argument("--duration", type=float, default=3.0, help="simulated time, s (3)")
    p.add_argument("--method", default="DOP853", choices=METHODS, help="integrator (DOP853)")
    p.add_argument("--dt", type=float, default=None,
                   help=f"step of the fixed-step methods, s ({DEFAULT_DT:g})")
    p.add_argument("--rtol", type=float, default=None, help="adaptive methods (1e-6)")
    p.add_argument("--atol", type=float, default=None, help="adaptive methods (1e-9)")
    p.add_argument("--q0", default=None, help="initial positions, comma separated (0)")
    p.add_argument("--qd0", default=None, help="initial speeds, comma separated (0)")
    p.add_argument("--torque", default=None, help="constant joint torques (0)")
    p.add_argument("--no-dissipation", action="store_true", help="no joint friction")
    p.add_argument("--position-limits", action="store_true",
                   help="hard stops at the URDF joint limits (fixed-step methods)")
    p.add_argument("--output-dt", type=float, default=None,
                   help="output spacing, s (every step; 0.01 with --plot/--csv)")
    p.add_argument("--plot", default=None, metavar="OUT.png", help="plot q, tau and energy")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="write the samples")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def cmd_excite(args):
    """Optimize a Fourier excitation trajectory; write it as CSV (t, q_*, qd_*, qdd_*)."""
    from .identification import excitation
    robot = _load(args)
    print(f"{robot}\noptimizing a {args.duration:g} s excitation ({args.harmonics} harmonics "
          f"per joint, {args.periods} period(s)) for the condition number of the base "
          "regressor", flush=True)

    def progress(iteration, cond):
        if not args.quiet:
            print(f"  iteration {iteration:3d}: condition number {cond:.4g}", flush=True)

    ex = excitation(robot, args.duration, harmonics=args.harmonics, periods=args.periods,
                    friction=not args.no_friction, margin=args.margin, seed=args.seed,
                    maxiter=args.maxiter, progress=progress)
    print(f"condition number {ex.condition_number:.4g} (start {ex.initial_condition_number:.4g})")
    for kind, use in ex.peak.items():
        print(f"peak {kind:<12} use of its limit: " + ", ".join(
            f"{j} {100 * u:.0f}%" for j, u in zip(robot.joint_names, use)))
    ex.to_csv(args.out, dt=args.dt)
    print(f"wrote {args.out} ({int(round(ex.duration / args.dt)) + 1} samples every {args.dt:g} s)")
    return 0


def cmd_identify(args):
    """Identify the base parameters from a recording; summary table; --out URDF, --plot."""
    from .identification import identify, load_recording
    robot = _load(args)
    data = load_recording(args.data, robot.joint_names, args.topic)
    validation = (None if args.validate is None else
                  load_recording(args.validate, robot.joint_names, args.topic))
    print(f"{robot}\nidentifying from {args.data} ({args.method})", flush=True)
    say = (lambda message: None) if args.quiet else (lambda message: print(message, flush=True))
    res = identify(robot, data.t, data.q, data.tau, data.qd, friction=not args.no_friction,
                   method=args.method, cutoff=args.cutoff, decimate=args.decimate,
                   validation=validation, progress=say)   # write_urdf: robot.model.source
    print(res.summary())
    if args.out:
        res.write_urdf(args.out)
        print(f"wrote {args.out}")
    if args.plot:
        res.plot(args.plot)
        print(f"wrote {args.plot}")
    return 0


def cmd_sweep(args):
    from .sweep import spec
    return spec.command(args)


def _builtin_source():
    from .builtin import DEFAULT, builtin_path
    return builtin_path(DEFAULT)


def _identification_options(p, name):
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--no-friction", action="store_true",
                   help="leave out the friction columns (viscous, Coulomb, offset)")
    if name == "excite":
        p.add_argument("--duration", type=float, default=10.0, help="seconds (10)")
        p.add_argument("--harmonics", type=int, default=5, help="per joint (5)")
        p.add_argument("--periods", type=int, default=1, help="repetitions of one period (1)")
        p.add_argument("--margin", type=float, default=0.8,
                       help="fraction of each limit the trajectory may use (0.8)")
        p.add_argument("--maxiter", type=int, default=10, help="optimizer iterations (10)")
        p.add_argument("--seed", type=int, default=0, help="of the starting coefficients (0)")
        p.add_argument("--dt", type=float, default=0.01, help="CSV sample spacing, s (0.01)")
        p.add_argument("--out", required=True, metavar="TRAJ.csv",
                       help="write t, q_*, qd_*, qdd_* here")
        return
    p.add_argument("data", metavar="DATA",
                   help="recording: CSV (t, q_*, qd_*, tau_*) or a ROS 2 bag of JointState")
    p.add_argument("--method", default="wls", choices=("ols", "wls", "physical"),
                   help="least squares, weighted per joint, or physically consistent (wls; "
                   "a fit that is not physical writes the consistent parameters closest to it)")
    p.add_argument("--validate", default=None, metavar="DATA2",
                   help="a second recording to validate the identified model on")
    p.add_argument("--topic", default="/joint_states", help="JointState topic of a bag")
    p.add_argument("--cutoff", type=float, default=None,
                   help="low-pass filter, Hz (a fifth of the sampling rate, at most 10)")
    p.add_argument("--decimate", type=int, default=None,
                   help="keep every k-th filtered sample (down to twice the cutoff)")
    p.add_argument("--out", default=None, metavar="IDENTIFIED.urdf",
                   help="write the URDF with the identified inertials and friction")
    p.add_argument("--plot", default=None, metavar="FIT.png",
                   help="plot measured and identified torques")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="serial-dynamics", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, fn, help_ in (("info", cmd_info, "print a robot's gravity torques and mass matrix"),
                            ("demo", cmd_demo, "run the main demo on the default robot"),
                            ("simulate", cmd_simulate, "simulate the forward dynamics; plot, CSV"),
                            ("excite", cmd_excite, "optimize an excitation trajectory (CSV)"),
                            ("identify", cmd_identify,
                             "identify inertial and friction parameters from a recording")):
        p = sub.add_parser(name, help=help_)
        p.add_argument("urdf", nargs="?", default=None, help="URDF path (default: built-in UR5e)")
        p.add_argument("--base-link", default=None, metavar="LINK",
                       help="first link of the model (default: the URDF root)")
        p.add_argument("--tip-link", default=None, metavar="LINK",
                       help="last link of one chain (default: every movable joint below the "
                            "base: the chain's end followed down fixed links, e.g. tool0, "
                            "or the whole tree where it branches)")
        p.set_defaults(func=fn)
        if name == "demo":   # the ROS demo's options (serial_dynamics.ros.demo)
            p.add_argument("--plot", metavar="PNG", default=None, help="write a plot of the tracking")
            p.add_argument("--json", metavar="PATH", default=None, help="write the numbers as JSON")
            p.add_argument("--real-time-factor", type=float, default=1.0,
                           help="simulated s per wall s (> 0; default 1)")
            p.add_argument("--scenario", choices=("pick_and_place", "collision"),
                           default="pick_and_place",
                           help="pick_and_place: track the task (default); collision: push "
                                "the arm during the task, detect it, float")
        if name == "simulate":
            _simulate_options(p)
        if name in ("excite", "identify"):
            _identification_options(p, name)
    p = sub.add_parser("sweep", help="run a study from a YAML spec on Dask (docs/scale.md)")
    p.add_argument("spec", metavar="SPEC.yaml", help="the study (config/sweep_example.yaml)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:8786",
                   help="a running Dask scheduler (default: local worker processes)")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: one per core)")
    p.add_argument("--out", required=True, metavar="RESULTS.parquet", help="the table")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)
    args = parser.parse_args(argv)
    warnings.showwarning = _warning_line
    try:
        return args.func(args)
    except (ValueError, OSError) as exc:   # URDFError, ModelError are ValueErrors
        print(f"serial-dynamics: error: {exc}", file=sys.stderr)
        return 2


def _warning_line(message, category, filename, lineno, file=None, line=None):
    """A warning (e.g. HeldJointsWarning) as one line, without Python's source line."""
    print(f"serial-dynamics: {category.__name__}: {message}", file=sys.stderr if file is None else file)


if __name__ == "__main__":
    sys.exit(main())
