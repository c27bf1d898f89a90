"""URDF -> Model: the chain or tree of joints the scene needs, and lumping.

Parsed with yourdfpy; meshes are never loaded. The model is the chain of joints from
``base_link`` to ``tip_link``, the subtree from ``base_link`` to ``tip_links``, or by
default every movable joint below ``base_link`` (a tree where they branch), its bodies in
depth-first order (parents first, children in the URDF's order, as Pinocchio numbers
them). Fixed joints in the model fold into the next joint's placement; links hanging off
it by fixed joints are lumped into the inertia of the body they are rigidly attached to;
movable joints outside it are held at zero and lumped too, with one warning naming them.
Physical consistency is judged on the lumped bodies, which are what the dynamics uses (a
link may carry a placeholder inertia that its fixed neighbours make physical); a body that
is not is refused, or with ``repair_inertia`` replaced by the nearest physical one
(``inertia.physical_body``). The XML is checked first (``xml_checks.py``); the tree walks
that find cycles and the default tip are in ``tree.py``.
"""
from __future__ import annotations

import io
import os
import warnings

import numpy as np

from ..algorithms._batch import rotation_about
from ..model.inertia import (MAX_INERTIA, MAX_LENGTH, MAX_MASS, body_sizes, check_magnitude,
                              check_mass, combine_inertias, physical_body)
from ..model.errors import HeldJointsWarning, URDFError
from ..model.model import Model
from .mass_matrix import check_mass_matrix
from .transmissions import reflected_inertias
from .tree import check_tree, has_movable, movable_leaves, path_up, single_chain_tip
from .joint_types import MOVABLE, elementary_joints
from .xml_checks import (check_elements, check_well_formed, without_harmless_header,
                         without_undeclared_prefixes)

__all__ = ["load_model", "URDFError", "HeldJointsWarning"]


def read_source(source):
    """(bytes, where) of a URDF given as a file path or as XML (str or bytes), with the
    header urdfdom reads and lxml refuses made plain (``without_harmless_header``)."""
    text = _xml_text(source)
    if text is not None:
        return without_harmless_header(text.encode()), "the URDF string"
    path = os.fspath(source)
    if not os.path.isfile(path):
        raise URDFError(f"URDF file {path!r} not found; give a path to a .urdf file or "
                        "the URDF XML itself as a string")
    with open(path, "rb") as f:
        return without_harmless_header(f.read()), repr(path)


def _parse(source):
    import yourdfpy
    from lxml import etree

    data, where = read_source(source)
    xml = check_well_formed(io.BytesIO(data), where)
    check_elements(xml, where)        # every value yourdfpy reads, named, before it reads it
    for parent, tags in (("link", ("visual", "collision")),      # what the model never uses
                         ("joint", ("calibration", "safety_controller"))):
        for element in xml.findall(parent):
            for unused in [e for tag in tags for e in element.findall(tag)]:
                element.remove(unused)
    for unused in xml.findall("material"):
        xml.remove(unused)
    plain = etree.tostring(without_undeclared_prefixes(xml))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            urdf = yourdfpy.URDF.load(io.BytesIO(plain), build_scene_graph=False,
                                      load_meshes=False, build_collision_scene_graph=False,
                                      load_collision_meshes=False)
    except Exception as exc:  # pragma: no cover - _check_elements lets nothing through
        detail = f"missing attribute {exc}" if isinstance(exc, KeyError) else exc
        raise URDFError(f"cannot parse {where}: {detail}. Check that it is well-formed URDF XML "
                        "(a <robot> with <link> and <joint> elements).") from exc
    if urdf.robot is None or not urdf.robot.links:
        raise URDFError(f"{where} has no <link>; nothing to model")
    return urdf.robot, xml


def _transform(X):
    return (np.eye(4) if X is None else np.asarray(X, dtype=float))


def _finite_or_fail(value, what):
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise URDFError(f"{what} has a NaN or Inf value ({arr.tolist()}); fix the number")
    return arr


def _float(value, default):
    return default if value is None else float(value)


