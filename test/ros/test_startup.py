"""A bad URDF or parameter at start-up: the node exits with a non-zero status and one
paragraph that names the culprit -- no traceback."""

import serial_dynamics as sd

from conftest import wait_for_log

NEG_MASS = open(sd.builtin_path("planar_3r")).read().replace('<mass value="2.0"/>',
                                                             '<mass value="-2.0"/>')


# a robot whose zero pose is outside its limits (as the Panda's): joint2 in [0.5, 2.0]
LIMITED = open(sd.builtin_path("planar_3r")).read().replace(
    '<joint name="joint2" type="continuous">', '<joint name="joint2" type="revolute">').replace(
    '<limit effort="100" velocity="10"/></joint>\n<link name="link3"',
    '<limit effort="100" velocity="10" lower="0.5" upper="2.0"/></joint>\n<link name="link3"')


def cases(tmp):
    broken = tmp / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    negative = tmp / "negative_mass.urdf"
    negative.write_text(NEG_MASS)
    limited = tmp / "limited.urdf"
    limited.write_text(LIMITED)
    assert LIMITED.count('lower="0.5"') == 1
    return [   # (node, parameters, text the message must contain[, text it must not])
        # ranges in the parameter descriptors: rclpy's check (a double), ours (an integer)
        ("simulator", {"real_time_factor": -1.0}, "Parameter real_time_factor out of range "
         "Min: 0.0, Max: 1000000.0, value: -1.0", "command_timeout"),
        ("simulator", {"real_time_factor": -1}, "parameter 'real_time_factor' = -1.0 is out "
         "of its range [0, 1e+06]"),
        ("simulator", {"step_count": 0}, "Parameter step_count out of range"),
        ("simulator", {"urdf_path": str(limited)},    # the fix, with numbers that work
         "joint2 = 0.0 is outside its limits [0.5, 2.0]; give positions within the limits, "
         "e.g. the middle of each range: -p initial_positions:=[0.0000, 1.2500, 0.0000]"),
        ("simulator", {"urdf_path": str(tmp / "missing.urdf")}, "missing.urdf"),
        ("inverse_dynamics", {"urdf_path": str(broken)}, "broken.urdf"),
        ("computed_torque_controller", {"urdf_path": str(negative)}, "mass"),
        ("inverse_dynamics", {"tip_link": "no_such_link"}, "no_such_link"),
        ("simulator", {"sim_dt": -0.001}, "sim_dt"),
        ("simulator", {"integrator": "rk99"}, "rk99"),
        ("simulator", {"publish_rate": "fast"}, "publish_rate"),
        ("simulator", {"initial_positions": [0.0, 7.0, 0.0, 0.0, 0.0, 0.0]}, "shoulder_lift_joint"),
        ("simulator", {"initial_positions": [0.0, 1]}, "ROS arguments"),   # rcl refuses mixed lists
        ("simulator", {"effort_limits": [1.0, 2.0]}, "effort_limits"),
        ("computed_torque_controller", {"kp": [1.0, 2.0, 3.0]}, "kp"),
        ("computed_torque_controller", {"dissipation.joints": ["elbow"]}, "dissipation.joints"),
        ("inverse_dynamics", {"gravity": [0.0, -9.81]}, "gravity"),
        ("simulator", {"floating_base": True, "initial_base_pose": [0.0] * 7},
         "initial_base_pose has a quaternion [qx, qy, qz, qw] = [0.0, 0.0, 0.0, 0.0] of length 0"),
        # the ground and its contacts (issue 51): the parameter and the fix
        ("simulator", {"contacts": ["tool0", "tool9"]}, "parameter 'contacts' [1]: link 'tool9' "
         "is not a link of the model; its links are"),
        ("simulator", {"contacts": ["tool0"], "ground.friction": 0.0}, "parameter "
         "'ground.friction' must be > 0 (Coulomb's coefficient, e.g. 1.0), got 0.0"),
        ("simulator", {"contacts": ["tool0"], "ground.normal": [0.0, 0.0, 0.0]}, "parameter "
         "'ground.normal' must be 3 numbers, not all zero"),
    ]


def test_bad_start_up_exits_with_one_paragraph(ros, tmp_path):
    procs = [(ros.start(node, params, expect_running=False), text, absent)
             for node, params, text, absent in [(*c, None)[:4] for c in cases(tmp_path)]]
    for p, text, absent in procs:
        ros.spin_until(lambda: not p.running(), 150, f"{p.module} {p.cmd[-1]} to exit")
        out = p.output()
        assert p.proc.returncode == 2, out
        assert "Traceback" not in out, out
        errors = [line for line in out.splitlines() if "cannot start" in line]
        assert len(errors) == 1 and errors[0].startswith(f"{p.module}: cannot start: "), out
        assert text in errors[0], out
        assert absent is None or absent not in errors[0], out
        # the paragraph is the last thing printed; before it at most the robot's info line
        assert out.rstrip().endswith(errors[0]) and len(out.strip().splitlines()) <= 2, out


def test_start_up_warnings_name_the_coarse_step_the_unknown_parameters_and_the_wait(ros):
    """sim_dt:=1 (0.001 meant), a parameter of another node and the robot_description wait
    are said once at start-up; the node runs on."""
    p = ros.start("simulator", {"sim_dt": 1.0, "kp": [1.0], "robot_description_timeout": 0.3,
                                "start_paused": True}, ros_args=["-r", "__ns:=/warned"])
    for text in ("waiting up to 0.3 s for a robot_description message (neither urdf_path nor "
                 "robot_description is set; robot_description_timeout:=0 skips the wait)",
                 "sim_dt = 1.0 s is a coarse step (above 0.01 s)",
                 "ignoring unknown parameter(s) ['kp']: simulator takes urdf_path, ",
                 "initial_positions, ", "ready"):
        wait_for_log(ros, p, text)
    out = p.output()
    assert out.count("unknown parameter") == 1 and out.count("coarse") == 1, out
    assert p.running()
    p.stop()
