"""``Robot.contact_points``: point contacts from the URDF's ``<collision>`` geometry, read
from the file or XML the robot was loaded from (``Model.source``): a sphere gives its centre
(``radius`` kept on the contact), a box its eight corners. Meshes are never loaded, and
cylinders are skipped: a model with such collisions names its contacts (``sd.Contact``).
Only links of the model count (a link lumped into a body by a fixed joint is one)."""
from __future__ import annotations

import io
import itertools

import numpy as np
from scipy.spatial.transform import Rotation

from ..model.errors import URDFError
from ..urdf.loader import read_source
from ..urdf.xml_checks import check_well_formed
from .contact import Contact


def _numbers(element, attribute, count, link):
    """The ``count`` finite numbers of ``attribute`` (zeros where the element or attribute
    is absent), or a URDFError naming the link."""
    text = element.get(attribute) if element is not None else None
    if text is None:
        return np.zeros(count)
    try:
        x = np.array([float(s) for s in text.split()])
    except ValueError:
        x = np.zeros(0)
    if x.shape != (count,) or not np.all(np.isfinite(x)):
        raise URDFError(f"link {link!r}: <collision> <{element.tag} {attribute}> must be "
                        f"{count} finite numbers; got {text!r}")
    return x


def _points(collision, link):
    """(points (p, 3) in the link frame, radius) of one <collision>, or None."""
    origin = collision.find("origin")
    xyz = _numbers(origin, "xyz", 3, link)
    # URDF rpy: fixed-axis roll about x, pitch about y, yaw about z (R = Rz Ry Rx)
    R = Rotation.from_euler("xyz", _numbers(origin, "rpy", 3, link)).as_matrix()
    sphere, box = collision.find("geometry/sphere"), collision.find("geometry/box")
    if sphere is not None:
        r = _numbers(sphere, "radius", 1, link)[0]
        if r < 0:
            raise URDFError(f"link {link!r}: <collision> <sphere radius> is negative ({r})")
        return xyz[None], r
    if box is not None:
        half = 0.5 * _numbers(box, "size", 3, link)
        corners = np.array(list(itertools.product((-1.0, 1.0), repeat=3))) * half
        return xyz + corners @ R.T, 0.0
    return None


def contact_points(robot):
    """[Contact] of every <collision> sphere (its centre) and box (its corners) on a link of
    the model, in the URDF's order."""
    source = robot.model.source
    if source is None:
        raise ValueError("this robot was not loaded from a URDF, so it has no <collision> "
                         "elements to read; name its contacts with sd.Contact(link, point)")
    data, where = read_source(source)
    xml = check_well_formed(io.BytesIO(data), where)
    out = []
    for link in xml.findall("link"):
        name = link.get("name")
        if name not in robot.model.frames:
            continue
        for collision in link.findall("collision"):
            found = _points(collision, name)
            if found is not None:
                out += [Contact(name, tuple(p), radius=found[1]) for p in found[0]]
    return out
