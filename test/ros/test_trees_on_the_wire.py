"""The whole robot on the wire (issue 25): a two-arm robot on a fixed torso, its simulator
publishing every joint of the tree, and the dynamics node answering for a subset of its
joints in any order (the rest at zero), with real rclpy nodes and topics."""
import numpy as np
import pytest
from geometry_msgs.msg import Vector3, Wrench
from sensor_msgs.msg import JointState

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
