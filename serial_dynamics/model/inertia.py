"""Rigid-body inertia: the physical checks of one body's mass and rotational inertia, the
bounds of absurd magnitudes, lumping rigidly attached parts into one body, and the nearest
physical inertia to one that is not (``repair_inertia``)."""
from __future__ import annotations

import warnings

import numpy as np

from .errors import InertiaRepairWarning, ModelError


def check_mass(link: str, mass: float) -> None:
    """Mass >= 0 (a NaN is refused too)."""
    if not mass >= 0:
        raise ModelError(f"link {link!r}: mass {mass} is negative; a mass must be >= 0")


def check_inertia(link: str, mass: float, inertia: np.ndarray, rtol: float = 1e-9,
                  length: float = 0.0) -> None:
    """Mass >= 0; inertia symmetric, positive semi-definite and obeying the triangle
    inequality of principal moments (I1 + I2 >= I3), as every physical body does
    (``moments_fault`` says how close counts)."""
    check_mass(link, mass)
    I = np.asarray(inertia, dtype=float)
    if not np.allclose(I, I.T, atol=max(rtol * _scale(I), _floor(mass, length))):
        raise ModelError(f"link {link!r}: inertia matrix is not symmetric")
    fault = moments_fault(mass, I, rtol, length)
    if fault is not None:
        raise ModelError(f"link {link!r}: {fault}")


def moments_fault(mass: float, inertia: np.ndarray, rtol: float = 1e-9,
                  length: float = 0.0) -> str | None:
    """Why the principal moments of a symmetric ``inertia`` (about the center of mass) are
    no rigid body's, as a phrase for a message, or None when they are some body's.

    Tolerances: relative, for numbers written with few digits, a principal moment down to
    -``rtol`` times the largest entry and the triangle inequality failing by 1e-6 of it; and
    absolute, for round-off-sized entries (iCub's links carry inertias of 1e-20 .. 1e-35
    kg m^2: point masses whose zeros went through a rotation), a shortfall up to
    ``INERTIA_FLOOR`` m L^2, L = ``length``, the body's size (the largest distance from its
    origin to its center of mass or to a joint it carries). A principal moment
    I1 = int (y^2 + z^2) dm, or a second moment (I1 + I2 - I3) / 2 = int z^2 dm, of
    -1e-12 m L^2 is that of mass spread over an imaginary 1e-6 L: a micrometre on a
    metre-long link, far below any part's tolerance (so physically zero), and far above the
    round-off (1e-16 m L^2) of the parallel-axis terms m |c|^2 every algorithm adds to it.
    """
    I = np.asarray(inertia, dtype=float)
    scale, floor = _scale(I), _floor(mass, length)
    ev = np.linalg.eigvalsh(I)
    if ev[0] < -max(rtol * scale, floor):
        return (f"inertia is not positive semi-definite (principal moments {_moments(ev)} "
                "kg m^2); fix ixx..izz: every principal moment of a rigid body is >= 0")
    if ev[0] + ev[1] < ev[2] - max(1e-6 * scale, floor):
        return (f"principal moments {_moments(ev)} kg m^2 violate the triangle inequality "
                "I1 + I2 >= I3; no rigid body has them")
    return None


def _scale(I):
    return max(np.max(np.abs(I)), 1e-300)


def _floor(mass, length):
    return INERTIA_FLOOR * mass * float(length) ** 2


def nearest_physical_inertia(inertia: np.ndarray) -> tuple:
    """(I, moments before, moments after): the physically consistent rotational inertia
    nearest to ``inertia`` (about the center of mass; the mass and center of mass kept).

    A body is physical when its pseudo-inertia J = [[Sigma, h], [h^T, m]] is positive
    semi-definite (Wensing, Kim & Slotine, IEEE RA-L 3(1), 2018); with m and h = m c kept that
    is Sigma_c = tr(I)/2 1 - I >= 0, the second moments of mass s_k = int x_k^2 dm along the
    principal axes. Its nearest point in the Frobenius norm of J sets each s_k < 0 to 0 (the
    projection onto the positive semi-definite cone) and keeps the principal axes; the
    principal moments are then I_k = s_j + s_l."""
    I = np.asarray(inertia, dtype=float)
    ev, V = np.linalg.eigh((I + I.T) / 2)
    s = np.maximum(ev.sum() / 2 - ev, 0.0)     # s_k = (I_j + I_l - I_k) / 2, clipped
    after = s.sum() - s                        # I_k = s_j + s_l
    repaired = V @ np.diag(after) @ V.T
    return (repaired + repaired.T) / 2, ev, after


def physical_body(who: str, mass: float, inertia: np.ndarray, length: float,
                  repair: bool) -> np.ndarray:
    """The inertia of a body the dynamics uses (its links lumped): ``inertia`` when it is
    some rigid body's (``moments_fault``); else, with ``repair``, the nearest physical one
    with one ``InertiaRepairWarning`` giving the principal moments before and after, and
    without, a ``ModelError`` naming ``who`` and the option."""
    fault = moments_fault(mass, inertia, length=length)
    if fault is None:
        return inertia
    if not repair:
        raise ModelError(f"{who}: {fault}. Fix the <inertia> in the URDF, or load with "
                         "repair_inertia=True (the nodes' parameter repair_inertia:=true) to "
                         "replace it by the nearest physical inertia, with a warning")
    repaired, before, after = nearest_physical_inertia(inertia)
    warnings.warn(f"{who}: inertia not physical, principal moments {_moments(before)} kg m^2; "
                  f"repaired (repair_inertia=True) to {_moments(after)} kg m^2, the nearest "
                  "physical inertia (mass, center of mass and principal axes kept)",
                  InertiaRepairWarning, stacklevel=4)
    return repaired


def body_sizes(com, joint_origins, parent, tip_p, base_com=None) -> np.ndarray:
    """(n + 1,) the size L of each body for the round-off floor of ``moments_fault``: the
    largest distance from its origin to its center of mass, to the origin of a joint it
    carries, or (the last body) to the tip frame; entry n (index -1, as in ``parent``) is
    the base's (its center of mass ``base_com``, zero when None, and the joints it carries)."""
    n = len(parent)
    sizes = np.zeros(n + 1)
    sizes[:n] = np.linalg.norm(np.reshape(com, (n, 3)), axis=1)
    sizes[n] = 0.0 if base_com is None else np.linalg.norm(base_com)
    for k, body in enumerate(parent):
        sizes[body] = max(sizes[body], np.linalg.norm(joint_origins[k]))
    sizes[n - 1] = max(sizes[n - 1], np.linalg.norm(tip_p))
    return sizes


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
