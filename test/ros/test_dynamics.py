"""The dynamics node in its own process: its four services (serial_dynamics_interfaces),
called from this process with real rclpy, answer the library's numbers on a robot loaded
from a URDF path and one loaded from the robot_description parameter; bad requests are
refused field by field and the node carries on; /diagnostics counts calls, refusals and
latency per service."""
import ast
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3, Wrench
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

import serial_dynamics as sd

from conftest import Latest

srv = pytest.importorskip("serial_dynamics_interfaces.srv")

SERVICES = {"inverse_dynamics": srv.InverseDynamics, "forward_dynamics": srv.ForwardDynamics,
            "mass_matrix": srv.MassMatrix, "trajectory_torques": srv.TrajectoryTorques}
# the robot_description parameter gets a tilted gravity as well: a second load path, a
# second robot (3 joints), a second gravity
DESCRIPTION = ("spatial_3r", (1.0, -2.0, -9.0))


class Node:
    """Clients of the four services of the dynamics node ``name``."""

    def __init__(self, ros, proc, name, robot):
        self.ros, self.proc, self.robot = ros, proc, robot
        self.clients = {s: ros.node.create_client(t, f"{name}/{s}") for s, t in SERVICES.items()}

    def call(self, service, **fields):
        return self.ros.call(self.clients[service], SERVICES[service].Request(**fields),
                             timeout=150.0, resend=10.0)     # the services are pure


def wrench(w):
    return Wrench(force=Vector3(x=float(w[0]), y=float(w[1]), z=float(w[2])),
                  torque=Vector3(x=float(w[3]), y=float(w[4]), z=float(w[5])))


@pytest.fixture(scope="module")
def nodes(ros, tmp_path_factory):
    """The node twice, started together: from urdf_path (the UR5e file) and from the
    robot_description parameter (a parameter file, as a launch file gives it)."""
    name, gravity = DESCRIPTION
    params = tmp_path_factory.mktemp("dynamics") / "params.yaml"
    xml = open(sd.builtin_path(name)).read()
    params.write_text("/**:\n  ros__parameters:\n    robot_description: |\n"
                      + "".join(f"      {line}\n" for line in xml.splitlines()))
    path = ros.start("dynamics", {"urdf_path": sd.builtin_path("ur5e")})   # /dynamics: docs' name
    desc = ros.start("dynamics", {"gravity": list(gravity)},
                     ros_args=["-r", "__ns:=/from_description", "--params-file", str(params)])
    return {"urdf_path": Node(ros, path, "/dynamics", sd.default_robot()),
            "robot_description": Node(ros, desc, "/from_description/dynamics",
                                      sd.load_urdf(xml, gravity=gravity))}


