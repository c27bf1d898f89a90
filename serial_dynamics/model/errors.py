"""Every exception (and warning) class of the library, in one place.

The ROS layer keeps its own (``ros.common.Rejected``, a refused message; ``ros.parameters.
StartupError``; the demo's ``DemoError``): they never leave a node.
"""


class RobotDescriptionError(ValueError):
    """The robot description cannot be used: the URDF cannot be read (``URDFError``) or the
    chain it describes is not a valid dynamic model (``ModelError``). Catch this one for
    both; the message names the link, joint or element at fault and what is expected."""


class ModelError(RobotDescriptionError):
    """The chain is not a valid dynamic model (negative mass, an inertia no rigid body has,
    an absurd magnitude, a singular mass matrix, ...)."""


class URDFError(RobotDescriptionError):
    """The URDF cannot be read or does not describe a usable serial chain."""


class HeldJointsWarning(UserWarning):
    """Movable joints off the chain were held at zero and lumped into the chain."""


class SimulationError(RuntimeError):
    """The simulation diverged (NaN/Inf, a state out of bounds, energy growing).

    Attributes: ``t`` (s, time of detection), ``joint`` (name or None), ``reason``.
    """

    def __init__(self, message, t=None, joint=None, reason=None):
        super().__init__(message)
        self.t, self.joint, self.reason = t, joint, reason
