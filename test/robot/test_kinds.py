"""The kinds of robot: ``kind_of`` chooses, each kind overrides, nobody else asks.

- ``kind_of(model)`` (robot/facade.py) picks the facade a model needs, and ``sd.Robot(model)``,
  ``sd.load_urdf`` and ``with_payload`` build that kind;
- no module outside ``serial_dynamics/robot/`` reads a private attribute of a robot
  (``robot._mimic``, ``robot._P``, ``robot._reduce(...)``): it asks the facade's public
  methods, which each kind overrides.
"""
import ast
import os

import pytest

import serial_dynamics as sd
from serial_dynamics.core.planar_layout import planar_pack
from serial_dynamics.robot import FloatingMimicRobot, MimicRobot, PlanarRobot, Robot, kind_of

from test_mimic import mimic_chain

PKG = os.path.dirname(os.path.abspath(sd.__file__))


def planar_mimic():
    """The planar 3R with its last joint mimicking the second: planar and mimic at once."""
    xml = sd.builtin.planar_3r_urdf()
    tail = '<joint name="joint3"'
    i = xml.index(tail)
    j = xml.index("</joint>", i)
    joint = xml[i:j] + '<mimic joint="joint2" multiplier="0.5"/>'
    return xml[:i] + joint + xml[j:]


@pytest.mark.parametrize("source, kind", [
    ("ur5e", Robot),
    ("planar_3r", PlanarRobot),
    ("mimic", MimicRobot),
    ("planar+mimic", MimicRobot),         # the reduction comes first
    ("floating+mimic", FloatingMimicRobot),
])
def test_kind_of_chooses_and_every_constructor_builds_it(source, kind):
    xml = {"ur5e": sd.builtin.ur5e_urdf, "planar_3r": sd.builtin.planar_3r_urdf,
           "mimic": mimic_chain, "planar+mimic": planar_mimic,
           "floating+mimic": mimic_chain}[source]()
    robot = sd.load_urdf(xml, floating_base=source.startswith("floating"))
    assert kind_of(robot.model) is kind
    assert type(robot) is kind
    assert type(sd.Robot(robot.model)) is kind
    assert type(sd.Robot(robot.model, backend="numpy")) is kind
    assert type(robot.with_payload(0.5)) is kind
    assert type(robot.with_payload(0.5).without_payload()) is kind
    assert robot.is_planar == (kind is PlanarRobot)
    if source == "planar+mimic":
        assert planar_pack(robot.model) is not None and robot.model.has_mimic_joints


def _private_robot_accesses(path):
    """(line, text) of every ``<x>._name`` where <x> is a name or attribute called robot."""
    tree = ast.parse(open(path).read())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") \
                and not node.attr.startswith("__"):
            v = node.value
            owner = v.id if isinstance(v, ast.Name) else v.attr if isinstance(v, ast.Attribute) else ""
            if owner in ("robot", "plant", "model_robot"):
                out.append((node.lineno, ast.unparse(node)))
    return out


def test_nothing_outside_robot_reads_a_robots_private_attributes():
    found = []
    for dirpath, _, files in os.walk(PKG):
        if os.path.relpath(dirpath, PKG).split(os.sep)[0] == "robot":
            continue
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(dirpath, f)
                found += [f"{os.path.relpath(path, PKG)}:{ln}: {t}"
                          for ln, t in _private_robot_accesses(path)]
    assert not found, "ask the facade instead:\n" + "\n".join(found)


def test_the_private_access_finder_finds_one():
    """The check above is not vacuous: it finds a planted access."""
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write("def f(robot, self):\n    return robot._mimic or self.robot._P\n")
    try:
        assert sorted(t for _, t in _private_robot_accesses(f.name)) == ["robot._mimic",
                                                                         "self.robot._P"]
    finally:
        os.unlink(f.name)
