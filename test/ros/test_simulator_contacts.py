"""The simulator node's ground and contacts (issue 51, item 5): the ``ground.*`` and
``contacts`` parameters without a node (``ros/simulator_parameters.py``: the session they make,
each bad value named with its fix), the topic names of the contacts, then Solo12 standing
under the real simulator node for 5 s of simulated time on the torques the real dynamics
node's ``~/contact_inverse_dynamics`` answers, plus a small joint PD."""
import numpy as np
import pytest
from geometry_msgs.msg import Pose, WrenchStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool

from pin_reference import erd

import serial_dynamics as sd
from serial_dynamics.contacts.stepper import GroundSession
from serial_dynamics.loops.simulator import SimulatorLoop, contact_names
from serial_dynamics.ros import parameters
from serial_dynamics.ros.simulator_parameters import PARAMETERS, session
from serial_dynamics.sim.session import Session

from conftest import Latest, stamp_ns, wait_for_log

SOLO = "solo_description/robots/solo12.urdf"
FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]
LEGS = [0.0, 0.8, -1.6, 0.0, 0.8, -1.6, 0.0, -0.8, 1.6, 0.0, -0.8, 1.6]   # knees bent
NS = "/standing"
SECONDS = 5.0                 # simulated
G = 9.81


@pytest.fixture(scope="module")
def solo():
    return sd.load_urdf(erd(SOLO), floating_base=True)


def values(**changes):
    return {**parameters.defaults(PARAMETERS), **changes}


def standing(robot):
    """The base pose [x, y, z, qx, qy, qz, qw] with the feet of LEGS on the ground z = 0."""
    q = np.r_[np.zeros(6), 1.0, LEGS]
    q[2] = -min(robot.forward_kinematics(q, f)[2, 3] for f in FEET)
    return q[:7]


def weight(robot):
    return G * (robot.model.base_mass + robot.model.mass.sum())


# ----------------------------------------------------------------- without a node
def test_contacts_make_a_ground_session_and_an_arm_keeps_its_own(solo):
    s, notes = session(solo, values(floating_base=True, contacts=FEET, initial_positions=LEGS,
                                    initial_base_pose=standing(solo).tolist()))
    assert isinstance(s, GroundSession) and [c.link for c in s.contacts] == FEET
    assert s.integrator.ground == sd.Ground() and s.servo_ok
    assert any("4 contacts on the ground" in text for _, text in notes)
    loop = SimulatorLoop(s, values(odom_frame="world"))
    assert loop.contact_names == FEET and loop.contact_frame == "world"
    np.testing.assert_array_equal(loop.contact_forces(), np.zeros((4, 3)))
    q, still = s.q.copy(), np.zeros(solo.nv)
    tau, _ = solo.contact_inverse_dynamics(q, still, still, [sd.Contact(f) for f in FEET])
    loop.command(None, tau[6:], np.array(LEGS), np.zeros(12))     # held where it stands
    s.step()
    assert abs(loop.contact_forces()[:, 2].sum() - weight(solo)) < 1e-6 * weight(solo)
    # the default: no contacts, no ground (the UR5e as before); ground.enabled false: none
    arm, notes = session(sd.default_robot(), values())
    assert type(arm) is Session and notes == []
    s, notes = session(solo, values(contacts=FEET, **{"ground.enabled": False}))
    assert type(s) is Session and "touch nothing" in notes[0][1]
    s, _ = session(solo, values(contacts=FEET, **{"ground.height": 0.5, "ground.normal": [0, 0, 2],
                                                  "ground.friction": 0.4,
                                                  "ground.restitution": 0.2}))
    assert s.integrator.ground == sd.Ground(0.5, (0, 0, 1), 0.4, 0.2)


