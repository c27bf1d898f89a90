"""What the robot is: the immutable, validated ``Model`` and what it is made of.

    model.py        Model: the chain as given (URDF frames) and in joint frames; validate()
    inertia.py      one body's inertia: physical checks and repair, magnitude bounds, lumping
    payload.py      a payload rigidly attached to a link (Robot.with_payload)
    links.py        the links a call may name: one resolver for every call that takes one
    dissipation.py  joint friction: viscous, Coulomb, Coulomb with a low-speed rise
    errors.py       every exception class of the library
"""
from .dissipation import Dissipation
from .errors import ModelError, RobotDescriptionError
from .model import Model

__all__ = ["Model", "Dissipation", "ModelError", "RobotDescriptionError"]
