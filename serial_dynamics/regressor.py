"""The torque regressor Y(q, qd, qdd): inverse dynamics linear in the inertial parameters.

(Being written: see issue 10.)
"""


def regressor(robot, q, qd, qdd, friction=False):
    raise NotImplementedError("regressor: not yet implemented")


def inertial_parameters(robot, friction=False):
    raise NotImplementedError("inertial_parameters: not yet implemented")