def _link_inertia(link):
    """(mass, com (3,), inertia about com (3, 3)) in the link frame; a link with no
    <inertial> is massless. A NaN or Inf is a URDFError (a bad number in the file); a negative
    mass or an absurd magnitude a ModelError. Whether the inertia is some rigid body's is
    judged on the lumped body (``load_model``)."""
    inertial = link.inertial
    if inertial is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    what = f"link {link.name!r} <inertial>"
    m = float(_finite_or_fail(_float(inertial.mass, 0.0), what + " mass"))
    X = _finite_or_fail(_transform(inertial.origin), what + " origin")
    I = _finite_or_fail(np.zeros((3, 3)) if inertial.inertia is None else inertial.inertia,
                        what + " inertia")
    who = f"link {link.name!r}"
    check_magnitude(who, "mass", m, MAX_MASS, "kg")          # before any product of them
    check_magnitude(who, "center of mass", X[:3, 3], MAX_LENGTH, "m")
    check_magnitude(who, "inertia", I, MAX_INERTIA, "kg m^2")
    check_mass(link.name, m)
    R = X[:3, :3]
    return m, X[:3, 3].copy(), R @ I @ R.T


def _origin(joint):
    """The joint's <origin> (4, 4), its numbers checked: finite, and within any robot."""
    X = _finite_or_fail(_transform(joint.origin), f"joint {joint.name!r} origin")
    check_magnitude(f"joint {joint.name!r}", "origin xyz", X[:3, 3], MAX_LENGTH, "m")
    return X


