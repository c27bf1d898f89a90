"""``Contact``: what holds a robot, as data, and the checks of a set of contacts.

A point contact (``frame=False``) is a point of a link, given in the link's frame, that
transmits a force (3 numbers); a frame contact (``frame=True``) is the link's frame, moved
to ``point`` (the link's axes kept), that transmits a wrench (6 numbers: a foot flat on the
ground, a hand welded to a bar). With ``other_link`` the contact is a loop closure between
two links of the robot (a four-bar linkage, two arms holding one bar): the force is the one
``other_link`` exerts on ``link``, the opposite acts on ``other_link``.

``anchor`` is where the contact is held, read only by the Baumgarte term's position error:
for a point contact a point (3,), for a frame contact a pose (4, 4), in ``other_link``'s
frame, or in the world (a fixed base's base frame) for a contact with the environment.
``None``: a loop closes on ``other_link``'s frame origin (frames coinciding); a contact with
the environment is held where it is (no position error). A point loop's point on
``other_link`` is its anchor (Pinocchio's ``joint2_placement``). ``radius``: the sphere of
``<collision>`` a contact was read from (``Robot.contact_points``), kept for the ground; the
dynamics use the point (the sphere's centre).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.links import resolve_link


def _numbers(value, shape, what):
    """``value`` as a tuple of finite floats of ``shape`` (nested for (4, 4))."""
    a = np.asarray(value, dtype=float) if not isinstance(value, str) else np.zeros(0)
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise ValueError(f"Contact {what} must be {np.prod(shape)} finite numbers of shape "
                         f"{shape}; got {value!r}")
    return tuple(map(tuple, a)) if a.ndim == 2 else tuple(a.tolist())


@dataclass(frozen=True)
class Contact:
    """A contact of the robot (module docstring): ``Contact(link, point=(0, 0, 0),
    frame=False, other_link=None, anchor=None, radius=0.0)``."""

    link: str
    point: tuple = (0.0, 0.0, 0.0)
    frame: bool = False
    other_link: str | None = None
    anchor: tuple | None = None
    radius: float = 0.0

    def __post_init__(self):
        if not isinstance(self.link, str) or not self.link:
            raise ValueError(f"Contact link must be a link name (a string); got {self.link!r}")
        if self.other_link is not None and (not isinstance(self.other_link, str)
                                            or self.other_link == self.link):
            raise ValueError(f"Contact other_link must be another link's name or None; got "
                             f"{self.other_link!r} for the contact on {self.link!r}")
        if not isinstance(self.frame, (bool, np.bool_)):
            raise ValueError(f"Contact frame must be True (a wrench) or False (a force); got "
                             f"{self.frame!r}")
        set_ = object.__setattr__                  # frozen: the fields normalized once
        set_(self, "frame", bool(self.frame))
        set_(self, "point", _numbers(self.point, (3,), "point"))
        if self.anchor is not None:
            set_(self, "anchor", _numbers(self.anchor, (4, 4) if self.frame else (3,),
                                          "anchor (a pose (4, 4) for a frame contact, a point "
                                          "(3,) for a point contact)"))
            X = np.array(self.anchor)
            if self.frame and not (np.allclose(X[:3, :3].T @ X[:3, :3], np.eye(3), atol=1e-9)
                                   and np.linalg.det(X[:3, :3]) > 0
                                   and np.array_equal(X[3], [0.0, 0.0, 0.0, 1.0])):
                raise ValueError(f"Contact anchor of {self.link!r} must be a rigid pose: a "
                                 "rotation matrix in its top-left 3 x 3, last row [0, 0, 0, 1]")
        r = float(self.radius) if np.isscalar(self.radius) else np.nan
        if not np.isfinite(r) or r < 0:
            raise ValueError(f"Contact radius must be a number >= 0 (m); got {self.radius!r}")
        set_(self, "radius", r)

    size = property(lambda self: 6 if self.frame else 3,
                    doc="rows it adds: 3 (a force) or 6 (a wrench)")

    def __str__(self):
        where = self.link if not any(self.point) else f"{self.link} at {list(self.point)}"
        return where + (f" (to {self.other_link})" if self.other_link else "")


def check_contacts(robot, contacts):
    """The contacts as a tuple, each on links of ``robot`` (ValueError naming the culprit)."""
    if isinstance(contacts, Contact):
        contacts = (contacts,)
    contacts = tuple(contacts) if not isinstance(contacts, (str, bytes)) else (contacts,)
    if not contacts:
        raise ValueError("contacts is empty; give sd.Contact objects (or forward_dynamics "
                         "for a robot that touches nothing)")
    for i, c in enumerate(contacts):
        if not isinstance(c, Contact):
            raise ValueError(f"contacts[{i}] is {c!r}; each contact must be an sd.Contact")
        for name in (c.link, c.other_link):
            if name is not None:       # the set every call that takes a link accepts
                resolve_link(robot.model, name, prefix=f"contacts[{i}]: ")
    return contacts
