"""A bad URDF or parameter at start-up: the node exits with a non-zero status and one
paragraph that names the culprit -- no traceback."""
import pytest

import serial_dynamics as sd

NEG_MASS = open(sd.builtin_path("planar_3r")).read().replace('<mass value="2.0"/>',
                                                             '<mass value="-2.0"/>')


def cases(tmp):
    broken = tmp / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    negative = tmp / "negative_mass.urdf"
    negative.write_text(NEG_MASS)
    return [   # (node, parameters, text the message must contain)
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
    ]


def test_bad_start_up_exits_with_one_paragraph(ros, tmp_path):
    procs = [(ros.start(node, params, expect_running=False), text)
             for node, params, text in cases(tmp_path)]
    for p, text in procs:
        ros.spin_until(lambda: not p.running(), 150, f"{p.module} {p.cmd[-1]} to exit")
        out = p.output()
        assert p.proc.returncode == 2, out
        assert "Traceback" not in out, out
        errors = [line for line in out.splitlines() if "cannot start" in line]
        assert len(errors) == 1 and errors[0].startswith(f"{p.module}: cannot start: "), out
        assert text in errors[0], out
        # the paragraph is the last thing printed; before it at most the robot's info line
        assert out.rstrip().endswith(errors[0]) and len(out.strip().splitlines()) <= 2, out
