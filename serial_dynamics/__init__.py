"""serial_dynamics: fast, tested dynamics of serial manipulators from URDF.

    import serial_dynamics as sd
    robot = sd.load_urdf("arm.urdf", base_link="base_link", tip_link="tool0")
    tau = robot.inverse_dynamics(q, qd, qdd)

The core library never imports rclpy; the ROS 2 nodes live in ``serial_dynamics.ros``.
"""
from .model import Dissipation, Model, ModelError, RobotDescriptionError
from .model.errors import HeldJointsWarning, InertiaRepairWarning, SimulationError, URDFError
from .contacts import Contact, Ground
from .robot import BaseMotion, Robot
from .builtin import builtin_path, builtin_robot, default_robot
from .sim.driver import simulate   # sd.simulate is the function
from .urdf import load_model

__all__ = ["load_urdf", "Robot", "Model", "Dissipation", "RobotDescriptionError", "URDFError",
           "ModelError", "HeldJointsWarning", "InertiaRepairWarning", "default_robot",
           "builtin_robot", "builtin_path", "simulate", "SimulationError", "BaseMotion", "Contact",
           "Ground"]
__version__ = "0.1.0"


def load_urdf(source, base_link=None, tip_link=None, gravity=(0.0, 0.0, -9.81),
              armature=None, floating_base=False, tip_links=None,
              repair_inertia=False) -> Robot:
    """Load a robot from a URDF (file path or XML string): the chain ``base_link`` ->
    ``tip_link``, the subtree from ``base_link`` to the links ``tip_links``, or (neither
    given) every movable joint below ``base_link``: one chain when they form a single path,
    else the whole tree (two arms, legs, fingers), bodies parents first.

    ``base_link`` defaults to the URDF root. Movable joints outside the model are held at
    zero and lumped, with a ``HeldJointsWarning`` naming them. ``gravity`` (m/s^2) is given in the URDF root's
    frame and carried into the base frame. ``armature``: {joint name: reflected rotor
    inertia, kg m^2 (kg for a prismatic joint)}, which sets or overrides what the URDF's
    ``<transmission>`` elements give. Raises ``URDFError`` (the file cannot be read) or
    ``ModelError`` (the chain is not physical), both ``RobotDescriptionError``s.
    ``floating_base=True`` (or a ``type="floating"`` joint at the URDF root) makes the base
    link, with everything lumped into it, float: a ``FloatingRobot`` (gravity in the world
    frame; docs/modelling.md).
    Physical consistency is judged on the bodies the dynamics uses (links joined by fixed
    joints lumped): a body whose inertia is no rigid body's is a ``ModelError``, or with
    ``repair_inertia=True`` gets the nearest physical inertia (mass, center of mass and
    principal axes kept), with one ``InertiaRepairWarning`` per body.
    """
    return Robot(load_model(source, base_link, tip_link, gravity, armature=armature,
                            floating_base=floating_base, tip_links=tip_links,
                            repair_inertia=repair_inertia))

