"""``BaseMotion``: the known motion of a robot's base (a ship deck, a vehicle, a mobile base).

The base's angular velocity omega_0 and angular acceleration alpha_0 (rad/s, rad/s^2) and the
classical acceleration a_0 of its origin (m/s^2, gravity *not* included: the model's gravity is
added separately), all in base-frame coordinates. The recursions start from them as they
start from gravity (Angeles, *Fundamentals of Robotic Mechanical Systems*, Sec. 7.5.2):
omega_{-1} = omega_0, alpha_{-1} = alpha_0, acc_{-1} = a_0 - g. The linear velocity of the
base changes nothing (Galilean invariance) and is not an input.

The joint coordinates stay relative to the base; the torques and accelerations are those
the moving base produces. Gravity stays the model's constant vector in base coordinates:
for a base that tilts far, add the change of gravity's direction to ``linear_acceleration``
(a_0 - (g(t) - g), base coordinates).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.layout import W_ALL, W_WRENCH


@dataclass(frozen=True, eq=False)
class BaseMotion:
    """Known motion of the base, in base-frame coordinates (see the module docstring)."""

    angular_velocity: np.ndarray = (0.0, 0.0, 0.0)       # omega_0, rad/s
    angular_acceleration: np.ndarray = (0.0, 0.0, 0.0)   # alpha_0, rad/s^2
    linear_acceleration: np.ndarray = (0.0, 0.0, 0.0)    # a_0 of the origin, m/s^2, no gravity

    def __post_init__(self):
        ext = np.zeros(W_ALL)          # the compiled core's external inputs: [w; omega; alpha; a]
        for k, name in enumerate(("angular_velocity", "angular_acceleration", "linear_acceleration")):
            v = np.array(getattr(self, name), dtype=float)
            if v.shape != (3,):
                raise ValueError(f"BaseMotion {name} has shape {v.shape}; give 3 numbers "
                                 "(x, y, z in base coordinates)")
            if not np.all(np.isfinite(v)):
                raise ValueError(f"BaseMotion {name} = {v.tolist()} has a NaN or Inf entry; "
                                 "give finite numbers")
            v.setflags(write=False)
            object.__setattr__(self, name, v)
            ext[W_WRENCH + 3 * k:W_WRENCH + 3 * k + 3] = v
        object.__setattr__(self, "_ext", ext)

    def external(self, wrench=None) -> np.ndarray:
        """The compiled core's input vector (``core/layout.py`` W_*): the tip wrench (zeros
        when None) followed by this motion. A new array."""
        ext = self._ext.copy()
        if wrench is not None:
            ext[:W_WRENCH] = wrench
        return ext

    def __repr__(self):
        return (f"BaseMotion(angular_velocity={self.angular_velocity.tolist()}, "
                f"angular_acceleration={self.angular_acceleration.tolist()}, "
                f"linear_acceleration={self.linear_acceleration.tolist()})")


def check_base_motion(base_motion):
    """``base_motion`` if it is a BaseMotion or None; else a TypeError naming the fix."""
    if base_motion is None or isinstance(base_motion, BaseMotion):
        return base_motion
    raise TypeError(f"base_motion must be a serial_dynamics.BaseMotion or None, got "
                    f"{type(base_motion).__name__}; build one with "
                    "sd.BaseMotion(angular_velocity, angular_acceleration, linear_acceleration)")