def test_a_box_from_collision_gets_one_topic_per_corner():
    box = sd.load_urdf(
        '<robot name="b"><link name="base"/><link name="lid"><inertial><mass value="1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="lid"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '</robot>')
    s, _ = session(box, values(contacts=["collision"], **{"ground.height": -1.0}))
    assert contact_names(s.contacts) == [f"lid_{i}" for i in range(8)]
    assert contact_names([sd.Contact("a.b-c"), sd.Contact("9z")]) == ["a_b_c", "_9z"]


@pytest.mark.parametrize("change, words", [
    ({"contacts": ["FL_FOOT", "FL_HOOF"]}, "parameter 'contacts' [1]: link 'FL_HOOF' is not a "
     "link of the model; its links are ['FL_FOOT'"),
    ({"contacts": ["FL_FOOT", "FL_FOOT"]}, "parameter 'contacts' names 'FL_FOOT' twice"),
    ({"contacts": ["collision"]}, "parameter 'contacts' = [collision], but the URDF has no "
     "<collision> sphere or box on a link of the model (meshes are not read); name the links"),
    ({"contacts": ["collision", "FL_FOOT"]}, "give [collision] alone"),
    ({"ground.friction": 0.0}, "parameter 'ground.friction' must be > 0 (Coulomb's "
     "coefficient, e.g. 1.0), got 0.0"),
    ({"ground.friction": -0.5}, "parameter 'ground.friction' must be > 0"),
    ({"ground.normal": [0.0, 0.0, 0.0]}, "parameter 'ground.normal' must be 3 numbers, not all "
     "zero (the plane's upward direction, world axes), e.g. [0.0, 0.0, 1.0]; got [0.0, 0.0, 0.0]"),
    ({"ground.normal": [0.0, 1.0]}, "parameter 'ground.normal' must be 3 numbers"),
    ({"integrator": "rk4"}, "parameter 'integrator' is 'rk4': contacts with the ground are "
     "stepped by semi-implicit Euler; give -p integrator:=semi_implicit_euler")])
def test_bad_ground_parameters_are_named_with_their_fix(solo, change, words):
    p = values(floating_base=True, initial_positions=LEGS, contacts=FEET)
    with pytest.raises(ValueError) as e:
        session(solo, {**p, **change})
    assert words in str(e.value)


# ----------------------------------------------------------------- the nodes
def test_solo12_stands_on_the_torques_the_dynamics_node_answers(ros, solo):
    """Solo12 on the ground, its feet where LEGS puts them, held by the torques of
    ~/contact_inverse_dynamics (the dynamics node) plus the simulator's joint PD (kp 20 N m/rad,
    kd 0.5 N m s/rad): that state is an equilibrium of the step (the feet at rest on the
    ground, the weight carried by the contacts, the PD's error zero), so over 5 s of simulated
    time the base may move only by round-off and the solver's tolerance (projected
    Gauss-Seidel stops at 1e-9 relative change of the impulses): bound 1e-6 m. Without the
    ground it falls (12 cm in the first 0.16 s); without the feed-forward the soft PD lets it
    sag. The simulator runs as fast as it can (real_time_factor 0: the NumPy contact step
    reaches a real-time factor of about 0.4 on the loaded test machine) and stamps with
    simulated time (publish_clock), so the test waits on stamps, not on the wall clock."""
    srv = pytest.importorskip("serial_dynamics_interfaces.srv")
    base = standing(solo)
    dyn = ros.start("dynamics", {"urdf_path": erd(SOLO), "floating_base": True},
                    ros_args=["-r", f"__ns:={NS}"])
    sim = ros.start("simulator", {
        "urdf_path": erd(SOLO), "floating_base": True, "initial_positions": LEGS,
        "initial_base_pose": base.tolist(), "contacts": FEET, "start_paused": True,
        "real_time_factor": 0.0, "publish_clock": True, "command_timeout": 0.0,
        "servo.kp": [20.0], "servo.kd": [0.5], "odom_frame": "world"},
        ros_args=["-r", f"__ns:={NS}"])
    odom = Latest(ros, Odometry, f"{NS}/odom", depth=1000)
    wrenches = {f: Latest(ros, WrenchStamped, f"{NS}/simulator/contacts/{f}", depth=1000)
                for f in FEET}
    command = ros.node.create_publisher(JointState, f"{NS}/joint_commands", 10)
    pause = ros.node.create_client(SetBool, f"{NS}/simulator/pause")
    cid = ros.node.create_client(srv.ContactInverseDynamics,
                                 f"{NS}/dynamics/contact_inverse_dynamics")
    try:
        # the torques that hold it, from the dynamics node
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = base[:3]
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = base[3:]
        out = ros.call(cid, srv.ContactInverseDynamics.Request(
            positions=LEGS, base_pose=pose, contact_links=FEET), timeout=150.0)
        assert out.success, out.message
        tau = np.array(out.efforts)
        f = np.array([[w.force.x, w.force.y, w.force.z] for w in out.contact_wrenches])
        assert abs(f[:, 2].sum() - weight(solo)) < 1e-9 * weight(solo)
        # they hold it: the base rows of M a + b = tau + J^T f (a = 0, v = 0) are the
        # contact forces' alone (base rows of tau zero), the joint rows tau's
        q = np.r_[base, LEGS]
        generalized = np.r_[np.zeros(6), tau]
        for c, fc in zip(FEET, f):
            generalized += solo.jacobian(q, c)[:3].T @ fc      # J_P^T f at each foot's origin
        np.testing.assert_allclose(generalized, solo.gravity_torques(q), rtol=0, atol=1e-9)
        # the simulator: paused, commanded, resumed
        wait_for_log(ros, sim, "ready", timeout=150)
        ros.wait_matched(command, also=lambda: odom.msgs, what="the simulator")
        command.publish(JointState(name=solo.joint_names, position=LEGS,
                                   velocity=[0.0] * 12, effort=tau.tolist()))
        wait_for_log(ros, sim, "4 contacts on the ground")
        ros.spin_for(0.5)                     # the command is in (a paused simulator takes it)
        odom.clear()
        for w in wrenches.values():
            w.clear()
        assert ros.call(pause, SetBool.Request(data=False)).message == "running"
        odom.wait(lambda m: stamp_ns(m) >= SECONDS * 1e9, timeout=120,
                  what=f"{SECONDS} s of simulated time")
        for foot in FEET:
            wrenches[foot].wait(lambda m: stamp_ns(m) >= SECONDS * 1e9, timeout=20)
        heights = np.array([m.pose.pose.position.z for m in odom.msgs])
        assert len(heights) >= 400 and np.max(np.abs(heights - base[2])) < 1e-6
        # the feet carry the weight at every published step, world axes, on the robot
        stamps = sorted(set.intersection(*(set(map(stamp_ns, wrenches[x].msgs)) for x in FEET))
                        - {0})                # 0: published while paused, before any step
        assert len(stamps) >= 400
        by_foot = {x: {stamp_ns(m): m for m in wrenches[x].msgs} for x in FEET}
        for s in stamps:
            msgs = [by_foot[x][s] for x in FEET]
            assert all(m.header.frame_id == "world" for m in msgs)
            fz = sum(m.wrench.force.z for m in msgs)
            assert abs(fz - weight(solo)) < 1e-6 * weight(solo), (s, fz)
            assert all(m.wrench.torque.x == m.wrench.torque.y == m.wrench.torque.z == 0.0
                       for m in msgs)
        assert sim.running() and dyn.running()
    finally:
        odom.destroy()
        for w in wrenches.values():
            w.destroy()
        sim.stop()
        dyn.stop()
