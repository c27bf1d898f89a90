"""The exceptions of a bad robot description (a URDF, or a model built by hand)."""


class RobotDescriptionError(ValueError):
    """The robot description cannot be used: the URDF cannot be read (``URDFError``) or the
    chain it describes is not a valid dynamic model (``ModelError``). Catch this one for
    both; the message names the link, joint or element at fault and what is expected."""


class ModelError(RobotDescriptionError):
    """The chain is not a valid dynamic model (negative mass, an inertia no rigid body has,
    an absurd magnitude, a singular mass matrix, ...)."""