def load_model(source, base_link=None, tip_link=None, gravity=(0.0, 0.0, -9.81),
               armature=None, floating_base=False, tip_links=None,
               repair_inertia=False) -> Model:
    """Parse a URDF (path or XML string) and build the validated model: the chain from
    ``base_link`` to ``tip_link``, the subtree from ``base_link`` to the links
    ``tip_links``, or (neither given) every movable joint below ``base_link``: a chain
    when they form one path, else the whole tree.
    ``armature``: {joint name: kg m^2}, set or override the transmissions' rotor inertia.
    ``floating_base``: the base link (with everything lumped into it) floats; so does the
    child of a ``type="floating"`` joint at the root, which is then the default base.
    ``repair_inertia``: a lumped body whose inertia is no rigid body's gets the nearest
    physical one, with an ``InertiaRepairWarning`` (default: a ``ModelError``)."""
    robot, xml = _parse(source)
    for kind, items in (("link", robot.links), ("joint", robot.joints)):
        seen = set()
        for item in items:
            if item.name in seen:
                raise URDFError(f"two <{kind}> elements are named {item.name!r}; "
                                f"{kind} names must be unique: rename or remove one")
            seen.add(item.name)
    links = {link.name: link for link in robot.links}
    joints = {joint.name: joint for joint in robot.joints}
    parent_joint = {}
    children = {name: [] for name in links}
    for joint in robot.joints:
        for end in (joint.parent, joint.child):
            if end not in links:
                raise URDFError(f"joint {joint.name!r} refers to link {end!r}, which is not "
                                "defined; add the <link> or fix the name")
        if joint.child in parent_joint:
            raise URDFError(f"link {joint.child!r} is the child of two joints "
                            f"({parent_joint[joint.child].name!r}, {joint.name!r}); "
                            "a URDF must be a tree")
        parent_joint[joint.child] = joint
        children[joint.parent].append(joint)
    roots = [name for name in links if name not in parent_joint]
    if not roots:                        # every link has a parent: the joints form a cycle
        check_tree(None, links, children, parent_joint)
    if len(roots) != 1:
        raise URDFError(f"the URDF must have exactly one root link (a link that is no "
                        f"joint's child), found {len(roots)}: {roots}; join them by joints")
    root = roots[0]
    check_tree(root, links, children, parent_joint)
    for joint in (j for j in children[root] if j.type == "floating"):   # world -> base
        floating_base = True
        base_link = joint.child if base_link in (None, root) else base_link

    base_link = root if base_link is None else base_link
    for role, name in (("base_link", base_link), ("tip_link", tip_link)):
        if name is not None and name not in links:
            raise URDFError(f"{role} {name!r} is not a link of this URDF; links are "
                            f"{sorted(links)}")
    if tip_link is not None and tip_links is not None:
        raise URDFError("give tip_link (one chain) or tip_links (a subtree), not both")
    if tip_links is None and tip_link is None and floating_base \
            and not has_movable(base_link, children):
        tips = [base_link]         # a free body: the floating root is its only joint
    elif tip_links is None:        # one chain, or the whole tree when the joints branch
        tip = tip_link if tip_link is not None else single_chain_tip(base_link, children)
        tips = [tip] if tip is not None else movable_leaves(base_link, children)
    else:
        tips = _check_tips(tip_links, links, base_link, parent_joint)
    paths = [path_up(tip, base_link, parent_joint) for tip in tips]
    for tip, path in zip(tips, paths):
        if path is None:
            raise URDFError(f"tip_link {tip!r} is not below base_link {base_link!r}; "
                            "choose a tip in the subtree of the base")
    chain_joints = {j.name for path in paths for j in path}   # the model's joints
    tip_link = tips[0] if len(tips) == 1 else None
    movable_chain = {name for name in chain_joints if joints[name].type in MOVABLE}
    all_joints = set(joints)
    scope = (f"chain {base_link!r} -> {tip_link!r}" if tip_link is not None else
             f"tree {base_link!r} -> {tips}")
    on, off = ("on the chain", "off the chain") if tip_link is not None else (
        "in the tree", "outside the tree")

    # -- walk the model's joints depth first (parents before children, Featherstone's
    # topological order): fold fixed joints, place links in bodies
    bodies = []                                  # dicts per movable joint
    frames = {base_link: (-1, np.eye(3), np.zeros(3))}
    parts = {-1: []}                             # inertia parts per body (-1: the base)
    held = []                                    # movable joints held (names, for the warning)
    def below(link, body, X_link):       # the model's joints below a link, first on top
        return [(j, body, X_link) for j in reversed(children[link]) if j.name in chain_joints]

    stack = below(base_link, -1, np.eye(4))      # a joint, its parent's body, link pose there
    while stack:
        joint, body, X_acc = stack.pop()
        what = f"joint {joint.name!r}"
        X = X_acc @ _origin(joint)
        child_body = body
        if joint.type in MOVABLE and joint.mimic is not None \
                and joint.mimic.joint not in movable_chain:
            X = X @ _held_at_offset(joint, all_joints, scope)
            held.append(f"joint {joint.name!r} {on} is held at its offset "
                        f"{_float(joint.mimic.offset, 0.0):g}: it mimics "
                        f"{joint.mimic.joint!r}, which is {off} and held at zero")
        elif joint.type in MOVABLE:          # its elementary joints, one body each
            for e, elementary in enumerate(_bodies(joint)):
                bodies.append(dict(elementary, X=X if e == 0 else np.eye(4), parent=child_body))
                child_body = len(bodies) - 1
                parts[child_body] = []
            X = np.eye(4)
        elif joint.type == "floating":
            raise URDFError(f"{what} {on} is floating, below the root {root!r}: a "
                            "floating joint may only join the root (the world) to the base; "
                            "make it fixed, or load the model from its child with "
                            "floating_base=True")
        elif joint.type != "fixed":
            raise URDFError(f"{what} {on} is of type {joint.type!r}; only "
                            f"{', '.join(MOVABLE)} and fixed joints can form a chain or a "
                            "tree")
        frames[joint.child] = (child_body, X[:3, :3].copy(), X[:3, 3].copy())
        stack.extend(below(joint.child, child_body, X))
    chain_links = list(frames)                   # the model's links, as met
    X_acc = _pose(frames[tips[0]]) if tip_link is not None else np.eye(4)
    if tip_link is None:
        tip_link = bodies[-1]["link"] if bodies else base_link

    # -- lump every link rigidly attached to a body (chain links and off-chain subtrees)
    off_chain, followers = [], []
    stack = [(name, frames[name][0], _pose(frames[name])) for name in chain_links]
    while stack:
        name, body, X_link = stack.pop()
        if body >= 0 or floating_base:   # links fixed to a fixed base: neither used nor checked
            m, c, I = _link_inertia(links[name])
            R = X_link[:3, :3]
            parts[body].append((m, R @ c + X_link[:3, 3], R @ I @ R.T))
        for joint in children[name]:
            if joint.name in chain_joints:
                continue
            X = X_link @ _origin(joint)
            if joint.type != "fixed":
                off_chain.append(joint.name)
                if joint.mimic is not None and joint.mimic.joint in movable_chain:
                    followers.append(f"{joint.name!r} mimics {joint.mimic.joint!r}")
            frames[joint.child] = (body, X[:3, :3].copy(), X[:3, 3].copy())
            stack.append((joint.child, body, X))
    if off_chain:
        held.insert(0, f"joints {sorted(off_chain)} are {off}: held at zero and "
                       "lumped into the link they hang from" + (
                           f" ({', '.join(sorted(followers))} {on} but does not "
                           "follow it: its mass stays where zero puts it; choose a tip_link "
                           "whose chain holds it to model it)" if followers else ""))
    if held:
        warnings.warn(f"{scope}: " + "; ".join(held), HeldJointsWarning, stacklevel=3)
    rotors = _armature(xml, bodies, armature, scope)
    leader, multiplier, offset = _mimic(bodies, scope)

    if not bodies and not floating_base:
        raise URDFError(f"no movable joint between {base_link!r} and {tip_link!r}; "
                        "choose a base_link and tip_link with revolute or prismatic joints between")
    lumped = {i: combine_inertias(p) if p else (0.0, np.zeros(3), np.zeros((3, 3)))
              for i, p in parts.items() if i >= 0 or floating_base}   # -1: a floating base
    sizes = body_sizes([lumped[i][1] for i in range(len(bodies))],
                       [b["X"][:3, 3] for b in bodies], [b["parent"] for b in bodies],
                       X_acc[:3, 3], lumped[-1][1] if floating_base else None)
    carrying = {}                              # body: its links that have an <inertial>
    for name, (body, _, _) in frames.items():
        if links[name].inertial is not None:
            carrying.setdefault(body, []).append(name)
    for i, (m, c, I) in lumped.items():        # judged as the dynamics sees them
        who = _body_name(i, bodies, base_link, carrying.get(i, []))
        lumped[i] = (m, c, physical_body(who, m, I, sizes[i], repair_inertia))
    mass, com, inertia = [[lumped[i][k] for i in range(len(bodies))] for k in range(3)]
    for i, b in enumerate(bodies):       # the links between a URDF joint's elementary ones
        if b["link"] not in frames:
            frames[b["link"]] = (i, np.eye(3), np.zeros(3))
    g_root = _finite_or_fail(gravity, "gravity").reshape(3)
    R_base = _pose_in_root(base_link, root, parent_joint)[:3, :3]
    model = Model.build(
        name=robot.name or "robot",
        joint_names=[b["name"] for b in bodies],
        joint_types=[b["type"] for b in bodies],
        link_names=[b["link"] for b in bodies],
        base_link=base_link, tip_link=tip_link,
        R_parent=[b["X"][:3, :3] for b in bodies], p_parent=[b["X"][:3, 3] for b in bodies],
        axis=[b["axis"] for b in bodies],
        mass=mass, com=com, inertia=inertia,
        gravity=g_root if floating_base else R_base.T @ g_root,   # a fixed base's coordinates
        tip_R=X_acc[:3, :3], tip_p=X_acc[:3, 3],
        lower=[b["lower"] for b in bodies], upper=[b["upper"] for b in bodies],
        velocity_limit=[b["velocity"] for b in bodies],
        effort_limit=[b["effort"] for b in bodies],
        damping=[b["damping"] for b in bodies], friction=[b["friction"] for b in bodies],
        frames=frames, parent=[b["parent"] for b in bodies], armature=rotors, mimic_leader=leader, mimic_multiplier=multiplier,
        mimic_offset=offset, source=_kept(source),
        base_inertia=lumped.get(-1),
    )
    check_mass_matrix(model)     # positive definite (the check that needs the algorithms)
    return model


