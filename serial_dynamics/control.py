"""The library's model-based joint control laws, as pure functions (no ROS): the
computed-torque controller node and ``sweep.monte_carlo`` both call them.

With e = q_d - q, edot = qd_d - qd and the feed-forward acceleration qdd_d:

    computed_torque       tau = M(q) (qdd_d + Kp e + Kd edot) + b(q, qd)
                          (inverse dynamics at the commanded acceleration: one Newton-Euler call)
    pd_gravity            tau = Kp' e + Kd' edot + g(q)
    gravity_compensation  tau = g(q)
                          [- delta(qd) in each mode when compensating the joint dissipation]

(Siciliano et al., Robotics: Modelling, Planning and Control, 2009, Sec. 8.5.2 (PD with
gravity compensation) and 8.5.3 (inverse dynamics control)). Kp, Kd are in 1/s^2 and 1/s
for computed torque (they shape the error dynamics e'' + Kd e' + Kp e = 0), in N m/rad and
N m s/rad for pd_gravity (``pd_gains`` gives the usual defaults).
"""
from __future__ import annotations

import numpy as np

MODES = ("computed_torque", "pd_gravity", "gravity_compensation")


def pd_gains(robot, kp, kd):
    """Default pd_gravity gains: the computed-torque gains times the diagonal of M(0)."""
    m0 = np.diag(robot.mass_matrix(np.zeros(robot.dof)))
    return kp * m0, kd * m0


def torque(robot, mode, q, qd, e, ed, qdd_ff, kp, kd, compensate=False):
    """The joint torques of law ``mode`` (one of MODES) at the state (q, qd), tracking error
    (e, ed), feed-forward acceleration qdd_ff, with that law's gains kp, kd."""
    if mode == "computed_torque":
        tau = robot.inverse_dynamics(q, qd, qdd_ff + kp * e + kd * ed)
    elif mode == "pd_gravity":
        tau = kp * e + kd * ed + robot.gravity_torques(q)
    elif mode == "gravity_compensation":
        tau = robot.gravity_torques(q)
    else:
        raise ValueError(f"control law {mode!r} unknown; use one of {', '.join(MODES)}")
    if compensate:
        tau = tau - robot.dissipation_torques(qd)
    return tau
