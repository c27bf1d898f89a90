"""Command line: ``serial-dynamics {info,demo} ...``."""
from __future__ import annotations

import argparse
import sys

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
    from scipy.integrate import solve_ivp
    robot = _load(args)
    cmd_info(args)
    n = robot.dof
    rhs = lambda t, x: np.concatenate([x[n:], robot.forward_dynamics(x[:n], x[n:], np.zeros(n))])  # noqa: E731
    x0 = np.zeros(2 * n)
    sol = solve_ivp(rhs, (0.0, 1.0), x0, method="DOP853", rtol=1e-10, atol=1e-10)
    q, qd = sol.y[:n, -1], sol.y[n:, -1]
    e0, e1 = robot.total_energy(x0[:n], x0[n:]), robot.total_energy(q, qd)
    print(f"1 s free swing from q = 0: q(1 s) = {q}")
    print(f"energy drift over the swing: {abs(e1 - e0):.2e} J ({sol.nfev} evaluations)")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="serial-dynamics", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, fn, help_ in (("info", cmd_info, "print a robot's gravity torques and mass matrix"),
                            ("demo", cmd_demo, "run the main demo on the default robot")):
        p = sub.add_parser(name, help=help_)
        p.add_argument("urdf", nargs="?", default=None, help="URDF path (default: built-in UR5e)")
        p.add_argument("--base-link", default=None)
        p.add_argument("--tip-link", default=None)
        p.set_defaults(func=fn)
        if name == "demo":   # the ROS demo's options (serial_dynamics.ros.demo)
            p.add_argument("--plot", metavar="PNG", default=None, help="write a plot of the tracking")
            p.add_argument("--json", metavar="PATH", default=None, help="write the numbers as JSON")
            p.add_argument("--real-time-factor", type=float, default=1.0,
                           help="simulated s per wall s (0: as fast as possible)")
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, OSError) as exc:   # URDFError, ModelError are ValueErrors
        print(f"serial-dynamics: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
