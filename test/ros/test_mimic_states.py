"""The simulator with mimic joints on the chain publishes every joint in joint_states (for
robot_state_publisher): the followers at multiplier * leader + offset, the efforts of the
independent joints as commanded and 0 for the followers."""

import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from test_mimic import mimic_chain  # noqa: E402

from conftest import Latest  # noqa: E402

import serial_dynamics as sd  # noqa: E402


def test_simulator_publishes_every_joint_of_a_mimic_chain(ros):
    xml = mimic_chain("prismatic")
    robot = sd.load_urdf(xml)
    ros.start("simulator", {"robot_description": xml, "publish_clock": True,
                            "initial_positions": [0.3, -0.4]}, ["-r", "__ns:=/mimic"])
    states = Latest(ros, JointState, "/mimic/joint_states", depth=100)
    effort = ros.node.create_publisher(Float64MultiArray, "/mimic/effort_commands", 10)
    ros.wait_matched(effort, also=lambda: states.msgs, what="the simulator")
    effort.publish(Float64MultiArray(data=[0.5, -0.25]))
    m = states.wait(lambda m: m.effort[0] == 0.5, what="the commanded effort")
    assert list(m.name) == ["j1", "j2", "j3", "j4"] == robot.all_joint_names
    q, qd = np.array(m.position)[[0, 1]], np.array(m.velocity)[[0, 1]]
    # j3 = 1.5 j2 + 0.2 (prismatic), j4 = -0.7 j1
    np.testing.assert_allclose(m.position, [q[0], q[1], 1.5 * q[1] + 0.2, -0.7 * q[0]], rtol=1e-15)
    np.testing.assert_allclose(m.velocity, [qd[0], qd[1], 1.5 * qd[1], -0.7 * qd[0]], rtol=1e-15)
    assert list(m.effort) == [0.5, -0.25, 0.0, 0.0]
    assert np.any(np.array(m.velocity) != 0.0)          # it moves: the state is not trivial
