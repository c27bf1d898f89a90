"""A payload rigidly attached to a link of the model: ``Payload`` and ``attach``.

Attaching adds the payload's inertia to the body the link belongs to (the parallel-axis
theorem, ``model.combine_inertias``) and returns a new ``Model``; the model attached to is
not changed. Only that body's inertial fields (as given and in joint frames) are new; the
rest is shared, so attaching takes microseconds and compiles nothing
(``Robot.with_payload`` replaces the body's row of the compiled layout ``P``).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .errors import ModelError
from .inertia import (MAX_INERTIA, MAX_LENGTH, MAX_MASS, check_inertia, check_magnitude,
                      combine_inertias)
from .links import resolve_link
from .model import inertia_in_joint_frames


@dataclass(frozen=True, eq=False)
class Payload:
    """``mass`` kg; ``com`` (3,) m in ``link``'s frame; ``inertia`` (ixx, iyy, izz, ixy, ixz,
    iyz) kg m^2 about the center of mass, in ``link``'s axes."""

    mass: float
    com: tuple
    inertia: tuple
    link: str

    @staticmethod
    def make(mass, com, inertia, link) -> "Payload":
        """A validated payload; ValueError naming the bad number and the fix."""
        m = float(mass)
        c = np.asarray(com, dtype=float)
        i6 = np.asarray(inertia, dtype=float)
        if c.shape != (3,) or i6.shape != (6,):
            raise ValueError(f"payload com must be (x, y, z) and inertia (ixx, iyy, izz, ixy, ixz, "
                             f"iyz); got shapes {c.shape} and {i6.shape}")
        for what, v in (("mass", m), ("com", c), ("inertia", i6)):
            if not np.all(np.isfinite(v)):
                raise ValueError(f"payload {what} {np.round(v, 6).tolist()} has a NaN or Inf "
                                 "entry; give finite numbers")
        try:
            check_magnitude("payload", "mass", m, MAX_MASS, "kg")
            check_magnitude("payload", "center of mass", c, MAX_LENGTH, "m")
            check_magnitude("payload", "inertia", i6, MAX_INERTIA, "kg m^2")
            check_inertia("payload", m, _matrix(i6))   # m >= 0, PSD, triangle inequality
        except ModelError as exc:
            raise ValueError(str(exc).replace("link 'payload'", "payload")) from None
        return Payload(m, tuple(c.tolist()), tuple(i6.tolist()), str(link))

    @property
    def inertia_matrix(self) -> np.ndarray:
        """The 3x3 rotational inertia about the center of mass, link axes."""
        return _matrix(self.inertia)


def _matrix(i6):
    ixx, iyy, izz, ixy, ixz, iyz = i6
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


def attach(model, payload: Payload):
    """(the model with ``payload`` lumped into its link's body, that body's index)."""
    link = resolve_link(model, payload.link, moving=True, prefix="payload ")
    b, R, p = model.frames[link]               # the link's frame in body b's link frame
    c = R @ np.asarray(payload.com) + p        # into body b's link frame
    I = R @ payload.inertia_matrix @ R.T
    m, com, inertia = combine_inertias([(model.mass[b], model.com[b], model.inertia[b]),
                                        (payload.mass, c, I)])
    c_j, I_c, h, I_O = inertia_in_joint_frames(model.A[b], m, com, inertia)   # as the loader
    new = {"mass": m, "com": com, "inertia": inertia, "c": c_j, "h": h, "I_c": I_c, "I_O": I_O}
    changes = {}
    for key, value in new.items():
        a = np.array(getattr(model, key))
        a[b] = value
        a.setflags(write=False)
        changes[key] = a
    return dataclasses.replace(model, **changes), b
