"""The URDF as XML, before yourdfpy reads it: well-formed, and every element and attribute
that yourdfpy reads present and of the right kind, or a ``URDFError`` naming the link or
joint, the element and attribute, and what is expected."""
from __future__ import annotations

import re

from ..model.errors import URDFError

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")  # URDF's


# What each attribute yourdfpy reads as numbers must hold: (count, what it means).
_XYZ, _RPY = (3, 'three numbers "x y z" (m)'), (3, 'three numbers "roll pitch yaw" (rad)')
_NUMBERS = {
    "origin": {"xyz": _XYZ, "rpy": _RPY},
    "axis": {"xyz": (3, 'three numbers "x y z" (the direction of the joint axis)')},
    "mass": {"value": (1, "a number (kg)")},
    "inertia": {k: (1, "a number (kg m^2)") for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "limit": {"lower": (1, "a number (rad, or m for a prismatic joint)"),
              "upper": (1, "a number (rad, or m for a prismatic joint)"),
              "effort": (1, "a number (N m, or N)"), "velocity": (1, "a number (rad/s, or m/s)")},
    "dynamics": {"damping": (1, "a number (N m s/rad, or N s/m)"),
                 "friction": (1, "a number (N m, or N)")},
    "mimic": {"multiplier": (1, "a number"), "offset": (1, "a number (rad, or m)")},
}


def _is_number(text) -> bool:
    try:
        float(text)
    except (TypeError, ValueError):
        return False
    return True


def check_elements(root, where):
    """Check every element and attribute yourdfpy reads (so that it never fails with a bare
    "could not convert string to float") and raise a URDFError that names the link or joint,
    the element and attribute, and what is expected. Values are only checked to be numbers
    here; NaN, Inf and physics are checked where they are used, naming the same culprit."""
    from .transmissions import _local

    def fail(who, message):
        raise URDFError(f"cannot parse {where}: {who}: {message}")

    def numbers(element, who):
        for attr, (count, expected) in _NUMBERS.get(element.tag, {}).items():
            value = element.get(attr)
            if value is None:
                continue
            parts = value.split()
            if len(parts) != count or not all(_is_number(p) for p in parts):
                fail(who, f'<{element.tag} {attr}="{value}"> is not {expected}; fix it')

    def required(element, who, attrs, hint):
        for attr in attrs:
            if not (element.get(attr) or "").strip():
                fail(who, f"<{element.tag}> has no {attr} attribute; {hint}")

    if _local(root.tag) != "robot":
        raise URDFError(f"cannot parse {where}: its root element is <{root.tag}>, not <robot>; "
                        "a URDF is one <robot name=...> holding <link> and <joint> elements")
    if not (root.get("name") or "").strip():
        raise URDFError(f'cannot parse {where}: <robot> has no name attribute; name the '
                        'robot: <robot name="...">')
    for kind in ("link", "joint"):
        for k, element in enumerate(root.findall(kind)):
            if not (element.get("name") or "").strip():
                fail(f"the <{kind}> on line {element.sourceline} (the {_ordinal(k + 1)} <{kind}>)",
                     f"it has no name attribute; every <{kind}> needs a unique name")
    for link in root.findall("link"):
        who = f"link {link.get('name')!r}"
        inertial = link.find("inertial")
        if inertial is None:
            continue                                    # massless: legal
        for tag, attrs, what in (
                ("mass", ("value",), 'its mass, <mass value="..."/> (kg)'),
                ("inertia", ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
                 'its rotational inertia about the center of mass, all six of <inertia ixx="..." '
                 'ixy="..." ixz="..." iyy="..." iyz="..." izz="..."/> (kg m^2)')):
            element = inertial.find(tag)
            if element is None:
                fail(who, f"<inertial> has no <{tag}>; give {what}, or remove the <inertial> "
                          "of a massless link")
            required(element, who, attrs, f"give {what}")
            numbers(element, who)
        if inertial.find("origin") is not None:
            numbers(inertial.find("origin"), who + " <inertial>")
    for joint in root.findall("joint"):
        who = f"joint {joint.get('name')!r}"
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            fail(who, ("it has no type attribute" if kind is None else f"type {kind!r} is not a "
                       "URDF joint type") + f"; give one of {list(JOINT_TYPES)}")
        for end in ("parent", "child"):
            element = joint.find(end)
            if element is None:
                fail(who, f'it has no <{end}>; give <{end} link="..."/> naming its {end} link')
            required(element, who, ("link",), f'name its {end} link: <{end} link="..."/>')
        for tag in ("origin", "axis", "limit", "dynamics", "mimic"):
            element = joint.find(tag)
            if element is not None:
                numbers(element, who)
        if joint.find("mimic") is not None:
            required(joint.find("mimic"), who, ("joint",),
                     'name the joint it follows: <mimic joint="..." multiplier="1" offset="0"/>')


def _ordinal(k) -> str:
    return f"{k}{'th' if 10 <= k % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(k % 10, 'th')}"


# An XML declaration (any version) after nothing but blank space, as urdfdom (TinyXML2)
# reads it; lxml wants version 1.0 at the very first byte.
_DECLARATION = re.compile(rb"\A(\xef\xbb\xbf)?(\s*)<\?xml(\s.*?)?\?>", re.S)
_ENCODING = re.compile(rb"""encoding\s*=\s*["']([A-Za-z0-9._-]+)["']""")


def without_harmless_header(data: bytes) -> bytes:
    """The document ``data`` with what urdfdom reads and lxml refuses before the root
    element made plain: blank lines before the XML declaration, a declaration of another
    version than 1.0 (pybullet's ``<?xml version="0.0" ?>``). The declaration becomes
    ``<?xml version="1.0"?>`` (its encoding kept) on line 1, followed by as many line breaks
    as it replaced, so that every error keeps its line number."""
    m = _DECLARATION.match(data)
    if m is None:
        return data
    encoding = _ENCODING.search(m.group(3) or b"")
    declaration = (b'<?xml version="1.0"' + (b' encoding="' + encoding.group(1) + b'"'
                                             if encoding else b"") + b"?>")
    return ((m.group(1) or b"") + declaration + b"\n" * m.group(0).count(b"\n")
            + data[m.end():])


def without_undeclared_prefixes(root):
    """A copy of ``root`` without the elements and attributes whose namespace prefix is
    not declared (``xacro:``, ``drake:`` leftovers): no URDF reader uses them, and yourdfpy
    logs two error lines for each before parsing the file the same way."""
    import copy

    root = copy.deepcopy(root)
    for element in [e for e in root.iter() if isinstance(e.tag, str) and ":" in e.tag
                    and not e.tag.startswith("{")]:
        if element.getparent() is not None:
            element.getparent().remove(element)
    for element in root.iter():
        for key in [k for k in element.attrib if ":" in k and not k.startswith("{")]:
            del element.attrib[key]
    return root


def check_well_formed(handle, where):
    """yourdfpy silently recovers from broken XML (and would build a wrong robot): refuse
    fatal syntax errors here; undeclared namespace prefixes (xacro leftovers) are tolerated."""
    from lxml import etree

    parser = etree.XMLParser(recover=True)
    tree = None
    try:
        tree = etree.parse(handle, parser)
        errors = [e for e in parser.error_log if e.level_name == "FATAL"]
    except etree.XMLSyntaxError as exc:      # nothing recoverable, e.g. an empty document
        errors = [exc]
    if errors:
        e = errors[0]
        line = getattr(e, "line", None) or getattr(e, "lineno", "?")
        raise URDFError(f"cannot parse {where}: not well-formed XML (line {line}: "
                        f"{getattr(e, 'message', None) or e}); fix the markup")
    return tree.getroot()
