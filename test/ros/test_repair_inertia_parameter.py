"""The nodes' ``repair_inertia`` parameter (read-only, default false) reaches the loader
(``parameters.load_robot``, which every node calls): false stops the node at start-up with a
message naming the body and the parameter; true loads the repaired robot and logs the
loader's warning, one per repaired body."""
import pytest

from serial_dynamics.ros import (computed_torque_controller, dynamics, external_torque_observer,
                                 parameters, simulator_parameters)

# link2: principal moments (0.01, 0.01, 0.05) kg m^2, no rigid body's; link1 is physical
BAD = ('<robot name="bad"><link name="base"/>'
       '<link name="link1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" '
       'izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
       '<link name="link2"><inertial><origin xyz="0 0 0.1"/><mass value="1"/><inertia '
       'ixx="0.01" iyy="0.01" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial></link>'
       '<joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>'
       '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>'
       '<joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>'
       '<origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>'
       '<limit lower="-3" upper="3" effort="10" velocity="1"/></joint></robot>')


class Logger:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(("info", text))

    def warning(self, text):
        self.lines.append(("warning", text))


class Node:
    """What load_robot uses of a node when the robot comes from a parameter."""

    def __init__(self):
        self.logger = Logger()

    def get_logger(self):
        return self.logger


def values(**changes):
    return {**parameters.defaults(parameters.ROBOT_PARAMETERS), "robot_description": BAD,
            **changes}


@pytest.mark.parametrize("spec", [dynamics.PARAMETERS, simulator_parameters.PARAMETERS,
                                  computed_torque_controller.PARAMETERS,
                                  external_torque_observer.PARAMETERS],
                         ids=["dynamics", "simulator", "controller", "observer"])
def test_every_node_takes_it_read_only_default_false(spec):
    kind, default, text = spec["repair_inertia"]
    assert (kind, default) == ("bool", False) and "nearest physical" in text
    assert "repair_inertia" not in parameters.WRITABLE


def test_false_stops_the_node_naming_the_body_and_the_parameter():
    with pytest.raises(parameters.StartupError) as e:
        parameters.load_robot(Node(), values())
    msg = str(e.value)
    assert msg.startswith("cannot load the robot from the robot_description parameter: "
                          "link 'link2' (the body of joint 'j2'): principal moments"), msg
    assert "repair_inertia:=true" in msg


def test_true_loads_the_repaired_robot_and_logs_one_warning_per_body():
    node = Node()
    robot = parameters.load_robot(node, values(repair_inertia=True))
    warned = [text for level, text in node.logger.lines if level == "warning"]
    assert len(warned) == 1 and warned[0].startswith("link 'link2' (the body of joint 'j2'): "
                                                     "inertia not physical")
    assert "to [0.025, 0.025, 0.05] kg m^2" in warned[0]
    assert robot.joint_names == ["j1", "j2"]
    assert abs(robot.model.inertia[1][2, 2] - 0.05) < 1e-15
    assert abs(robot.model.inertia[1][0, 0] - 0.025) < 1e-15
