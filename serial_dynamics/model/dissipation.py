"""Joint dissipation (friction) models, per joint, as functions of the joint rate qd.

Dissipation function Delta(qd) and generalized dissipative torques delta = -dDelta/dqd
(Angeles, *Fundamentals of Robotic Mechanical Systems*, Sec. 7.8):

    viscous                 delta = -beta qd                     Delta = 1/2 beta qd^2
    Coulomb                 delta = -tau_c sgn(qd)               Delta = tau_c |qd|
    Coulomb, low-speed rise delta = -(tau_c + eps e^{-gamma|qd|}) sgn(qd)
                            Delta = tau_c |qd| + (eps/gamma)(1 - e^{-gamma|qd|})

URDF ``<dynamics damping="beta" friction="tau_c"/>`` gives the defaults. Rigid-body
methods never include these; the simulator and the nodes add them when enabled.
The static (breakaway) torque of a joint is tau_c + eps.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .inertia import MAX_DAMPING, MAX_FRICTION


# the torques' coefficients are bounded as the URDF's (inertia.py): finite at any finite speed
_BOUNDS = {"viscous": MAX_DAMPING, "coulomb": MAX_FRICTION, "stribeck": MAX_FRICTION}


@dataclass(frozen=True, eq=False)
class Dissipation:
    """Per-joint coefficients, arrays of length n, all >= 0 (SI: N m s/rad, N m, s/rad)."""

    joint_names: tuple
    viscous: np.ndarray          # beta
    coulomb: np.ndarray          # tau_c
    stribeck: np.ndarray         # eps, extra static torque at rest
    stribeck_rate: np.ndarray    # gamma, decay rate of the low-speed rise

    FIELDS = ("viscous", "coulomb", "stribeck", "stribeck_rate")

    def __post_init__(self):
        n = len(self.joint_names)
        for name in self.FIELDS:
            a = np.array(getattr(self, name), dtype=float).reshape(-1)
            if a.shape != (n,):
                raise ValueError(f"dissipation {name} has {a.size} values; give one per joint "
                                 f"({n}: {list(self.joint_names)})")
            bound = _BOUNDS.get(name, np.inf)
            bad = np.flatnonzero(~np.isfinite(a) | (a < 0) | (a > bound))
            if bad.size:
                raise ValueError(f"dissipation {name} of joint {self.joint_names[bad[0]]!r} is "
                                 f"{a[bad[0]]}; coefficients must be finite and >= 0"
                                 + (f", and at most {bound:g} (beyond any robot)"
                                    if np.isfinite(bound) else ""))
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @classmethod
    def from_model(cls, model):
        """Defaults from the URDF: viscous = damping, Coulomb = friction, no low-speed rise."""
        zero = np.zeros(model.dof)
        return cls(model.joint_names, model.damping, model.friction, zero, zero)

    @classmethod
    def none(cls, joint_names):
        zero = np.zeros(len(joint_names))
        return cls(tuple(joint_names), zero, zero, zero, zero)

    def override(self, **per_joint) -> "Dissipation":
        """New model with some coefficients replaced, e.g.
        ``override(coulomb={"elbow_joint": 2.0}, viscous=0.1)`` (a scalar sets every joint)."""
        changes = {}
        for name, values in per_joint.items():
            if name not in self.FIELDS:
                raise ValueError(f"unknown dissipation coefficient {name!r}; use {self.FIELDS}")
            a = np.array(getattr(self, name))
            if isinstance(values, dict):
                for joint, v in values.items():
                    if joint not in self.joint_names:
                        raise ValueError(f"dissipation override names joint {joint!r}, which "
                                         f"is not a joint of the model {list(self.joint_names)}")
                    a[self.joint_names.index(joint)] = v
            else:   # a scalar sets every joint; an array is checked for length on rebuild
                v = np.asarray(values, dtype=float)
                a = np.full(a.shape, v) if v.ndim == 0 else v
            changes[name] = a
        return replace(self, **changes)

    @property
    def enabled(self) -> bool:
        """False when every coefficient is zero (the term then costs nothing)."""
        return any(np.any(getattr(self, f) > 0) for f in ("viscous", "coulomb", "stribeck"))

    @property
    def static_friction(self) -> np.ndarray:
        """Breakaway torque at rest, tau_c + eps."""
        return self.coulomb + self.stribeck

    def sliding_friction(self, qd):
        """Magnitude of the Coulomb friction while sliding, tau_c + eps e^(-gamma |qd|)."""
        return self.coulomb + self.stribeck * np.exp(-self.stribeck_rate * np.abs(qd))

    def torque(self, qd):
        """delta(qd): dissipative joint torques (they oppose the motion); sgn(0) = 0."""
        qd = np.asarray(qd, dtype=float)
        return -self.viscous * qd - self.sliding_friction(qd) * np.sign(qd)

    def smooth_torque(self, qd, v_eps=1e-3):
        """delta with sgn(qd) regularized to tanh(qd / v_eps): continuous, for adaptive
        integrators. The error against ``torque`` is below 2 tau_s e^{-2|qd|/v_eps}
        (1 - tanh x = 2 e^{-2x} / (1 + e^{-2x}))."""
        qd = np.asarray(qd, dtype=float)
        return -self.viscous * qd - self.sliding_friction(qd) * np.tanh(qd / v_eps)

    def torque_derivative(self, qd, smooth=False, v_eps=1e-3, sign=None):
        """d delta / d qd of ``torque`` (or of ``smooth_torque(qd, v_eps)`` with
        ``smooth=True``): delta_i depends on qd_i only, so the Jacobian is diagonal and this
        returns its diagonal, shape of ``qd`` ((n,) or (N, n)); ``np.diag`` of it is the matrix.

            viscous                  -beta
            Coulomb, low-speed rise  + eps gamma e^{-gamma|qd|} sgn(qd) s   (s = sgn(qd);
                                     with ``sign``: the fixed sliding direction s of a step)
            smooth (tanh)            - (tau_c + eps e^{-gamma|qd|}) (1 - tanh^2(qd/v_eps)) / v_eps

        Exact mode: sgn has no derivative at qd = 0 (the Coulomb jump); there the value
        is the one of either side, -beta (the low-speed rise term vanishes with sgn(0) = 0).
        ``sign`` (exact mode only): the derivative of -beta qd - (tau_c + eps e^{-gamma|qd|}) sign
        with the sliding signs held fixed (the simulator's stick-slip steps)."""
        qd = np.asarray(qd, dtype=float)
        e = self.stribeck * np.exp(-self.stribeck_rate * np.abs(qd))
        ds = -self.stribeck_rate * e * np.sign(qd)    # d/dqd of tau_c + eps e^{-gamma|qd|}
        if smooth:
            t = np.tanh(qd / v_eps)
            return -self.viscous - ds * t - (self.coulomb + e) * (1.0 - t * t) / v_eps
        return -self.viscous - ds * (np.sign(qd) if sign is None else np.asarray(sign, float))

    def function(self, qd):
        """Delta(qd) summed over the joints (W); delta = -dDelta/dqd. (N, n) gives (N,)."""
        qd = np.asarray(qd, dtype=float)
        s = np.abs(qd)
        g = self.stribeck_rate
        with np.errstate(divide="ignore", invalid="ignore"):
            rise = np.where(g > 0, self.stribeck / np.where(g > 0, g, 1.0) * -np.expm1(-g * s),
                            self.stribeck * s)   # limit gamma -> 0: eps |qd|
        return np.sum(0.5 * self.viscous * qd**2 + self.coulomb * s + rise, axis=-1)