def _body_name(i, bodies, base_link, carrying):
    """Body i (-1: the floating base) for a message: its link, and the other links with an
    <inertial> lumped into it (``carrying``: the body's links that have one)."""
    link = bodies[i]["link"] if i >= 0 else base_link
    lumped = [name for name in carrying if name != link]
    where = "the floating base" if i < 0 else f"the body of joint {bodies[i]['name']!r}"
    return f"link {link!r} ({where}" + (f", with {lumped} fixed to it)" if lumped else ")")


def _check_tips(tip_links, links, base_link, parent_joint):
    """``tip_links`` as a list of distinct links of the URDF below ``base_link``, none on
    another one's path from the base (it would add nothing)."""
    tips = [tip_links] if isinstance(tip_links, str) else list(tip_links)
    if not tips:
        raise URDFError("tip_links is empty; name the links the subtree must reach, or leave "
                        "it out for the whole tree")
    for tip in tips:
        if tip not in links:
            raise URDFError(f"tip_links entry {tip!r} is not a link of this URDF; links are "
                            f"{sorted(links)}")
    for tip in tips:
        path = path_up(tip, base_link, parent_joint)
        if path is None:
            raise URDFError(f"tip_links entry {tip!r} is not below base_link {base_link!r}; "
                            "choose links in the subtree of the base")
        above = {j.parent for j in path}
        for other in tips:
            if other != tip and other in above:
                raise URDFError(f"tip_links entry {other!r} is on the path from {base_link!r} "
                                f"to {tip!r}: it adds nothing; drop it")
    if len(set(tips)) != len(tips):
        raise URDFError(f"tip_links {tips} names a link twice; give each once")
    return tips


