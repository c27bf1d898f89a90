"""The whole robot on the wire (issue 25): a two-arm robot on a fixed torso, its simulator
publishing every joint of the tree, and the dynamics node answering for a subset of its
joints in any order (the rest at zero), with real rclpy nodes and topics."""
import numpy as np
import pytest
from geometry_msgs.msg import Vector3, Wrench
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

import serial_dynamics as sd
from conftest import Latest
from test_trees import two_arms

srv = pytest.importorskip("serial_dynamics_interfaces.srv")


def test_a_two_arm_robot_on_the_wire(ros):
    xml = two_arms()
    robot = sd.load_urdf(xml)
    assert not robot.model.is_chain
    ros.start("simulator", {"robot_description": xml, "publish_clock": True,
                            "command_timeout_action": "limp",      # no commands: let them fall
                            "initial_positions": [0.0, 0.3, 0.01, 0.01, 0.0, -0.3, 0.01, 0.01]},
              ["-r", "__ns:=/arms"])
    ros.start("dynamics", {"robot_description": xml}, ["-r", "__ns:=/arms"])
    states = Latest(ros, JointState, "/arms/joint_states", depth=100)
    ros.spin_until(lambda: states.msgs, 150.0, "the simulator's joint_states")
    m = states.wait(lambda m: np.any(np.array(m.velocity) != 0.0), what="the arms to fall")
    assert list(m.name) == robot.all_joint_names == robot.joint_names     # all 8 joints
    assert len(m.position) == len(m.velocity) == len(m.effort) == 8
    client = ros.node.create_client(srv.InverseDynamics, "/arms/dynamics/inverse_dynamics")
    names = ["r_elbow", "l_shoulder", "l_fa"]                  # 3 of the 8, out of order
    values = np.array([0.7, -0.4, 0.01])
    answer = ros.call(client, srv.InverseDynamics.Request(
        joint_names=names, positions=values.tolist(), velocities=[0.5, 0.0, 0.1],
        accelerations=[1.0, 2.0, 0.0],
        tip_wrench=Wrench(force=Vector3(), torque=Vector3())))
    assert answer.success, answer.message
    index = [robot.joint_names.index(x) for x in names]
    q, qd, qdd = (np.zeros(robot.dof) for _ in range(3))
    q[index], qd[index], qdd[index] = values, [0.5, 0.0, 0.1], [1.0, 2.0, 0.0]
    assert list(answer.joint_names) == robot.joint_names
    np.testing.assert_allclose(answer.efforts, robot.inverse_dynamics(q, qd, qdd), rtol=1e-12,
                               atol=1e-12)
    refused = ros.call(client, srv.InverseDynamics.Request(
        joint_names=["r_elbow", "nose"], positions=[0.0, 0.0]))
    assert not refused.success and "'nose'" in refused.message


def test_the_controller_and_the_observer_run_the_two_arm_tree(ros):
    """The controller holds the two-arm tree's simulated joints at a target (every joint,
    both arms and their fingers, through effort_commands), and the observer, reading the
    simulator's joint_states, sees no external torque once the arms are at rest (within 0.1
    N m, and the held effort is gravity's within 0.1 N m, where gravity's exceed 1 N m): a
    controller or an observer on the wrong model (one arm, the chain, another joint order)
    leaves errors of the size of gravity's torques."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    xml, ns = two_arms(), ["-r", "__ns:=/tree_ctl"]
    robot = sd.load_urdf(xml)
    target = np.array([0.4, 0.6, 0.02, 0.015, -0.3, -0.5, 0.01, 0.02])
    ros.start("simulator", {"robot_description": xml, "dissipation.enabled": False,
                            "real_time_factor": 0.5,
                            "initial_positions": [0.0, 0.3, 0.01, 0.01, 0.0, -0.3, 0.01, 0.01]},
              ns)
    ros.start("computed_torque_controller", {"robot_description": xml, "kp": [100.0],
                                             "kd": [20.0]}, ns)
    ros.start("external_torque_observer", {"robot_description": xml, "gain": 50.0}, ns)
    traj = ros.node.create_publisher(JointTrajectory, "/tree_ctl/desired_trajectory", 10)
    states = Latest(ros, JointState, "/tree_ctl/joint_states", depth=100)
    estimates = Latest(ros, JointState, "/tree_ctl/estimated_external_torques", depth=100)
    efforts = Latest(ros, Float64MultiArray, "/tree_ctl/effort_commands")
    # the controller commands once it has a joint state; a trajectory that reaches it
    # before that is refused ("arrived before any joint_states message"), and the arms
    # stay where they started: that race was lost in 2 of the 37 runs logged here, both under load
    ros.wait_matched(traj, also=lambda: states.msgs and estimates.msgs and efforts.msgs,
                     what="the three nodes")
    traj.publish(JointTrajectory(joint_names=robot.joint_names, points=[JointTrajectoryPoint(
        positions=target.tolist(), time_from_start=Duration(sec=0))]))
    held = states.wait(lambda m: np.max(np.abs(np.array(m.position) - target)) < 1e-3
                       and np.max(np.abs(m.velocity)) < 1e-3, timeout=120.0,
                       what="the arms held at the target")
    assert list(held.name) == robot.joint_names
    assert np.max(np.abs(robot.gravity_torques(target))) > 1.0        # gravity is felt
    np.testing.assert_allclose(held.effort, robot.gravity_torques(np.array(held.position)),
                               atol=0.1)                              # the effort holds it
    quiet = estimates.wait(lambda m: m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                           >= held.header.stamp.sec * 10**9 + held.header.stamp.nanosec,
                           what="an estimate at rest")
    assert list(quiet.name) == robot.joint_names
    assert np.max(np.abs(quiet.effort)) < 0.1                         # N m, N: none
