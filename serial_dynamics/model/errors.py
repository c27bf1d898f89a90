"""Every exception (and warning) class of the library, in one place.

``Rejected`` is an input that a running loop refuses (a message to a node, a trajectory or
a sample given to ``loops/``), with the cause its repeats are grouped by when logged. The ROS
layer keeps its own others (``ros.parameters.StartupError``; the demo's ``DemoError``): they
never leave a node.
"""
import re

# A quoted name longer than this is cut in a message (its start, its end and its length are
# kept: the end of a long path is the file's name).
MAX_NAME = 80
# (a name: quoted, without white space, which tells it from the prose between two names)
_LONG_NAME = re.compile(r"'([^'\s]{%d,})'|\"([^\"\s]{%d,})\"" % (MAX_NAME + 1, MAX_NAME + 1))


def cut_long_names(message: str) -> str:
    """``message`` with every quoted name of more than MAX_NAME characters cut to its first
    30 and its last 30, followed by its length: 'LLLL...LLLL' (1000000 characters)."""
    def cut(match):
        name = match.group(1) if match.group(1) is not None else match.group(2)
        return f"'{name[:30]}...{name[-30:]}' ({len(name)} characters)"
    return _LONG_NAME.sub(cut, message)


class RobotDescriptionError(ValueError):
    """The robot description cannot be used: the URDF cannot be read (``URDFError``) or the
    chain it describes is not a valid dynamic model (``ModelError``). Catch this one for
    both; the message names the link, joint or element at fault and what is expected (a
    name too long to read is cut, ``cut_long_names``)."""

    def __init__(self, message="", *args):
        super().__init__(cut_long_names(message) if isinstance(message, str) else message,
                         *args)


class ModelError(RobotDescriptionError):
    """The chain is not a valid dynamic model (negative mass, an inertia no rigid body has,
    an absurd magnitude, a singular mass matrix, ...)."""


class URDFError(RobotDescriptionError):
    """The URDF cannot be read or does not describe a usable serial chain."""


class HeldJointsWarning(UserWarning):
    """Movable joints off the chain were held at zero and lumped into the chain."""


class InertiaRepairWarning(UserWarning):
    """A body's inertia was no rigid body's and ``repair_inertia=True`` replaced it by the
    nearest physical one (``model.inertia.physical_body``); one per body, naming it and its
    principal moments before and after."""


class SimulationError(RuntimeError):
    """The simulation diverged (NaN/Inf, a state out of bounds, energy growing).

    Attributes: ``t`` (s, time of detection), ``joint`` (name or None), ``reason``.
    """

    def __init__(self, message, t=None, joint=None, reason=None):
        super().__init__(message)
        self.t, self.joint, self.reason = t, joint, reason


class Rejected(ValueError):
    """An input refused (a message, a request, a trajectory, a sample); ``cause`` groups
    repeats for throttled logging; the text names the culprit and the fix. What was in
    force before stays in force."""

    def __init__(self, cause: str, text: str):
        super().__init__(text)
        self.cause = cause
