"""The immutable description of a serial chain (the *model*) and its validation.

A ``Model`` is data: it is built once (by ``urdf/loader.py`` or by hand), validated once,
and never mutated by an algorithm. Every array is read-only and contiguous so that
the algorithms (pure NumPy or compiled) can use it directly.

Frames and conventions
----------------------
Body ``i`` (0-based, ``i = 0 .. n-1``) is the link moved by joint ``i``; its frame is
the child frame of that joint in the URDF. The bodies form a tree in topological order:
joint ``i`` hangs from body ``parent[i] < i`` (``-1``: the base), Featherstone's parent
array lambda(i) (2008, Sec. 4.1.2); a chain is the case ``parent[i] = i - 1``. The
placement of joint ``i`` in its parent body ``l = parent[i]`` is the rotation
``R_parent[i]`` and the translation ``p_parent[i]``, so that, with ``E(q)`` the joint motion,

    X_{l <- i}(q) = (R_parent[i], p_parent[i]) * E_i(q)

    revolute:  E = (Rot(axis[i], q), 0)      prismatic: E = (1, axis[i] * q)

``axis[i]`` is a unit vector in body ``i``'s frame (equal in the joint frame, since the
joint motion leaves its axis fixed). Inertia of body ``i``: ``mass[i]``, center of mass
``com[i]`` in body ``i``'s frame and the 3x3 rotational inertia ``inertia[i]`` about the
center of mass, in body ``i``'s axes. ``armature[i]``: joint ``i``'s reflected rotor
inertia (gear ratio squared times the rotor's inertia), which adds to M_ii and, times
qdd_i, to tau_i. ``gravity`` is in the base frame.
``tip_R, tip_p`` place the tip frame (where a tip wrench acts) in the last body.
``frames`` maps every named link of the model to ``(body, R, p)``: its placement in
body ``body``'s link frame (``-1``: the base).

The algorithms' frames (one convention for every algorithm; docs/conventions.md)
--------------------------------------------------------------------------------
The fields above are the chain *as given* (URDF link frames). ``build`` derives from them,
once, the chain in **joint frames**, which every algorithm (NumPy reference and compiled
core alike) uses: joint frame ``i`` has body ``i``'s origin and its z axis along joint
``i``'s axis, ``x_link = A[i] x_joint`` (``A[i] = 1`` when the URDF axis is already +z).

    Xtree_R[i], Xtree_p[i]   joint frame i in joint frame parent[i] at q = 0 (-1: the base)
    body i in its parent     R = Xtree_R Rz(q), p = Xtree_p        (revolute)
                             R = Xtree_R,       p = Xtree_p + q Xtree_R e_z  (prismatic)
    c[i], I_c[i]             center of mass and rotational inertia about it
    h[i] = m c, I_O[i]       first moment and rotational inertia about the body origin
    Xtip_R, Xtip_p           the tip frame in joint frame n-1
    jframes                  ``frames`` with every placement in joint frames

so the joint's motion subspace is always S = e_z (angular, revolute) or e_z (linear,
prismatic), as in Featherstone's *Rigid Body Dynamics Algorithms* (2008), Ch. 4.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType

import numpy as np

from .errors import ModelError
from .inertia import (MAX_DAMPING, MAX_FRICTION, MAX_INERTIA, MAX_LENGTH, MAX_MASS,
                      body_sizes, check_inertia, check_magnitude)
from ..joints import PRISMATIC, REVOLUTE  # noqa: F401  (re-exported)


def _frozen(a, shape=None, dtype=float):
    a = np.ascontiguousarray(np.array(a, dtype=dtype))
    if shape is not None and a.size == 0 and 0 in shape:
        a = a.reshape(shape)          # no joints (a free body): empty lists of any shape
    if shape is not None and a.shape != shape:
        raise ModelError(f"expected an array of shape {shape}, got {a.shape}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Model:
    """Immutable serial-chain model; see the module docstring for the conventions."""

    name: str
    joint_names: tuple
    joint_types: tuple          # 'revolute' | 'continuous' | 'prismatic' (as in the URDF)
    link_names: tuple           # body i's link name
    base_link: str
    tip_link: str
    R_parent: np.ndarray        # (n, 3, 3)
    p_parent: np.ndarray        # (n, 3)
    axis: np.ndarray            # (n, 3) unit
    kind: np.ndarray            # (n,) int: REVOLUTE or PRISMATIC
    mass: np.ndarray            # (n,)
    com: np.ndarray             # (n, 3)
    inertia: np.ndarray         # (n, 3, 3) about the center of mass
    gravity: np.ndarray         # (3,) in the base frame, m/s^2
    tip_R: np.ndarray           # (3, 3)
    tip_p: np.ndarray           # (3,)
    lower: np.ndarray           # (n,) rad or m, -inf where absent
    upper: np.ndarray           # (n,)
    velocity_limit: np.ndarray  # (n,) rad/s or m/s, inf where absent
    effort_limit: np.ndarray    # (n,) N m or N, inf where absent
    damping: np.ndarray         # (n,) URDF <dynamics damping>, N m s/rad or N s/m
    friction: np.ndarray        # (n,) URDF <dynamics friction>, N m or N
    frames: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))
    armature: np.ndarray = None # (n,) reflected rotor inertia N^2 J_rotor, kg m^2 or kg
    # mimic joints: q_i = multiplier[i] q_leader[i] + offset[i] where leader[i] >= 0
    mimic_leader: np.ndarray = None      # (n,) int, -1 for an independent joint
    mimic_multiplier: np.ndarray = None  # (n,)
    mimic_offset: np.ndarray = None      # (n,) rad or m
    # the URDF the model was loaded from: a file's absolute path, or the XML text (None when
    # built by hand); kept across with_payload, read by identification's write_urdf
    source: object = None
    # the tree: joint i hangs from body parent[i] < i (-1: the base); a chain has i - 1
    parent: np.ndarray = None            # (n,) int
    # -- derived by build(): the chain in joint frames (the algorithms' convention)
    A: np.ndarray = None        # (n, 3, 3) joint frame i's axes in link frame i
    Xtree_R: np.ndarray = None  # (n, 3, 3)
    Xtree_p: np.ndarray = None  # (n, 3)
    h: np.ndarray = None        # (n, 3) m c, joint frame
    c: np.ndarray = None        # (n, 3) center of mass, joint frame
    I_c: np.ndarray = None      # (n, 3, 3) rotational inertia about the center of mass, joint frame
    I_O: np.ndarray = None      # (n, 3, 3) rotational inertia about the body origin, joint frame
    Xtip_R: np.ndarray = None   # (3, 3)
    Xtip_p: np.ndarray = None   # (3,)
    jframes: MappingProxyType = None
    # -- a free-floating base (docs/modelling.md): the base link's own inertia (everything
    # lumped into it), base frame; gravity is then in the world frame
    floating: bool = False
    base_mass: float = 0.0
    base_com: np.ndarray = None      # (3,)
    base_inertia: np.ndarray = None  # (3, 3) about the center of mass
    base_h: np.ndarray = None        # (3,) m c
    base_I_O: np.ndarray = None      # (3, 3) about the base origin

    @property
    def dof(self) -> int:
        """The number of bodies (joints) of the chain, mimic joints included."""
        return len(self.joint_names)

    @property
    def is_chain(self) -> bool:
        """Every body hangs from the one before it (parent[i] = i - 1): a serial chain."""
        return bool(np.array_equal(self.parent, np.arange(self.dof) - 1))

    @cached_property
    def children(self) -> tuple:
        """children[i]: the bodies whose joints hang from body i (a tuple of tuples)."""
        kids = [[] for _ in range(self.dof)]
        for i, l in enumerate(self.parent):
            if l >= 0:
                kids[l].append(i)
        return tuple(tuple(k) for k in kids)

    @cached_property
    def depths(self) -> np.ndarray:
        """depths[i]: the joints from the base to body i, its own included (i + 1 on a
        chain)."""
        d = np.zeros(self.dof, dtype=int)
        for i, l in enumerate(self.parent):          # parents come first
            d[i] = 1 + (d[l] if l >= 0 else 0)
        return d

    def ancestors(self, body) -> list:
        """The bodies from the root down to ``body`` (included; [] for -1, the base)."""
        path = []
        while body >= 0:
            path.append(int(body))
            body = self.parent[body]
        return path[::-1]

    @property
    def independent(self) -> np.ndarray:
        """Indices of the joints that mimic none: the coordinates of the reduced system."""
        return np.flatnonzero(self.mimic_leader < 0)

    @property
    def mimic_matrix(self):
        """(G, o): q_all = G q + o maps the independent joints' q to every joint's (G is
        (n, k), constant), so qd_all = G qd, tau = G^T tau_all and M = G^T M_all G."""
        ind = self.independent
        column = {j: k for k, j in enumerate(ind)}
        G = np.zeros((self.dof, ind.size))
        for i in range(self.dof):
            lead = self.mimic_leader[i]
            G[i, column[i] if lead < 0 else column[lead]] = 1.0 if lead < 0 else self.mimic_multiplier[i]
        return G, np.where(self.mimic_leader < 0, 0.0, self.mimic_offset)

    @property
    def has_mimic_joints(self) -> bool:
        """Some joint of the chain follows another (``<mimic>``)."""
        return bool(np.any(self.mimic_leader >= 0))

    @staticmethod
    def build(*, name, joint_names, joint_types, link_names, base_link, tip_link,
              R_parent, p_parent, axis, mass, com, inertia, gravity=(0, 0, -9.81),
              tip_R=None, tip_p=None, lower=None, upper=None, velocity_limit=None,
              effort_limit=None, damping=None, friction=None, frames=None, armature=None,
              mimic_leader=None, mimic_multiplier=None, mimic_offset=None, source=None,
              base_inertia=None, parent=None) -> "Model":
        """Build and validate a model; every array argument is copied and frozen.
        ``parent``: the body each joint hangs from (parent[i] < i, -1: the base); None: a chain.
        ``base_inertia``: (mass, com, inertia about the com) of a free-floating base, in the
        base frame (None: a fixed base); ``gravity`` is then in the world frame."""
        n = len(joint_names)
        if n == 0 and base_inertia is None:     # a free body (floating base only) has none
            raise ModelError(f"chain {base_link!r} -> {tip_link!r} has no movable joint")
        full = lambda v, fill: _frozen(np.full(n, fill) if v is None else v, (n,))  # noqa: E731
        given = np.array(axis, dtype=float).reshape(n, 3)
        axis = given.copy()
        big = np.max(np.abs(axis), axis=1)
        odd = (big > 0) & ((big < 1e-100) | (big > 1e100))   # |axis| would under/overflow
        axis[odd] /= big[odd, None]
        norms = np.linalg.norm(axis, axis=1)
        for i in np.flatnonzero(~(norms > 1e-12) | ~np.isfinite(norms)):
            raise ModelError(f"joint {joint_names[i]!r}: axis is {given[i].tolist()}; give a "
                             "finite, non-zero direction (a unit vector)")
        kind = [PRISMATIC if t == "prismatic" else REVOLUTE for t in joint_types]
        model = Model(
            name=name, joint_names=tuple(joint_names), joint_types=tuple(joint_types),
            link_names=tuple(link_names), base_link=base_link, tip_link=tip_link,
            R_parent=_frozen(R_parent, (n, 3, 3)), p_parent=_frozen(p_parent, (n, 3)),
            axis=_frozen(axis / norms[:, None]), kind=_frozen(kind, (n,), np.int64),
            mass=_frozen(mass, (n,)), com=_frozen(com, (n, 3)),
            inertia=_frozen(inertia, (n, 3, 3)), gravity=_frozen(gravity, (3,)),
            tip_R=_frozen(np.eye(3) if tip_R is None else tip_R, (3, 3)),
            tip_p=_frozen(np.zeros(3) if tip_p is None else tip_p, (3,)),
            lower=full(lower, -np.inf), upper=full(upper, np.inf),
            velocity_limit=full(velocity_limit, np.inf), effort_limit=full(effort_limit, np.inf),
            damping=full(damping, 0.0), friction=full(friction, 0.0),
            armature=full(armature, 0.0),
            mimic_leader=_frozen(np.full(n, -1) if mimic_leader is None else mimic_leader, (n,),
                                 np.int64),
            mimic_multiplier=full(mimic_multiplier, 1.0), mimic_offset=full(mimic_offset, 0.0),
            frames=MappingProxyType({link: (int(b), _frozen(R, (3, 3)), _frozen(p, (3,)))
                                     for link, (b, R, p) in (frames or {}).items()}),
            source=source,
            parent=_frozen(np.arange(n) - 1 if parent is None else parent, (n,), np.int64),
        )
        _check_parent(model)
        if base_inertia is not None:
            m0, c0, I0 = (np.asarray(x, dtype=float) for x in base_inertia)
            _, _, h0, I_O0 = inertia_in_joint_frames(np.eye(3), m0, c0, I0)
            for key, value in dict(floating=True, base_mass=float(m0), base_com=_frozen(c0, (3,)),
                                   base_inertia=_frozen(I0, (3, 3)), base_h=_frozen(h0, (3,)),
                                   base_I_O=_frozen(I_O0, (3, 3))).items():
                object.__setattr__(model, key, value)
        _check_magnitudes(model)
        for key, value in _joint_frames(model).items():
            object.__setattr__(model, key, value)     # derived once, before anyone sees it
        model.validate()
        return model

    # ------------------------------------------------------------------ validation
    def validate(self) -> None:
        """Raise ``ModelError`` naming the culprit if the model is not physical: finite
        numbers, physical inertias, rotations, limits, mimic joints. (Whether its mass
        matrix is positive definite needs an algorithm: ``urdf/mass_matrix.py``, which the
        loader runs.)"""
        for arr_name in ("R_parent", "p_parent", "axis", "mass", "com", "inertia", "gravity",
                         "tip_R", "tip_p", "damping", "friction", "armature"):
            arr = getattr(self, arr_name)
            if not np.all(np.isfinite(arr)):
                bad = np.argwhere(~np.isfinite(arr))[0]
                who = (f"joint {self.joint_names[bad[0]]!r} / link {self.link_names[bad[0]]!r}"
                       if arr.ndim >= 1 and arr.shape[0] == self.dof and arr_name not in
                       ("gravity", "tip_p") else "the model")
                raise ModelError(f"{who}: {arr_name} has a NaN or Inf entry; fix the number")
        sizes = body_sizes(self.com, self.p_parent, self.parent, self.tip_p,
                           self.base_com if self.floating else None)
        for i in range(self.dof):
            check_inertia(self.link_names[i], self.mass[i], self.inertia[i], length=sizes[i])
            R = self.R_parent[i]
            if not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
                raise ModelError(f"joint {self.joint_names[i]!r}: origin rotation is not a rotation")
        for arr_name in ("damping", "friction"):
            arr = getattr(self, arr_name)
            for i in np.flatnonzero(arr < 0):
                raise ModelError(f"joint {self.joint_names[i]!r}: {arr_name} = {arr[i]} < 0; "
                                 "dissipation coefficients must be >= 0")
        for i in np.flatnonzero(self.armature < 0):
            raise ModelError(f"joint {self.joint_names[i]!r}: armature (reflected rotor inertia) "
                             f"= {self.armature[i]} < 0; give gear_ratio^2 * rotor_inertia >= 0")
        for i in np.flatnonzero(self.mimic_leader >= 0):
            lead = self.mimic_leader[i]
            if not (0 <= lead < self.dof and self.mimic_leader[lead] < 0):
                raise ModelError(f"joint {self.joint_names[i]!r} mimics body {lead}, which is "
                                 "not an independent joint of the model")
            if self.mimic_multiplier[i] == 0.0 or not np.isfinite(self.mimic_offset[i]):
                raise ModelError(f"joint {self.joint_names[i]!r}: mimic multiplier must be "
                                 "finite and non-zero, offset finite")
        for i in np.flatnonzero(self.lower > self.upper):
            raise ModelError(f"joint {self.joint_names[i]!r}: lower limit {self.lower[i]} > "
                             f"upper limit {self.upper[i]}")
        if self.floating:
            check_inertia(self.base_link, self.base_mass, self.base_inertia, length=sizes[-1])

def _check_parent(model) -> None:
    """The parent array lists the bodies in topological order: -1 <= parent[i] < i."""
    for i, l in enumerate(model.parent):
        if not -1 <= l < i:
            raise ModelError(f"joint {model.joint_names[i]!r} hangs from body {l}: bodies must "
                             "be in topological order, parent[i] in -1 .. i-1 (-1: the base)")


def _check_magnitudes(model) -> None:
    """Refuse absurd magnitudes, naming the link or joint and the bound."""
    for i in range(model.dof):
        joint, link = f"joint {model.joint_names[i]!r}", f"link {model.link_names[i]!r}"
        check_magnitude(joint, "origin xyz", model.p_parent[i], MAX_LENGTH, "m")
        check_magnitude(link, "center of mass", model.com[i], MAX_LENGTH, "m")
        check_magnitude(link, "mass", model.mass[i], MAX_MASS, "kg")
        check_magnitude(link, "inertia", model.inertia[i], MAX_INERTIA, "kg m^2")
        check_magnitude(joint, "armature", model.armature[i], MAX_INERTIA, "kg m^2")
        check_magnitude(joint, "damping", model.damping[i], MAX_DAMPING, "N m s/rad (N s/m)")
        check_magnitude(joint, "friction", model.friction[i], MAX_FRICTION, "N m (N)")
    check_magnitude(f"tip link {model.tip_link!r}", "placement in the last body", model.tip_p,
                    MAX_LENGTH, "m")


def axis_frame(axis) -> np.ndarray:
    """A rotation A with A e_z = axis (the identity when the axis is already +z)."""
    a = np.asarray(axis, dtype=float)
    if np.array_equal(a, [0.0, 0.0, 1.0]):
        return np.eye(3)
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    b1 = np.cross(helper, a)
    b1 /= np.linalg.norm(b1)
    return np.column_stack([b1, np.cross(a, b1), a])


def _joint_frames(model) -> dict:
    """The bodies in joint frames (module docstring), derived from the tree as given."""
    n = model.dof
    A = np.array([axis_frame(a) for a in model.axis]).reshape(n, 3, 3)
    A_prev = np.concatenate([np.eye(3)[None], A])[model.parent + 1]   # the parent's (-1: base)
    At_prev = np.swapaxes(A_prev, 1, 2)
    c, I_c, h, I_O = inertia_in_joint_frames(A, model.mass, model.com, model.inertia)
    A_tip = A[-1] if n else np.eye(3)          # a free body's tip is its base
    jframes = {link: (b, R if b < 0 else A[b].T @ R, p if b < 0 else A[b].T @ p)
               for link, (b, R, p) in model.frames.items()}
    return dict(
        A=_frozen(A, (n, 3, 3)), Xtree_R=_frozen(At_prev @ model.R_parent @ A, (n, 3, 3)),
        Xtree_p=_frozen(np.einsum("nji,nj->ni", A_prev, model.p_parent), (n, 3)),
        c=_frozen(c, (n, 3)), I_c=_frozen(I_c, (n, 3, 3)), h=_frozen(h, (n, 3)),
        I_O=_frozen(I_O, (n, 3, 3)),
        Xtip_R=_frozen(A_tip.T @ model.tip_R, (3, 3)), Xtip_p=_frozen(A_tip.T @ model.tip_p, (3,)),
        jframes=MappingProxyType({k: (int(b), _frozen(R, (3, 3)), _frozen(p, (3,)))
                                  for k, (b, R, p) in jframes.items()}))


def inertia_in_joint_frames(A, mass, com, inertia):
    """(c, I_c, h, I_O) in joint frames of bodies (stacks, or one) given in their link
    frames: c = A^T com, I_c = A^T inertia A, h = m c, and about the origin
    I_O = I_c + m (|c|^2 1 - c c^T) (parallel axes); the inertias symmetrized."""
    mass = np.asarray(mass, dtype=float)
    c = np.einsum("...ji,...j->...i", A, com)                   # A^T c
    Ic = np.swapaxes(A, -1, -2) @ inertia @ A                   # A^T I_c A
    cc = np.einsum("...i,...j->...ij", c, c)
    I_O = Ic + mass[..., None, None] * (np.einsum("...i,...i->...", c, c)[..., None, None]
                                        * np.eye(3) - cc)
    sym = lambda X: 0.5 * (X + np.swapaxes(X, -1, -2))          # noqa: E731
    return c, sym(Ic), mass[..., None] * c, sym(I_O)
