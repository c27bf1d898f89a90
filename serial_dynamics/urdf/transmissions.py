"""Rotor inertia and gear ratio from URDF ``<transmission>`` elements (the armature).

A geared motor adds its rotor's inertia, reflected through the gear, to its joint:
I_a = N^2 J_rotor (N the gear ratio; Featherstone 2008, Sec. 9.6), on the mass matrix's
diagonal. Read, per transmission with one ``<joint name=...>`` and one ``<actuator>``:

    <actuator name="...">
      <drake:rotor_inertia value="J_rotor"/>   kg m^2 (Drake's tag)
      <drake:gear_ratio value="N"/>            (Drake's tag; else the ROS
      <mechanicalReduction>N</mechanicalReduction>  element; else 1)
    </actuator>

A transmission without a rotor inertia adds nothing. yourdfpy does not read Drake's tags,
so the XML is read here (lxml, as yourdfpy does).
"""
from __future__ import annotations

import math


def _local(tag) -> str:
    """An element's name without namespace or an undeclared prefix ("drake:x" -> "x")."""
    tag = tag if isinstance(tag, str) else ""
    return tag.rsplit("}", 1)[-1].rsplit(":", 1)[-1]


def _number(text, what, error):
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise error(f"{what} is {text!r}, not a number; fix it") from None
    if not math.isfinite(value) or value < 0:
        raise error(f"{what} is {value}; give a finite number >= 0")
    return value


def reflected_inertias(root, error) -> dict:
    """{joint name: N^2 J_rotor} of every transmission with a rotor inertia under the
    ``<robot>`` element ``root``. A malformed one raises ``error`` naming it."""
    out = {}
    for k, tr in enumerate(el for el in root if _local(el.tag) == "transmission"):
        name = tr.get("name") or f"#{k + 1}"
        joints = [el for el in tr if _local(el.tag) == "joint"]
        actuators = [el for el in tr if _local(el.tag) == "actuator"]
        rotor = [el for a in actuators for el in a if _local(el.tag) == "rotor_inertia"]
        if not rotor:
            continue                      # nothing to add (e.g. a ros2_control interface)
        what = f"<transmission name={name!r}>"
        if len(joints) != 1 or len(actuators) != 1 or len(rotor) != 1:
            raise error(f"{what} has {len(joints)} <joint>, {len(actuators)} <actuator> and "
                        f"{len(rotor)} rotor_inertia elements; a rotor inertia needs exactly "
                        "one of each (a simple transmission)")
        joint = joints[0].get("name")
        if not joint:
            raise error(f"{what}: its <joint> has no name attribute; name the joint it drives")
        J = _number(rotor[0].get("value"), f"{what} rotor_inertia value", error)
        ratio = [el.get("value") for el in actuators[0] if _local(el.tag) == "gear_ratio"]
        ratio = ratio or [el.text for el in actuators[0] if _local(el.tag) == "mechanicalReduction"]
        N = _number(ratio[0], f"{what} gear ratio", error) if ratio else 1.0
        if joint in out:
            raise error(f"{what}: joint {joint!r} has a rotor inertia from two transmissions; "
                        "keep one")
        out[joint] = N * N * J
    return out
