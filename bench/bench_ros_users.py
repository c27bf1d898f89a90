"""What ROS users ask next: the cost of the dynamics node's ~/estimate_payload and
~/time_parameterize and ~/task_space calls (round trip from a client node, p50 and p99, with ~/inverse_dynamics
as the baseline in the same run), the time-parameterization's cost and result against its
grid size (our batched path torques against toppra's own JointTorqueConstraint, which calls
inverse dynamics point by point, both on the library's stretches between corners), TOPP-RA
against the textbook's minimum-time maneuver (shared/reference section E), and the task-space
calls.

    python bench/bench_ros_users.py [--calls 30]

Writes the "ros_users" section of bench/BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
os.environ.setdefault("ROS_DOMAIN_ID", str(90 + os.getpid() % 60))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import serial_dynamics as sd  # noqa: E402
from serial_dynamics import identification as ident  # noqa: E402
from serial_dynamics import trajectory as tj  # noqa: E402

from _report import stamp, write_section  # noqa: E402

HOME = np.array([0.0, -1.571, 1.571, -1.571, -1.571, 0.0])
PATH = np.array([w for _, w in tj.UR5E_PICK_AND_PLACE])
PATH = PATH[np.r_[True, np.any(np.diff(PATH, axis=0) != 0, axis=1)]]
EFFORT = np.array([60.0, 90.0, 45.0, 12.0, 12.0, 12.0])
Q0 = np.array([0.0, -1.5, 1.0, -1.0, 0.5, 0.0])
Q1 = Q0 + np.array([1.5, 0.8, -1.2, 0.7, -0.9, 2.0])


def best(fn, repeat=3):
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return min(out)


def load_note(start, end):
    """The sentence on the machine's load during the run (1-minute load averages)."""
    cores = os.cpu_count()
    said = f"{cores} cores; load average {start:.1f} at the start, {end:.1f} at the end"
    if max(start, end) < 0.5 * cores:
        return f"The machine was lightly loaded ({said})."
    return (f"The machine was shared with other developers' test runs ({said}): treat the "
            "figures as upper bounds, the p99s above all.")


def topp_vs_grid():
    """Ours and toppra's own JointTorqueConstraint on the same geometric path: the library's
    stretches between corners (``split_path``), each the same toppra spline by chord length
    (``run_geometry``) on the same grid points (``run_grid``), timed rest to rest under the
    same effort and velocity limits; the peer's duration is the sum over the stretches."""
    import toppra as ta
    from toppra import algorithm, constraint

    from serial_dynamics.trajectory import time_parameterization as tp
    robot = sd.default_robot().with_payload(2.0, (0, 0, 0.05))
    ours_call = lambda grid: tj.time_parameterize(robot, PATH, effort_limit=EFFORT,  # noqa: E731
                                                  grid=grid, dissipation=False)
    ours_call(50)      # first: the library routes toppra's log records to DEBUG (none printed)
    torque = constraint.JointTorqueConstraint(
        robot.inverse_dynamics, np.column_stack([-EFFORT, EFFORT]), np.zeros(6),
        discretization_scheme=constraint.DiscretizationType.Interpolation)
    speed = constraint.JointVelocityConstraint(np.column_stack([-robot.velocity_limit,
                                                                robot.velocity_limit]))

    def peer(grid):     # toppra's own torque constraint: inverse dynamics point by point
        runs = tp.split_path(PATH)              # the library's stretches between corners
        length = [np.sum(np.linalg.norm(np.diff(PATH[idx], axis=0), axis=1)) for idx in runs]
        total = 0.0
        for idx, L in zip(runs, length):
            spline, ss = tp.run_geometry(ta, PATH[idx])     # the same spline by chord length
            # the library's share of the grid: in proportion to the chord length, at least
            # MIN_INTERVALS (as in time_parameterization.solve), the vertices on it
            s = tp.run_grid(ss, max(tp.MIN_INTERVALS, round(grid * L / sum(length))))
            inst = algorithm.TOPPRA([speed, torque], spline, gridpoints=s)
            total += inst.compute_trajectory(0, 0).duration     # rest to rest
        return total

    rows = []
    for grid in (50, 100, 200, 400, 800, 1600):
        w = ours_call(grid)
        ours = best(lambda: ours_call(grid), repeat=5)
        duration = peer(grid)
        theirs = best(lambda: peer(grid), repeat=5)
        rows.append((grid, ours, theirs, w.duration, duration, w.stretch))
    return rows, [len(idx) for idx in tp.split_path(PATH)]


def textbook():
    out = []
    for gravity in ((0, 0, 0), (0, 0, -9.81)):
        robot = sd.default_robot(gravity=gravity)
        book = tj.minimum_time(robot, Q0, Q1, "cycloidal", gravity=any(gravity),
                               dissipation=False, velocity=False)
        for grid in (100, 400):
            w = tj.time_parameterize(robot, np.array([Q0, Q1]), velocity_limit=np.inf,
                                     dissipation=False, grid=grid)
            out.append((any(gravity), grid, book.T, w.duration))
    return out


