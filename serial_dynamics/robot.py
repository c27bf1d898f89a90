"""``Robot``: the friendly facade over a ``Model`` and the algorithms.

It holds the immutable model and the dissipation model, checks inputs, and calls the
algorithm functions. Every state argument accepts ``(n,)`` or a batch ``(N, n)``.
"""
from __future__ import annotations

import numpy as np

from .algorithms import energy, forward, kinematics, mass_matrix, noc, rnea
from .dissipation import Dissipation
from .model import Model


class Robot:
    """Dynamics of one serial chain. Build it with ``serial_dynamics.load_urdf``."""

    def __init__(self, model: Model, dissipation: Dissipation | None = None):
        self.model = model
        self._dissipation = Dissipation.from_model(model) if dissipation is None else dissipation

    # ------------------------------------------------------------- description
    dof = property(lambda self: self.model.dof)
    joint_names = property(lambda self: list(self.model.joint_names))
    joint_types = property(lambda self: list(self.model.joint_types))
    link_names = property(lambda self: list(self.model.link_names))
    base_link = property(lambda self: self.model.base_link)
    tip_link = property(lambda self: self.model.tip_link)
    gravity = property(lambda self: self.model.gravity)
    lower = property(lambda self: self.model.lower)
    upper = property(lambda self: self.model.upper)
    velocity_limit = property(lambda self: self.model.velocity_limit)
    effort_limit = property(lambda self: self.model.effort_limit)

    @property
    def dissipation(self) -> Dissipation:
        """Joint friction model (defaults from URDF <dynamics>); replace it with
        ``robot.dissipation = robot.dissipation.override(coulomb={...})``."""
        return self._dissipation

    @dissipation.setter
    def dissipation(self, value: Dissipation):
        if not isinstance(value, Dissipation) or value.joint_names != self.model.joint_names:
            raise ValueError("dissipation must be a serial_dynamics.Dissipation for the joints "
                             f"{self.joint_names}")
        self._dissipation = value

    def __repr__(self):
        return (f"Robot({self.model.name!r}, dof={self.dof}, {self.base_link!r} -> "
                f"{self.tip_link!r}, joints={self.joint_names})")

    # ------------------------------------------------------------- dynamics
    def inverse_dynamics(self, q, qd, qdd, wrench=None):
        """tau = M(q) qdd + b(q, qd) - J^T w  (rigid body; no friction). N m / N."""
        return rnea.inverse_dynamics(self.model, q, qd, qdd, wrench)

    def mass_matrix(self, q):
        """M(q), the generalized inertia matrix."""
        return mass_matrix.mass_matrix(self.model, q)

    def bias_torques(self, q, qd, wrench=None):
        """b(q, qd) - J^T w = C(q, qd) qd + g(q) - J^T w."""
        return rnea.inverse_dynamics(self.model, q, qd, None, wrench)

    def gravity_torques(self, q):
        """g(q): the torques that hold the chain still (the textbook's gamma is -g)."""
        return rnea.inverse_dynamics(self.model, q, None, None)

    def coriolis_matrix(self, q, qd):
        """C(q, qd) from the natural orthogonal complement: C qd + g = b, Mdot - 2C skew."""
        return noc.coriolis_matrix(self.model, q, qd)

    def forward_dynamics(self, q, qd, tau, wrench=None, method="cholesky"):
        """qdd for applied torques tau (rigid body). ``method``: "cholesky" or "qr"."""
        return forward.forward_dynamics(self.model, q, qd, tau, wrench, method)

    def dissipation_torques(self, qd):
        """delta(qd) of the current dissipation model (oppose the motion)."""
        return self._dissipation.torque(qd)

    # ------------------------------------------------------------- kinematics, energy
    def forward_kinematics(self, q, link=None):
        """4x4 pose of ``link`` (default: the tip) in the base frame."""
        return kinematics.forward_kinematics(self.model, q, link)

    def jacobian(self, q, link=None):
        """6 x n geometric Jacobian of ``link``'s origin, [linear; angular], base frame."""
        return kinematics.jacobian(self.model, q, link)

    def kinetic_energy(self, q, qd):
        return energy.kinetic_energy(self.model, q, qd)

    def potential_energy(self, q):
        return energy.potential_energy(self.model, q)

    def total_energy(self, q, qd):
        return self.kinetic_energy(q, qd) + self.potential_energy(q)

    def warmup(self):
        """Compile or load every fast path once, so that the first real call is fast.
        Nodes call this before they report ready. Returns self."""
        q = np.zeros(self.dof)
        self.inverse_dynamics(q, q, q)
        self.forward_dynamics(q, q, q)
        return self

    def random_state(self, rng=None, batch=None, speed=1.0):
        """(q, qd) drawn uniformly within the joint limits (+-pi where unlimited) and
        velocities in +-speed; handy for tests and benchmarks."""
        rng = np.random.default_rng(rng)
        shape = (self.dof,) if batch is None else (batch, self.dof)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        return rng.uniform(lo, hi, shape), rng.uniform(-speed, speed, shape)
