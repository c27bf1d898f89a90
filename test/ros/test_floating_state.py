"""ros/floating_state.py without a node: the initial pose parameter, the state <->
nav_msgs/Odometry, and the checks of a base state or wrench sent to the simulator."""
import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from scipy.spatial.transform import Rotation

import serial_dynamics as sd
from serial_dynamics.ros import floating_state as fs
from serial_dynamics.ros.common import Rejected
from serial_dynamics.ros.simulator_inputs import external_wrench

ROBOT = sd.load_urdf(sd.builtin_path(), gravity=(0.0, 0.0, 0.0), floating_base=True)
RNG = np.random.default_rng(19)


def test_initial_pose_defaults_to_identity_and_normalizes():
    np.testing.assert_array_equal(fs.initial_pose([]), fs.IDENTITY)
    pose = fs.initial_pose([1.0, 2.0, 3.0, 0.0, 0.0, 2.0, 2.0])
    np.testing.assert_allclose(pose, [1, 2, 3, 0, 0, np.sqrt(0.5), np.sqrt(0.5)], rtol=0,
                               atol=1e-15)


@pytest.mark.parametrize("values, words", [
    ([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "of length 0"),
    ([0.0, 0.0, 0.0, 1.0], "7 finite numbers"),
    ([0.0, 0.0, np.nan, 0.0, 0.0, 0.0, 1.0], "7 finite numbers")])
def test_bad_initial_pose_is_named(values, words):
    with pytest.raises(ValueError, match="initial_base_pose") as e:
        fs.initial_pose(values)
    assert words in str(e.value)


def test_odometry_round_trip_and_twist_in_the_base_frame():
    quat = RNG.normal(size=4)
    q = np.concatenate([RNG.normal(size=3), quat / np.linalg.norm(quat), np.zeros(ROBOT.dof)])
    v = RNG.normal(size=ROBOT.nv)
    msg = fs.odometry(q[:7], v[:6], "odom", ROBOT.base_link)
    assert (msg.header.frame_id, msg.child_frame_id) == ("odom", ROBOT.base_link)
    pose, twist = fs.base_state(msg, "odom", ROBOT.base_link)
    # the quaternion is normalised again on the way: equal to the last bit or two
    np.testing.assert_allclose(pose, q[:7], rtol=0, atol=4 * np.finfo(float).eps)
    np.testing.assert_array_equal(twist, v[:6])
    # REP 105 / nav_msgs: the twist is in child_frame_id (the base): rotated into the world
    # by the published orientation it is the rate of the published position (the library's
    # own SE(3) integration, by central differences)
    o, t = msg.pose.pose.orientation, msg.twist.twist
    R = Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix()
    h = 1e-6
    rate = (ROBOT.integrate(q, v, h)[:3] - ROBOT.integrate(q, v, -h)[:3]) / (2 * h)
    np.testing.assert_allclose(R @ [t.linear.x, t.linear.y, t.linear.z], rate, rtol=0, atol=1e-8)


@pytest.mark.parametrize("change, words", [
    (lambda m: setattr(m.header, "frame_id", "map"), "header.frame_id 'map'"),
    (lambda m: setattr(m, "child_frame_id", "tool0"), "child_frame_id 'tool0'"),
    (lambda m: setattr(m.pose.pose.orientation, "w", 0.9), "unit quaternion"),
    (lambda m: setattr(m.twist.twist.angular, "z", np.inf), "twist must be finite")])
def test_bad_base_state_is_named(change, words):
    msg = fs.odometry(np.array(fs.IDENTITY), np.zeros(6), "", "")
    change(msg)
    with pytest.raises(Rejected, match="set_base_state") as e:
        fs.base_state(msg, "odom", ROBOT.base_link)
    assert words in str(e.value)


def test_external_wrench_is_in_the_world_frame():
    msg = WrenchStamped()
    msg.wrench.force.x, msg.wrench.torque.z = 2.0, -1.0
    np.testing.assert_array_equal(external_wrench(msg, "odom", "world"), [2, 0, 0, 0, 0, -1])
    msg.header.frame_id = "odom"
    assert external_wrench(msg, "odom", "world") is not None
    msg.header.frame_id = ROBOT.base_link
    with pytest.raises(ValueError, match="world coordinates"):
        external_wrench(msg, "odom", "world")
    assert external_wrench(WrenchStamped(), "odom", "world") is None
