"""``sd.Contact`` and ``Robot.contact_points`` (contacts/contact.py, contacts/collision.py),
the SE(3) logarithm of the Baumgarte term against Pinocchio's log6, every kind inheriting the
contact methods from ``Robot``, and bad input: each a ValueError naming the culprit, before
any work."""
import numpy as np
import pytest

from pin_reference import erd, pin

import serial_dynamics as sd
from serial_dynamics.contacts.jacobians import se3_log
from serial_dynamics.robot import FloatingMimicRobot, FloatingRobot, MimicRobot, PlanarRobot, Robot

METHODS = ("contact_points", "constrained_forward_dynamics", "contact_inverse_dynamics")

URDF = """<robot name="r">
  <link name="world"><collision><geometry><sphere radius="2"/></geometry></collision></link>
  <joint name="w" type="fixed"><parent link="world"/><child link="base"/></joint>
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0 0 0.5"/>
      <inertia ixx="0.1" iyy="0.1" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0.2 0.3"/><geometry><sphere radius="0.05"/></geometry></collision>
    <collision><origin xyz="0 0 1" rpy="0 0 1.5707963267948966"/>
      <geometry><box size="0.2 0.4 0.6"/></geometry></collision>
    <collision><geometry><mesh filename="arm.stl"/></geometry></collision>
  </link>
  <link name="held"><collision><geometry><sphere radius="1"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <joint name="k" type="revolute"><parent link="base"/><child link="held"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
</robot>"""


def test_contact_points_reads_spheres_and_box_corners():
    """The sphere's centre (with its radius) and the box's corners, the box turned a quarter
    about z (x half-size 0.1 becomes y); the mesh is skipped, and so is the link above the
    model's base; a held link (lumped into the base) is part of the model."""
    with pytest.warns(sd.HeldJointsWarning):
        robot = sd.load_urdf(URDF, base_link="base", tip_link="arm")
    points = robot.contact_points()
    assert points[0] == sd.Contact("arm", (0.1, 0.2, 0.3), radius=0.05)
    assert all(c.link == "arm" and not c.frame and c.radius == 0 for c in points[1:9])
    corners = {tuple(np.round(c.point, 12) + 0.0) for c in points[1:9]}
    assert corners == {(sx * 0.2, sy * 0.1, 1 + sz * 0.3) for sx in (-1, 1) for sy in (-1, 1)
                       for sz in (-1, 1)}
    assert points[9:] == [sd.Contact("held", radius=1.0)]


def test_a_robot_with_mesh_collisions_has_no_contact_points():
    robot = sd.load_urdf(erd("solo_description/robots/solo12.urdf"), floating_base=True)
    assert robot.contact_points() == []


def test_se3_log_is_pinocchios_log6():
    for seed in range(5):
        np.random.seed(seed)
        X = pin.SE3.Random()
        X.rotation = pin.exp3(np.random.uniform(-1, 1, 3) * (1e-6 if seed == 0 else 1.0))
        assert np.allclose(se3_log(X.rotation, X.translation), pin.log6(X).vector,
                           rtol=0, atol=1e-12)


def test_every_kind_inherits_the_contact_methods_from_robot():
    for kind in (FloatingRobot, MimicRobot, PlanarRobot, FloatingMimicRobot):
        for name in METHODS:
            assert getattr(kind, name) is getattr(Robot, name), (kind, name)
    assert sd.Contact is sd.contacts.Contact


@pytest.mark.parametrize("kwargs, message", [
    (dict(link=3), "link must be a link name"),
    (dict(link="a", point=(0, 1)), r"point must be 3 finite numbers"),
    (dict(link="a", point=(0, np.nan, 1)), r"point must be 3 finite numbers"),
    (dict(link="a", frame="yes"), "frame must be True"),
    (dict(link="a", other_link="a"), "other_link must be another link"),
    (dict(link="a", anchor=(0, 0)), r"anchor .* point \(3,\)"),
    (dict(link="a", frame=True, anchor=2 * np.eye(4)), "anchor of 'a' must be a rigid pose"),
    (dict(link="a", radius=-1), "radius must be a number >= 0"),
])
def test_a_bad_contact_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        sd.Contact(**kwargs)


@pytest.fixture(scope="module")
def ur5e():
    return sd.load_urdf(sd.builtin_path("ur5e"))


def test_bad_input_is_refused_naming_the_culprit(ur5e):
    robot = ur5e
    q, v = robot.random_state(0)
    tau = np.zeros(6)
    hand = [sd.Contact("tool0")]
    cfd, cid = robot.constrained_forward_dynamics, robot.contact_inverse_dynamics
    for call in (cfd, cid):
        with pytest.raises(ValueError, match=r"'hand' is not a link of the model; its links are"):
            call(q, v, tau, [sd.Contact("hand")])
        with pytest.raises(ValueError, match=r"'elbow' is not a link"):
            call(q, v, tau, [sd.Contact("tool0", other_link="elbow")])
        with pytest.raises(ValueError, match="contacts is empty"):
            call(q, v, tau, [])
        with pytest.raises(ValueError, match=r"contacts\[1\] is 'tool0'"):
            call(q, v, tau, [hand[0], "tool0"])
        with pytest.raises(ValueError, match=r"q has a NaN or Inf entry"):
            call(np.r_[np.nan, q[1:]], v, tau, hand)
        with pytest.raises(ValueError, match=r"v has shape \(5,\); expected \(6,\)"):
            call(q, v[:5], tau, hand)
    with pytest.raises(ValueError, match=r"tau has a NaN"):
        cfd(q, v, np.r_[np.inf, tau[1:]], hand)
    with pytest.raises(ValueError, match=r"a has a NaN"):
        cid(q, v, np.r_[np.nan, tau[1:]], hand)
    for mu in (0.0, -0.5, np.nan, "high"):
        with pytest.raises(ValueError, match="friction must be a finite number > 0"):
            cid(q, v, tau, hand, friction=mu)
    with pytest.raises(ValueError, match="normal has a zero vector"):
        cid(q, v, tau, hand, friction=0.5, normal=(0, 0, 0))
    with pytest.raises(ValueError, match=r"baumgarte must be \(kp, kd\)"):
        cfd(q, v, tau, hand, baumgarte=5.0)
    with pytest.raises(ValueError, match="baumgarte's kd must be a finite number >= 0"):
        cfd(q, v, tau, hand, baumgarte=(1.0, -1.0))
    with pytest.raises(ValueError, match="mu must be a finite number > 0"):
        cfd(q, v, tau, hand, mu=0)
    with pytest.raises(ValueError, match="max_iterations must be an integer >= 1"):
        cfd(q, v, tau, hand, max_iterations=0.5)


def test_a_robot_built_by_hand_has_no_urdf_to_read(ur5e):
    import dataclasses
    robot = sd.Robot(dataclasses.replace(ur5e.model, source=None))
    with pytest.raises(ValueError, match="not loaded from a URDF"):
        robot.contact_points()