def task_space():
    robot = sd.default_robot()
    q, qd = robot.random_state(0)
    qdd = np.ones(6)
    Q, QD = robot.random_state(1, batch=1000)
    calls = {"frame_acceleration": lambda: robot.frame_acceleration(q, qd, qdd),
             "jacobian_dot_qd": lambda: robot.jacobian_dot_qd(q, qd),
             "operational_space_inertia": lambda: robot.operational_space_inertia(q),
             "dynamically_consistent_inverse": lambda: robot.dynamically_consistent_inverse(q),
             "jacobian (peer: the existing call)": lambda: robot.jacobian(q),
             "operational_space_inertia, 1000 states, damping 0.01": lambda: robot.operational_space_inertia(Q, damping=0.01)}
    rows = []
    for name, fn in calls.items():
        fn()
        n = 200 if "1000" not in name else 5
        rows.append((name, best(lambda: [fn() for _ in range(n)]) / n))
    return rows


def services(calls, blas_threads=None):
    """Round trips against a dynamics node (its BLAS limited to ``blas_threads``, if given)."""
    import rclpy
    from builtin_interfaces.msg import Time
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from serial_dynamics_interfaces.srv import (EstimatePayload, InverseDynamics, TaskSpace,
                                                TimeParameterize)
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from serial_dynamics.ros.processes import NodeProcess
    robot = sd.default_robot()
    truth = robot.with_payload(2.0, (0.01, -0.02, 0.06), (0.012, 0.01, 0.008, 0, 0, 0))
    ex = ident.excitation(robot, duration=6, harmonics=3, maxiter=0, seed=0)
    t, q, qd, qdd = ex.sample(dt=0.01)
    tau = truth.inverse_dynamics(q, qd, qdd) + np.random.default_rng(0).normal(0, 0.2, q.shape)
    rclpy.init()
    node = rclpy.create_node("bench_ros_users")
    ex_ = SingleThreadedExecutor()
    ex_.add_node(node)
    saved = dict(os.environ)
    if blas_threads:
        os.environ.update(OPENBLAS_NUM_THREADS=str(blas_threads), OMP_NUM_THREADS=str(blas_threads))
    proc = NodeProcess("dynamics", {"robot_description_timeout": 0.0},
                       ros_args=["-r", "__ns:=/bench_users"])
    os.environ.clear()
    os.environ.update(saved)
    try:
        def spin_until(done, timeout=120.0):
            deadline = time.monotonic() + timeout
            while not done():
                if time.monotonic() > deadline:
                    raise RuntimeError("timed out:\n" + proc.output()[-2000:])
                ex_.spin_once(timeout_sec=0.01)

        pub = node.create_publisher(JointState, "/bench_users/joint_states", 50)
        clients = {k: node.create_client(s, f"/bench_users/dynamics/{k}") for k, s in (
            ("estimate_payload", EstimatePayload), ("time_parameterize", TimeParameterize),
            ("inverse_dynamics", InverseDynamics), ("task_space", TaskSpace))}
        spin_until(lambda: all(c.service_is_ready() for c in clients.values())
                   and pub.get_subscription_count() > 0)
        for k in range(t.size):
            s = 100.0 + t[k]
            msg = JointState(name=robot.joint_names, position=q[k].tolist(), effort=tau[k].tolist())
            msg.header.stamp = Time(sec=int(s), nanosec=int(round((s % 1) * 1e9)))
            pub.publish(msg)
            t0 = time.monotonic()
            while time.monotonic() - t0 < 0.002:
                ex_.spin_once(timeout_sec=0.001)
        path = JointTrajectory(points=[JointTrajectoryPoint(positions=p.tolist()) for p in PATH])
        requests = {
            "inverse_dynamics": InverseDynamics.Request(positions=HOME.tolist()),
            "estimate_payload": EstimatePayload.Request(window=0.0),
            "time_parameterize": TimeParameterize.Request(path=path, effort_limits=EFFORT.tolist(),
                                                          grid=200),
            "task_space": TaskSpace.Request(positions=HOME.tolist(), velocities=[0.5] * 6,
                                            damping=0.01)}
        rows = []
        for key, req in requests.items():
            ms, answer = [], None
            for k in range(calls + 2):
                t0 = time.perf_counter()
                future = clients[key].call_async(req)
                spin_until(future.done)
                answer = future.result()
                if k >= 2:                               # the first two: warm-up
                    ms.append(1e3 * (time.perf_counter() - t0))
            assert answer.success, answer.message
            rows.append((key, np.percentile(ms, 50), np.percentile(ms, 99), len(ms)))
            if key == "estimate_payload":
                print("the node's estimate:", answer.message, answer.samples)
        # the library calls behind them, in this process
        lib = {"estimate_payload": lambda: ident.estimate_payload(robot, t, q, tau),
               "time_parameterize": lambda: tj.time_parameterize(robot, PATH, effort_limit=EFFORT,
                                                                 grid=200),
               "task_space": lambda: (robot.jacobian(HOME), robot.frame_acceleration(
                   HOME, np.full(6, 0.5), np.zeros(6)), robot.jacobian_dot_qd(HOME, np.full(6, 0.5)),
                   robot.operational_space_inertia(HOME, None, 0.01),
                   robot.dynamically_consistent_inverse(HOME, None, 0.01))}
        return rows, {k: 1e3 * best(f) for k, f in lib.items()}, t.size
    finally:
        proc.stop()
        node.destroy_node()
        rclpy.try_shutdown()


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=30)
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    svc, lib, samples = services(args.calls)
    svc1, _, _ = services(args.calls, blas_threads=1)
    grid, stretches = topp_vs_grid()
    book = textbook()
    ts = task_space()
    lines = ["## What ROS users ask next: payload, timing, task space (`bench/bench_ros_users.py`)",
             "", stamp(),
             load_note(load0, os.getloadavg()[0]), "",
             f"### Service calls of the `dynamics` node (round trip from a client node, {args.calls} "
             "calls after 2 warm-up ones; UR5e)", "",
             "| service | p50 (ms) | p99 (ms) | the library call alone (ms) |", "|---|---|---|---|"]
    what = {"inverse_dynamics": "one state (the baseline)",
            "estimate_payload": f"{samples} joint_states (6 s at 100 Hz)",
            "time_parameterize": f"{len(PATH)} waypoints, grid 200",
            "task_space": "the tip at one state, damping 0.01: J, its acceleration, J-dot qd, Lambda, J-bar"}
    for key, p50, p99, _ in svc:
        alone = f"{lib[key]:.1f}" if key in lib else "-"
        lines.append(f"| `~/{key}` ({what[key]}) | {p50:.2f} | {p99:.2f} | {alone} |")
    lines += ["", "The same node started with one BLAS thread (`OPENBLAS_NUM_THREADS=1`), in the "
              "same run: " + ", ".join(f"`~/{k}` p50 {a:.2f} ms, p99 {b:.2f} ms" for k, a, b, _ in svc1)
              + ". The fit's least squares (NumPy's `lstsq`, `pinv`) run on OpenBLAS's threads, "
              "which contend for the two shared cores with the node's executor and the other "
              "processes: on a loaded machine give the node one BLAS thread."]
    lines += ["", "### Time-parameterization against the grid size (pick-and-place path, UR5e "
              "with 2 kg, effort limits 60/90/45/12/12/12 N m, velocity limits of the URDF)", "",
              "Both time the same geometric path: the library's stretches between corners "
              f"({len(stretches)} on this path"
              + (": it turns by more than 0.1 rad at every inner waypoint, so each stretch is "
                 "a straight line" if max(stretches) == 2 else "") +
              "), each timed from rest to rest on the same spline by chord length and the "
              "same grid points, the durations summed. Ours: "
              "`trajectory.time_parameterize` (the path torques in three batched "
              "inverse-dynamics calls per stretch, the check on a grid 8 times finer, "
              "joined into one trajectory); peer: toppra's own `JointTorqueConstraint` "
              "(inverse dynamics point by point, no check) with the same effort and velocity "
              "limits. Best of 5.", "",
              "| grid | ours (ms) | toppra's constraint (ms) | ratio | duration ours (s) | "
              "duration peer (s) | stretch after the check |", "|---|---|---|---|---|---|---|"]
    for g, ours, theirs, d, dp, st in grid:
        lines.append(f"| {g} | {1e3 * ours:.1f} | {1e3 * theirs:.1f} | {ours / theirs:.2f} | "
                     f"{d:.4f} | {dp:.4f} | {st:.4f} |")
    lines += ["", "### Against the textbook's minimum-time maneuver (section E: UR5e, Q0 -> Q1, "
              "effort limits only)", "",
              "The textbook scales the cycloidal law uniformly in time; TOPP-RA chooses the best "
              "timing of the same straight line, so it can only be faster.", "",
              "| gravity | grid | textbook T (s) | TOPP-RA T (s) | ratio |", "|---|---|---|---|---|"]
    for g, grid_, T, d in book:
        lines.append(f"| {'yes' if g else 'no'} | {grid_} | {T:.4f} | {d:.4f} | {d / T:.3f} |")
    lines += ["", "### Task-space calls (UR5e, one state unless said)", "",
              "| call | time (us) |", "|---|---|"]
    for name, s in ts:
        lines.append(f"| `{name}` | {1e6 * s:.1f} |")
    write_section("ros_users", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
