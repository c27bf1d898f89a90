"""Write identified parameters back into a copy of the original URDF.

Per body i of the chain (the links the loader lumps into it: the child link of joint i and
every link rigidly attached to it), the identified standard parameters phi_i = (m, m c,
I_O) in the child link's frame (``regressor.py``'s order) go into the child link's
``<inertial>``, *less* the inertia of the other links lumped into body i, which stay as
they are (a gripper keeps its own inertial); ``sd.load_urdf`` of the written file then
combines them back into exactly phi_i. When that remainder is not a physical body (the
identified body is lighter than the parts attached to it), the whole body goes into the
child link and the other links' ``<inertial>`` are removed, with a warning naming them.
Joint friction goes into ``<dynamics damping="fv" friction="fc">``. Everything else of
the file (visuals, collisions, transmissions, other joints) is kept as it was.
"""
from __future__ import annotations

import io
import os
import warnings

import numpy as np

from ..model.errors import ModelError
from ..model.inertia import check_inertia
from ..urdf.loader import _link_inertia, _parse, read_source
from ..urdf.xml_checks import check_well_formed

# column order of one body's standard parameters (regressor.py)
M, MX, MY, MZ, IXX, IXY, IYY, IXZ, IYZ, IZZ = range(10)


def body_inertia(phi):
    """(m, h (3,), I_O (3, 3)) of one body's 10 standard parameters."""
    I = np.array([[phi[IXX], phi[IXY], phi[IXZ]],
                  [phi[IXY], phi[IYY], phi[IYZ]],
                  [phi[IXZ], phi[IYZ], phi[IZZ]]])
    return phi[M], np.array(phi[MX:MZ + 1]), I


def about_com(m, h, I_O):
    """(c, I_c): the center of mass and the inertia about it (parallel axes, Steiner)."""
    c = h / m if m > 0 else np.zeros(3)
    return c, I_O - m * (c @ c * np.eye(3) - np.outer(c, c))      # parallel-axis theorem


def is_physical(m, h, I_O, name="body"):
    """True when mass > 0 and the inertia about the center of mass is positive
    semi-definite with the triangle inequality (``inertia.check_inertia``)."""
    if not m > 0:
        return False
    c, I_c = about_com(m, h, I_O)
    try:
        check_inertia(name, m, I_c, length=float(np.linalg.norm(c)))
    except ModelError:
        return False
    return True


def _parts(source, model):
    """Per body: [(link name, m, h, I_O)] of the links lumped into it other than the joint's
    child link, in the body's (child link's) frame, as the loader places them."""
    urdf, _ = _parse(source)
    links = {link.name: link for link in urdf.links}
    parts = {i: [] for i in range(model.dof)}
    for name, (body, R, p) in model.frames.items():
        if body < 0 or name == model.link_names[body] or name not in links:
            continue
        m, c, I = _link_inertia(links[name])
        if m == 0 and not np.any(I):
            continue
        cb = R @ c + p
        Ib = R @ I @ R.T
        parts[body].append((name, m, m * cb, Ib + m * (cb @ cb * np.eye(3) - np.outer(cb, cb))))
    return parts


def write_urdf(source, model, phi, damping, friction, path):
    """Write the URDF ``source`` (file path or XML) with body i's inertial parameters
    ``phi[i]`` (n, 10) and joint i's ``damping``, ``friction`` (n,) to ``path``.
    Returns the list of warnings issued (strings)."""
    from lxml import etree

    tree = check_well_formed(io.BytesIO(read_source(source)[0]), "the URDF")
    links = {e.get("name"): e for e in tree.findall("link")}
    joints = {e.get("name"): e for e in tree.findall("joint")}
    said = []
    for i, parts in _parts(source, model).items():
        m, h, I_O = body_inertia(np.asarray(phi[i], float))
        child = model.link_names[i]
        if not is_physical(m, h, I_O, child):
            said.append(f"body of joint {model.joint_names[i]!r} (link {child!r}): the "
                        f"identified inertia is not physical (mass {m:.4g} kg); "
                        "sd.load_urdf will refuse it: identify with method='physical'")
        rest = (m - sum(p[1] for p in parts), h - sum((p[2] for p in parts), np.zeros(3)),
                I_O - sum((p[3] for p in parts), np.zeros((3, 3))))
        if parts and not is_physical(*rest, child):
            said.append(f"link {child!r}: the identified body is lighter than the links "
                        f"attached to it {[p[0] for p in parts]}; their <inertial> is removed "
                        f"and the whole body written into {child!r}")
            for name, *_ in parts:
                for e in links[name].findall("inertial"):
                    links[name].remove(e)
        else:
            m, h, I_O = rest
        _set_inertial(links[child], m, h, I_O)
        _set_dynamics(joints[model.joint_names[i]], damping[i], friction[i])
    for text in said:
        warnings.warn(text, UserWarning, stacklevel=3)
    etree.ElementTree(tree).write(os.fspath(path), xml_declaration=True, encoding="utf-8",
                                  pretty_print=True)
    return said


def _set_inertial(link, m, h, I_O):
    from lxml import etree
    for e in link.findall("inertial"):
        link.remove(e)
    c, I = about_com(m, h, I_O)
    inertial = etree.SubElement(link, "inertial")
    etree.SubElement(inertial, "origin", xyz=" ".join(repr(float(v)) for v in c), rpy="0 0 0")
    etree.SubElement(inertial, "mass", value=repr(float(m)))
    etree.SubElement(inertial, "inertia", **{k: repr(float(v)) for k, v in (
        ("ixx", I[0, 0]), ("ixy", I[0, 1]), ("ixz", I[0, 2]), ("iyy", I[1, 1]),
        ("iyz", I[1, 2]), ("izz", I[2, 2]))})


def _set_dynamics(joint, damping, friction):
    from lxml import etree
    dyn = joint.find("dynamics")
    if dyn is None:
        dyn = etree.SubElement(joint, "dynamics")
    dyn.set("damping", repr(max(float(damping), 0.0)))
    dyn.set("friction", repr(max(float(friction), 0.0)))