def _xml_text(source):
    """The URDF XML of a source given as XML (str or bytes); None for a file path."""
    text = source.decode() if isinstance(source, bytes) else source
    return text if isinstance(text, str) and text.lstrip().startswith("<") else None


def _kept(source):
    """What ``Model.source`` keeps of a URDF source: the XML, or a file's absolute path."""
    text = _xml_text(source)
    return text if text is not None else os.path.abspath(os.fspath(source))


def _mimic(bodies, scope):
    """Per body: the index of the joint it mimics (-1: independent), multiplier, offset."""
    index = {b["name"]: i for i, b in enumerate(bodies)}
    several = {b["joint"] for b in bodies if b["name"] != b["joint"]}
    leader, multiplier, offset = [-1] * len(bodies), [1.0] * len(bodies), [0.0] * len(bodies)
    for i, b in enumerate(bodies):
        if b["mimic"] is None:
            continue
        what, lead = f"joint {b['name']!r}", b["mimic"].joint
        if lead in several:
            raise URDFError(f"{what} mimics {lead!r}, a joint of several coordinates "
                            f"({', '.join(c['name'] for c in bodies if c['joint'] == lead)}); "
                            "only a joint of one coordinate can be followed")
        if lead not in index:
            raise URDFError(f"{what} mimics {lead!r}, which is not a movable joint "
                            f"of the {scope}; choose a base_link and tip_link (or "
                            "tip_links) whose model holds both, or a tip_link above the "
                            "mimic joint")
        if bodies[index[lead]]["mimic"] is not None:
            raise URDFError(f"{what} mimics {lead!r}, which mimics "
                            f"{bodies[index[lead]]['mimic'].joint!r} in turn: a mimic of a "
                            "mimic is not supported; make it mimic the independent joint "
                            "(multiply the multipliers, combine the offsets)")
        m = _float(b["mimic"].multiplier, 1.0)
        o = _float(b["mimic"].offset, 0.0)
        if not (np.isfinite(m) and np.isfinite(o)) or m == 0.0:
            raise URDFError(f"{what}: <mimic multiplier=\"{m}\" offset=\"{o}\"> must be finite "
                            "with a multiplier other than 0 (a joint that never moves is fixed)")
        leader[i], multiplier[i], offset[i] = index[lead], m, o
    return leader, multiplier, offset


def _held_at_offset(joint, all_joints, scope):
    """The motion (4, 4) of a mimic joint on the chain whose leader is off it: the leader
    is held at zero like every joint off the chain, so the joint at multiplier * 0 + offset."""
    lead = joint.mimic.joint
    if lead not in all_joints:
        raise URDFError(f"joint {joint.name!r} on the {scope} "
                        f"mimics {lead!r}, which is not a joint of this URDF; fix the name in "
                        "its <mimic joint=...>")
    offset = _float(joint.mimic.offset, 0.0)
    axis = _bodies(joint)[0]["axis"]
    X = np.eye(4)
    if joint.type == "prismatic":
        X[:3, 3] = offset * axis
    else:
        X[:3, :3] = rotation_about(axis, np.array([offset]))[0]
    return X


