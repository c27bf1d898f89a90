"""Simulation of the state equations  qdd = M^-1 (tau + delta(qd) - b(q, qd) + J^T w).

(Interface stub: the full simulator -- adaptive and fixed-step methods, stick-slip,
divergence checks, results -- is being built on this.)
"""
from __future__ import annotations

import numpy as np


class SimulationError(RuntimeError):
    """The simulation diverged (NaN/Inf, a state out of bounds, energy growing)."""


class FixedStepIntegrator:
    """One fixed step at a time, for real-time use (the simulator node).

    ``step(q, qd, tau, wrench=None) -> (q, qd)`` advances by ``dt`` seconds with the
    robot's dissipation added when ``dissipation`` is true.
    """

    METHODS = ("semi_implicit_euler",)

    def __init__(self, robot, method="semi_implicit_euler", dt=1e-3, dissipation=True):
        if method not in self.METHODS:
            raise ValueError(f"fixed-step method {method!r} unknown; use one of {self.METHODS}")
        if not dt > 0:
            raise ValueError(f"dt = {dt}; the step must be > 0 s")
        self.robot, self.method, self.dt, self.dissipation = robot, method, float(dt), dissipation

    def step(self, q, qd, tau, wrench=None):
        robot, dt = self.robot, self.dt
        tau = np.asarray(tau, dtype=float)
        if self.dissipation and robot.dissipation.enabled:
            tau = tau + robot.dissipation.torque(qd)
        qdd = robot.forward_dynamics(q, qd, tau, wrench)
        qd_new = qd + dt * qdd            # semi-implicit (symplectic) Euler: velocity first,
        return q + dt * qd_new, qd_new    # then position with the new velocity
