"""Synthetic serial chains for tests and benchmarks (long, stiff, ill-conditioned), and two
of them on one base (``two_arm_urdf``: a tree).

``chain_urdf(n, ...)`` writes an n-joint chain of uniform rods: body i is a rod of
length ``lengths[i]`` along its local X with mass ``masses[i]`` (solid cylinder of
radius ``radius``), joint i+1 at its far end. Joint axes cycle through ``axes``
(default Z, Y, X: a genuinely spatial chain); ``kinds`` may make joints prismatic.
"""
from __future__ import annotations

import numpy as np

from . import _f, _inertial, _joint, _v


def chain_urdf(n, *, masses=1.0, lengths=0.3, radius=0.02, axes=("z", "y", "x"),
               kinds="revolute", damping=0.0, friction=0.0, effort=1000.0, velocity=100.0,
               limits=None, name="chain") -> str:
    """URDF XML of an n-joint serial chain; array arguments are per joint or scalar.
    ``limits``: None (revolute joints are continuous) or (lower, upper) of the revolute
    joints, one pair or one per joint (rad)."""
    per = lambda v: np.broadcast_to(np.asarray(v), (n,))  # noqa: E731
    masses, lengths, damping, friction = per(masses), per(lengths), per(damping), per(friction)
    kinds = [kinds] * n if isinstance(kinds, str) else list(kinds)
    unit = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
    out = ['<?xml version="1.0"?>', f'<robot name="{name}">', '<link name="base_link"/>']
    parent = "base_link"
    for i in range(n):
        m, L = float(masses[i]), float(lengths[i])
        I = np.diag([0.5 * m * radius**2] + [m * (3 * radius**2 + L**2) / 12.0] * 2)
        out.append(f'<link name="link{i + 1}">{_inertial(m, (L / 2, 0, 0), I)}</link>')
        xyz = (0, 0, 0) if i == 0 else (float(lengths[i - 1]), 0, 0)
        kind = kinds[i]
        lo, hi = (-1.0, 1.0) if kind == "prismatic" else (None, None)
        if kind == "revolute" and limits is not None:
            lo, hi = np.broadcast_to(np.asarray(limits, dtype=float), (n, 2))[i]
        bounds = "" if lo is None else f'lower="{_f(lo)}" upper="{_f(hi)}" '
        limit = f'<limit {bounds}effort="{_f(effort)}" velocity="{_f(velocity)}"/>'
        if kind == "revolute" and lo is None:
            kind = "continuous"
        dyn = f'<dynamics damping="{_f(damping[i])}" friction="{_f(friction[i])}"/>'
        out.append(_joint(f"joint{i + 1}", parent, f"link{i + 1}", xyz,
                          unit[axes[i % len(axes)]], kind=kind,
                          limit=limit, dynamics=dyn))
        parent = f"link{i + 1}"
    out.append('<link name="tip"/>')
    out.append(f'<joint name="tip_joint" type="fixed"><parent link="{parent}"/><child link="tip"/>'
               f'<origin xyz="{_v((float(lengths[-1]), 0, 0))}" rpy="0 0 0"/></joint>')
    out.append("</robot>")
    return "\n".join(out) + "\n"


def two_arm_urdf(n_each, base_mass=None, **kw) -> str:
    """Two ``chain_urdf(n_each, **kw)`` arms (joints ``joint1..`` and ``b_joint1..``) on one
    base link: a tree of depth ``n_each``. ``base_mass`` (kg): give the base link a body
    (a 0.2 m cube's inertia), as a floating base needs."""
    a, b = chain_urdf(n_each, **kw), chain_urdf(n_each, **kw)
    b = b.replace('"link', '"b_link').replace('"joint', '"b_joint').replace('"tip', '"b_tip')
    xml = a.split("</robot>")[0] + b.split('<link name="base_link"/>')[1]
    if base_mass is not None:
        I = np.eye(3) * base_mass * 0.2 ** 2 / 6.0
        xml = xml.replace('<link name="base_link"/>',
                          f'<link name="base_link">{_inertial(base_mass, (0, 0, 0), I)}</link>')
    return xml


