"""The simulator's parameters without a node (``ros/simulator_parameters.py``): the checks at
start-up (with the numbers they name), the Session they make and the lines to log."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.loops.simulator import dt_ns
from serial_dynamics.ros import parameters
from serial_dynamics.ros.simulator_parameters import PARAMETERS, session

UR5E = sd.default_robot()
TWO = ('<robot name="two"><link name="base"/>'
       '<link name="a"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" '
       'ixy="0" ixz="0" iyz="0"/></inertial></link>'
       '<link name="b"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" '
       'ixy="0" ixz="0" iyz="0"/></inertial></link>'
       '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
       '<axis xyz="0 0 1"/><limit lower="0.5" upper="1.5" effort="10" velocity="1"/></joint>'
       '<joint name="j2" type="prismatic"><parent link="a"/><child link="b"/>'
       '<origin xyz="0.3 0 0"/><axis xyz="1 0 0"/>'
       '<limit lower="-1" upper="3" effort="20" velocity="1"/></joint></robot>')


def values(**changes):
    return {**parameters.defaults(PARAMETERS), **changes}


def test_the_defaults_make_the_session_the_table_says():
    s, notes = session(UR5E, values(sim_dt=0.0015, effort_limits=[50.0]))
    assert notes == [] and s.dt == 0.0015 and dt_ns(values(sim_dt=0.0015)) == 1_500_000
    np.testing.assert_array_equal(s.q, np.zeros(6))
    np.testing.assert_array_equal(s.limit, np.full(6, 50.0))
    np.testing.assert_array_equal(s.hold.kp, np.full(6, 1e4))
    assert s.timeout_action == "brake" and s.hold.timeout_steps == round(0.5 / 0.0015)
    s, _ = session(UR5E, values(clamp_effort=False, command_timeout=0.0))
    assert np.all(np.isinf(s.limit)) and s.hold.timeout_steps == 0


def test_initial_positions_outside_the_limits_name_a_fit():
    robot = sd.load_urdf(TWO)
    with pytest.raises(ValueError) as e:
        session(robot, values())
    assert str(e.value).startswith("initial_positions (not set: zeros): j1 = 0.0 is outside "
                                   "its limits [0.5, 1.5]")
    assert e.value.args[0].endswith("-p initial_positions:=[1.0000, 1.0000]")
    with pytest.raises(ValueError, match=r"j2 = 3.5 is outside its limits \[-1.0, 3.0\]"):
        session(robot, values(initial_positions=[1.0, 3.5]))
    s, _ = session(robot, values(initial_positions=[0.7, -0.5]))
    np.testing.assert_array_equal(s.q, [0.7, -0.5])


@pytest.mark.parametrize("change, words", [
    ({"sim_dt": 0.0}, "'sim_dt' must be > 0, got 0.0"),
    ({"publish_rate": -1.0}, "'publish_rate' must be > 0, got -1.0"),
    ({"clock_rate": float("inf")}, "'clock_rate' must be > 0, got inf"),
    ({"servo.kp": [float("inf")]}, "'servo.kp' and 'servo.kd' must be finite"),
    ({"command_timeout_action": "stop"}, "command_timeout_action 'stop' unknown")])
def test_bad_values_are_named(change, words):
    with pytest.raises(ValueError, match=words.replace("(", r"\(")):
        session(UR5E, values(**change))


def test_a_wrong_count_is_a_startup_error():
    with pytest.raises(parameters.StartupError, match="'effort_limits' has 2 values"):
        session(UR5E, values(effort_limits=[1.0, 2.0]))


def test_the_lines_to_log():
    _, notes = session(UR5E, values(sim_dt=0.02, integrator="rk4"))
    assert [level for level, _ in notes] == ["warning", "warning"]
    assert "sim_dt = 0.02 s is a coarse step (above 0.01 s)" in notes[0][1]
    assert notes[1][1] == ("command_timeout_action 'brake' needs the joint servo (integrator "
                           "semi_implicit_euler or symplectic_euler): the arm goes limp at the "
                           "timeout")


def test_a_floating_base_starts_from_initial_base_pose_normalized():
    sat = sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))
    s, notes = session(sat, values(floating_base=True,
                                   initial_base_pose=[1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 2.0]))
    assert s.has_base and notes == [] and s.integrator.stops is None   # the satellite: no limits
    ur5e_floating = sd.load_urdf(sd.builtin_path(), floating_base=True)
    assert session(ur5e_floating, values(floating_base=True))[0].integrator.stops is not None
    np.testing.assert_array_equal(s.q0[:7], [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="initial_base_pose has a quaternion"):
        session(sat, values(initial_base_pose=[0.0] * 7))
    # a fixed base never reads initial_base_pose
    assert not session(UR5E, values(initial_base_pose=[0.0] * 7))[0].has_base