@pytest.mark.parametrize("source", ["urdf_path", "robot_description"])
def test_four_services_answer_the_library_numbers(nodes, source):
    node = nodes[source]
    robot, n = node.robot, node.robot.dof
    rng = np.random.default_rng(7)
    q, qd = robot.random_state(rng)
    qdd, tau = rng.uniform(-2, 2, n), rng.uniform(-20, 20, n)
    w = np.array([10.0, -5.0, 20.0, 1.0, 2.0, -0.5])
    perm = rng.permutation(n)                        # joint names shuffled
    names = [robot.joint_names[i] for i in perm]

    r = node.call("inverse_dynamics", joint_names=names, positions=q[perm].tolist(),
                  velocities=qd[perm].tolist(), accelerations=qdd[perm].tolist(),
                  tip_wrench=wrench(w))
    assert r.success and r.message == "" and list(r.joint_names) == robot.joint_names
    np.testing.assert_allclose(r.efforts, robot.inverse_dynamics(q, qd, qdd, w),
                               rtol=1e-12, atol=1e-10)
    assert np.max(np.abs(np.array(r.efforts) - robot.inverse_dynamics(q, qd, qdd))) > 0.1

    r = node.call("inverse_dynamics", positions=q.tolist())       # robot order, zeros
    assert f"from {'urdf_path' if source == 'urdf_path' else 'the robot_description'}" \
        in node.proc.output()
    np.testing.assert_allclose(r.efforts, robot.gravity_torques(q), rtol=1e-12, atol=1e-10)

    r = node.call("forward_dynamics", joint_names=names, positions=q[perm].tolist(),
                  velocities=qd[perm].tolist(), efforts=tau[perm].tolist(), tip_wrench=wrench(w))
    assert r.success and list(r.joint_names) == robot.joint_names
    np.testing.assert_allclose(r.accelerations, robot.forward_dynamics(q, qd, tau, w),
                               rtol=1e-10, atol=1e-10)
    tau_id = node.call("inverse_dynamics", positions=q.tolist(), velocities=qd.tolist(),
                       accelerations=qdd.tolist()).efforts
    back = node.call("forward_dynamics", positions=q.tolist(), velocities=qd.tolist(),
                     efforts=tau_id).accelerations            # forward(inverse) = identity
    np.testing.assert_allclose(back, qdd, rtol=1e-9, atol=1e-9)

    r = node.call("mass_matrix", joint_names=names, positions=q[perm].tolist())
    assert r.success and list(r.joint_names) == robot.joint_names
    M = np.array(r.mass_matrix).reshape(n, n)
    np.testing.assert_allclose(M, robot.mass_matrix(q), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(M, M.T)

    N = 40
    Q, QD = robot.random_state(rng, batch=N)
    QDD = rng.uniform(-2, 2, (N, n))
    traj = JointTrajectory(joint_names=names, points=[JointTrajectoryPoint(
        positions=Q[i, perm].tolist(), velocities=QD[i, perm].tolist(),
        accelerations=QDD[i, perm].tolist(), time_from_start=Duration(sec=i, nanosec=7))
        for i in range(N)])
    traj.header.frame_id = "plan 3"
    r = node.call("trajectory_torques", trajectory=traj)
    assert r.success and r.trajectory.header.frame_id == "plan 3"
    assert list(r.trajectory.joint_names) == robot.joint_names and len(r.trajectory.points) == N
    np.testing.assert_allclose([p.effort for p in r.trajectory.points],
                               robot.inverse_dynamics(Q, QD, QDD), rtol=1e-12, atol=1e-10)
    np.testing.assert_array_equal([p.positions for p in r.trajectory.points], Q)
    assert [(p.time_from_start.sec, p.time_from_start.nanosec) for p in r.trajectory.points] \
        == [(i, 7) for i in range(N)]


def _bad_requests(robot):
    """(service, fields, the field the message must name, a word of the fix)."""
    n, names = robot.dof, robot.joint_names
    q = [0.1] * n
    nan = [0.1] * (n - 1) + [float("nan")]
    return [
        ("inverse_dynamics", dict(joint_names=names[:-1], positions=q), "positions",
         "one per joint, 5"),          # a subset of the joints (issue 25), 6 positions for 5
        ("inverse_dynamics", dict(joint_names=[*names[:-1], "gripper"], positions=q),
         "joint_names", "gripper"),
        ("inverse_dynamics", dict(joint_names=[*names[:-1], names[0]], positions=q),
         "joint_names", "more than once"),
        ("inverse_dynamics", dict(positions=q[:-1]), "positions", f"one per joint, {n}"),
        ("inverse_dynamics", dict(positions=nan), "positions", "finite"),
        ("inverse_dynamics", dict(positions=q, velocities=[0.0]), "velocities", "or none"),
        ("inverse_dynamics", dict(positions=q, accelerations=nan), "accelerations", "finite"),
        ("inverse_dynamics", dict(positions=q, tip_wrench=wrench([0, float("inf"), 0, 0, 0, 0])),
         "tip_wrench", "finite"),
        ("forward_dynamics", dict(positions=q, efforts=[1.0] * (n + 1)), "efforts", "or none"),
        ("forward_dynamics", dict(positions=q, velocities=nan), "velocities", "finite"),
        ("mass_matrix", dict(positions=[]), "positions", f"one per joint, {n}"),
        ("trajectory_torques", dict(trajectory=JointTrajectory(joint_names=names)), "points", ""),
        ("trajectory_torques", dict(trajectory=JointTrajectory(joint_names=names, points=[
            JointTrajectoryPoint(positions=q, velocities=q[:-1])])), "velocities", "or none"),
    ]


def test_bad_requests_are_refused_naming_the_field_and_the_node_carries_on(ros, nodes):
    node = nodes["urdf_path"]
    robot = node.robot
    diagnostics = Latest(ros, DiagnosticArray, "/diagnostics")
    bad = _bad_requests(robot)
    for service, fields, field, fix in bad:
        r = node.call(service, **fields)
        assert not r.success, (service, fields)
        assert field in r.message and fix in r.message, (field, fix, r.message)
    r = node.call("mass_matrix", positions=[0.2] * robot.dof)      # still serving
    assert r.success
    np.testing.assert_allclose(np.reshape(r.mass_matrix, (6, 6)), robot.mass_matrix([0.2] * 6),
                               rtol=1e-12)
    assert node.proc.running()

    refused = {s: sum(b[0] == s for b in bad) for s in SERVICES}

    def counted(m):     # the node's report, once it counts every refusal of this test
        s = [s for s in m.status if s.name == "/dynamics"]
        values = {v.key: v.value for v in s[0].values} if s else {}
        return all(int(values.get(f"refused ~/{k}", 0)) >= refused[k] for k in SERVICES) \
            and values
    report = {v.key: v.value for v in next(s for s in diagnostics.wait(counted, what="a report")
                                           .status if s.name == "/dynamics").values}
    diagnostics.destroy()
    for k in SERVICES:
        assert int(report[f"received ~/{k}"]) > int(report[f"refused ~/{k}"]) >= refused[k]
        assert float(report[f"~/{k} latency max (ms)"]) >= float(report[f"~/{k} latency mean (ms)"])


def test_the_docs_service_client_gets_the_node_answers(nodes):
    """docs/ros.md's Python service client, run as written against the running node."""
    robot = nodes["urdf_path"].robot
    docs = open(os.path.join(os.path.dirname(__file__), "..", "..", "docs", "ros.md")).read()
    (code,) = [b for b in re.findall(r"```python\n(.*?)```", docs, re.S)
               if "import InverseDynamics, MassMatrix" in b]
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    lines = dict(line.split(": ", 1) for line in run.stdout.splitlines())
    q = [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]
    tau = ast.literal_eval(lines["gravity torques (N m)"])
    assert list(tau) == robot.joint_names
    np.testing.assert_allclose(list(tau.values()), robot.gravity_torques(q), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ast.literal_eval(lines["M(q) diagonal (kg m^2)"]),
                               np.diag(robot.mass_matrix(q)), rtol=1e-12)
    assert lines["a bad request"].startswith("False positions has 5 values")