def mimic_chain_urdf(n, follower=None, multiplier=0.5, **kw) -> str:
    """``chain_urdf(n, **kw)`` with joint ``follower`` (1-based; default the last) mimicking
    the joint before it: ``<mimic joint="joint{follower - 1}" multiplier=...>``."""
    follower = n if follower is None else follower
    xml = chain_urdf(n, **kw)
    start = xml.index(f'<joint name="joint{follower}"')
    end = xml.index("</joint>", start)
    return (xml[:end] + f'<mimic joint="joint{follower - 1}" multiplier="{_f(multiplier)}"/>'
            + xml[end:])


def stiff_chain_urdf(n=4) -> str:
    """Heavy proximal links (20 kg), very light distal links (10 g), joint damping
    1 .. 0.05 N m s/rad: a stiff ODE. For n = 4 the damped modes of the state equations
    decay at rates from about 0.6 /s to 3.6e3 .. 5e3 /s (eigenvalues of -M^-1 diag(beta)
    over configurations) while gravity swings the chain with periods near 1 s: explicit
    methods are held to steps of about 0.7 ms by stability (semi-implicit Euler diverges
    at 1 ms), implicit ones follow the slow motion."""
    masses = np.geomspace(20.0, 0.01, n)
    lengths = np.linspace(0.4, 0.1, n)
    damping = np.geomspace(2.0, 0.2, n)
    return chain_urdf(n, masses=masses, lengths=lengths, damping=damping, name="stiff_chain")


def ill_conditioned_chain_urdf(n=6) -> str:
    """Link masses spanning a ratio of 1e6 (10 kg down to 1e-5 kg) on slender rods (2 mm
    radius; the last joint spins the lightest rod about its own axis): the mass-matrix
    condition number is 1.6e10 .. 2.3e10 at generic configurations."""
    masses = np.geomspace(10.0, 1e-5, n)
    return chain_urdf(n, masses=masses, lengths=0.3, radius=0.002, name="ill_conditioned_chain")


def double_pendulum_urdf() -> str:
    """The double pendulum of the energy benchmarks (issue 12): two 1 m, 1 kg links with
    centres of mass at mid-length and 0.02 kg m^2 about them, both axes horizontal (y),
    hanging under gravity at q = 0."""
    def link(name):
        return (f'<link name="{name}"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>'
                '<inertia ixx="0.02" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/>'
                '</inertial></link>')
    return ('<robot name="double_pendulum"><link name="base"/>' + link("l1") + link("l2")
            + '<joint name="j1" type="continuous"><parent link="base"/><child link="l1"/>'
              '<axis xyz="0 1 0"/></joint>'
              '<joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>'
              '<origin xyz="0 0 -1"/><axis xyz="0 1 0"/></joint></robot>')


def satellite_urdf(base_mass=400.0, side=1.5) -> str:
    """A space manipulator: a cube satellite of ``base_mass`` kg and ``side`` m (uniform
    density) joined to the world by a floating joint, carrying a 7-joint arm (26 kg, 2.3 m
    reach; joint axes z, y, x, ...) on its face at x = side / 2."""
    arm = chain_urdf(7, masses=(6.0, 6.0, 4.0, 4.0, 3.0, 2.0, 1.0),
                     lengths=(0.2, 0.5, 0.5, 0.4, 0.3, 0.2, 0.2), radius=0.04, name="satellite")
    I = np.eye(3) * base_mass * side**2 / 6.0
    body = f'<link name="base_link">{_inertial(base_mass, (0, 0, 0), I)}</link>'
    world = ('<link name="world"/><joint name="world_to_base" type="floating">'
             '<parent link="world"/><child link="base_link"/></joint>')
    arm = arm.replace('<link name="base_link"/>', world + body, 1)
    return arm.replace('<child link="link1"/><origin xyz="0.0 0.0 0.0"',
                       f'<child link="link1"/><origin xyz="{_f(side / 2)} 0.0 0.0"', 1)
