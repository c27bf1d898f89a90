"""Rigid-body inertia: the physical checks of one body's mass and rotational inertia, the
bounds of absurd magnitudes, and lumping rigidly attached parts into one body."""
from __future__ import annotations

import numpy as np

from .errors import ModelError


def check_inertia(link: str, mass: float, inertia: np.ndarray, rtol: float = 1e-9,
                  length: float = 0.0) -> None:
    """Mass >= 0; inertia symmetric, positive semi-definite and obeying the triangle
    inequality of principal moments (I1 + I2 >= I3), as every physical body does.

    Tolerances: relative, for numbers written with few digits, a principal moment down to
    -``rtol`` times the largest entry and the triangle inequality failing by 1e-6 of it; and
    absolute, for round-off-sized entries (iCub's links carry inertias of 1e-20 .. 1e-35
    kg m^2: point masses whose zeros went through a rotation), a shortfall up to
    ``INERTIA_FLOOR`` m L^2, L = ``length``, the link's size (the largest distance from its
    origin to its center of mass or to a joint it carries). A principal moment
    I1 = int (y^2 + z^2) dm, or a second moment (I1 + I2 - I3) / 2 = int z^2 dm, of
    -1e-12 m L^2 is that of mass spread over an imaginary 1e-6 L: a micrometre on a
    metre-long link, far below any part's tolerance (so physically zero), and far above the
    round-off (1e-16 m L^2) of the parallel-axis terms m |c|^2 every algorithm adds to it.
    """
    if not mass >= 0:
        raise ModelError(f"link {link!r}: mass {mass} is negative; a mass must be >= 0")
    I = np.asarray(inertia, dtype=float)
    scale = max(np.max(np.abs(I)), 1e-300)
    floor = INERTIA_FLOOR * mass * float(length) ** 2
    if not np.allclose(I, I.T, atol=max(rtol * scale, floor)):
        raise ModelError(f"link {link!r}: inertia matrix is not symmetric")
    ev = np.linalg.eigvalsh(I)
    if ev[0] < -max(rtol * scale, floor):
        raise ModelError(f"link {link!r}: inertia is not positive semi-definite (principal "
                         f"moments {_moments(ev)} kg m^2); fix ixx..izz: every principal "
                         "moment of a rigid body is >= 0")
    if ev[0] + ev[1] < ev[2] - max(1e-6 * scale, floor):
        raise ModelError(f"link {link!r}: principal moments {_moments(ev)} kg m^2 violate "
                         "the triangle inequality I1 + I2 >= I3; no rigid body has them")


# Inertia shortfalls below INERTIA_FLOOR m L^2 are round-off (check_inertia).
INERTIA_FLOOR = 1e-12


def _moments(ev):
    """Principal moments for a message: 9 decimals, or 3 significant digits if smaller."""
    return [round(float(v), 9) if abs(v) >= 1e-6 or v == 0 else float(f"{v:.3g}") for v in ev]


def combine_inertias(parts):
    """Lump rigidly attached parts [(m, c, I_c)] (one frame) into one body.
    Parallel-axis theorem: I = sum I_i + m_i (|d_i|^2 1 - d_i d_i^T), d_i = c_i - c."""
    m = sum(p[0] for p in parts)
    c = sum(p[0] * p[1] for p in parts) / m if m > 0 else np.zeros(3)
    I = np.zeros((3, 3))
    for mi, ci, Ii in parts:
        d = ci - c
        I += Ii + mi * (d @ d * np.eye(3) - np.outer(d, d))
    return m, c, I


# Beyond these no robot link is (a 10 km lever, 10,000 t); far below where products of
# them overflow, which would otherwise surface as NaN deep in an algorithm.
MAX_LENGTH, MAX_MASS = 1e4, 1e7          # m, kg
MAX_INERTIA = MAX_MASS * MAX_LENGTH**2   # kg m^2
# Joint dissipation beyond these is no joint's: a Coulomb torque of MAX_MASS's weight (10 m/s^2)
# on a MAX_LENGTH lever, and that torque per rad/s of viscous damping; the friction torque
# then stays finite at any finite speed (damping="1e308" would be inf above 1.8 rad/s).
MAX_FRICTION = MAX_MASS * MAX_LENGTH * 10.0     # N m (N for a prismatic joint)
MAX_DAMPING = MAX_FRICTION                       # N m s/rad (N s/m)


def check_magnitude(who, what, value, bound, unit) -> None:
    """Refuse an absurd magnitude, naming ``who`` ("link 'x'") and the bound."""
    big = float(np.max(np.abs(value)))
    if big > bound:
        raise ModelError(f"{who}: {what} of magnitude {big:.3g} {unit} is beyond any robot "
                         f"(more than {bound:g} {unit}); fix the number")
