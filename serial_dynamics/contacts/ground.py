"""``Ground``: a plane the robot's point contacts may touch in simulation, and the signed
distance of a contact's sphere to it.

The plane is {p : n . p = height}, n the unit ``normal`` (a non-unit normal is normalised;
a zero or non-finite one is refused), in world axes (a fixed base's base frame). Its
``friction`` is Coulomb's coefficient mu (0: frictionless ice), its ``restitution`` e in
[0, 1] the share of a contact's approach speed it sends back (0: plastic, the default).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Ground:
    """A plane ``Ground(height=0.0, normal=(0, 0, 1), friction=1.0, restitution=0.0)``
    (module docstring)."""

    height: float = 0.0
    normal: tuple = (0.0, 0.0, 1.0)
    friction: float = 1.0
    restitution: float = 0.0

    def __post_init__(self):
        set_ = object.__setattr__                  # frozen: the fields normalized once
        for name, low, high in (("height", -np.inf, np.inf), ("friction", 0.0, np.inf),
                                ("restitution", 0.0, 1.0)):
            value = getattr(self, name)
            x = float(value) if np.isscalar(value) and not isinstance(value, (str, bool)) \
                else np.nan
            if not (np.isfinite(x) and low <= x <= high):
                raise ValueError(f"Ground {name} must be a finite number in [{low:g}, "
                                 f"{high:g}]; got {value!r}")
            set_(self, name, x)
        n = np.asarray(self.normal, dtype=float) if not isinstance(self.normal, str) \
            else np.zeros(0)
        length = np.linalg.norm(n) if n.shape == (3,) and np.all(np.isfinite(n)) else 0.0
        if not length > 1e-9:
            raise ValueError(f"Ground normal must be 3 finite numbers, not all zero (the "
                             f"upward direction, world axes); got {self.normal!r}")
        set_(self, "normal", tuple((n / length).tolist()))

    def tangents(self):
        """(t1, t2): unit vectors with (t1, t2, n) right-handed and orthonormal."""
        n = np.array(self.normal)
        seed = np.eye(3)[int(np.argmin(np.abs(n)))]        # the axis least along n
        t1 = np.cross(seed, n)
        t1 /= np.linalg.norm(t1)
        return t1, np.cross(n, t1)

    def distance(self, points, radius):
        """Signed distances (k,) of spheres (centres (k, 3), radii (k,)) to the plane:
        positive above it, negative where they penetrate."""
        return np.asarray(points) @ np.array(self.normal) - self.height - np.asarray(radius)
