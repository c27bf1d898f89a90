"""Analytical derivatives of inverse and forward dynamics.

(Being written: see issue 12.)
"""


def inverse_dynamics_derivatives(robot, q, qd, qdd, wrench=None, base_motion=None):
    raise NotImplementedError("inverse_dynamics_derivatives: not yet implemented")


def forward_dynamics_derivatives(robot, q, qd, tau, wrench=None, base_motion=None):
    raise NotImplementedError("forward_dynamics_derivatives: not yet implemented")