def _armature(xml, bodies, override, scope):
    """Reflected rotor inertia per chain joint: the transmissions', then ``override``."""
    names = [b["name"] for b in bodies]
    found = reflected_inertias(xml, URDFError)
    off = sorted(j for j in found if j not in names)
    if off:
        warnings.warn(f"transmissions of joints {off} act off the {scope}: their rotor "
                      "inertia is ignored", HeldJointsWarning,
                      stacklevel=4)
    for joint in override or {}:
        if joint not in names:
            raise URDFError(f"armature given for {joint!r}, which is not a movable joint of the "
                            f"{scope}; joints are {names}")
    merged = {**found, **(override or {})}
    for joint, value in merged.items():
        try:
            merged[joint] = float(value)
        except (TypeError, ValueError):
            raise URDFError(f"armature of joint {joint!r} is {value!r}, not a number; give the "
                            "reflected rotor inertia in kg m^2") from None
    return [merged.get(name, 0.0) for name in names]


def _pose(frame):
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = frame[1], frame[2]
    return X


def _pose_in_root(link, root, parent_joint):
    X = np.eye(4)
    while link != root:
        joint = parent_joint[link]
        X = _origin(joint) @ X   # joints above the base held at zero
        link = joint.parent
    return X


def _bodies(joint):
    """The model's bodies of a movable URDF joint, one per elementary joint
    (``joint_types.py``): name, type, link, axis, limits and dissipation, checked."""
    what = f"joint {joint.name!r}"
    axis = _finite_or_fail(np.array([1.0, 0, 0]) if joint.axis is None else joint.axis,
                           what + " axis")
    big = np.max(np.abs(axis))
    if big == 0:
        raise URDFError(f'{what} has a zero axis (<axis xyz="0 0 0">); give the direction of '
                        'the joint axis, e.g. <axis xyz="0 0 1"/>')
    axis = axis / big                    # |axis| of 1e200 or 1e-200 would over/underflow
    lim, dyn = joint.limit, joint.dynamics
    given = {key: getattr(lim, key, None) for key in ("lower", "upper", "effort", "velocity")}
    given.update({key: getattr(dyn, key, None) for key in ("damping", "friction")})
    values = {key: _float(v, 0.0) for key, v in given.items()}
    for key, v in values.items():    # an absent limit is none; an Inf one is refused
        if not np.isfinite(v):
            element = "limit" if key in ("lower", "upper", "effort", "velocity") else "dynamics"
            raise URDFError(f"{what}: <{element} {key}=\"{v}\"> is a NaN or Inf; give a "
                            "finite number" + (", or leave the attribute out for none"
                                               if element == "limit" else ""))
    lower, upper = _float(given["lower"], -np.inf), _float(given["upper"], np.inf)
    if lower == upper:                   # URDF default 0/0 means "no limits"
        lower, upper = -np.inf, np.inf
    if lower > upper:
        raise URDFError(f"{what}: lower limit {lower} > upper limit {upper}")
    for key in ("damping", "friction"):
        if values[key] < 0:
            raise URDFError(f"{what}: <dynamics {key}=\"{values[key]}\"> is negative; "
                            "dissipation coefficients must be >= 0")
    for key in ("effort", "velocity"):      # absent or non-positive limits are none
        if given[key] is None or values[key] <= 0:
            values[key] = np.inf
    parts = elementary_joints(joint.type, axis / np.linalg.norm(axis))
    if len(parts) > 1 and joint.mimic is not None:
        raise URDFError(f"{what} of type {joint.type!r} has a <mimic>: only a joint of one "
                        "coordinate can follow another; remove the <mimic>")
    last = len(parts) - 1
    return [dict(values, name=joint.name + e.suffix, type=e.type, joint=joint.name,
                 link=joint.child if k == last else joint.name + e.suffix, axis=e.axis,
                 lower=lower if e.limited else -np.inf, upper=upper if e.limited else np.inf,
                 mimic=joint.mimic)
            for k, e in enumerate(parts)]
