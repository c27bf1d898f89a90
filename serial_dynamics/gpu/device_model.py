"""A robot's model on the card: the packed joint-frame array ``P`` (``core/layout.py``),
the parent array of its bodies and the map of its coordinates to every joint, sent once
per robot and kept while the robot lives.

The kernels are written on the parent array (``parent[i] < i``: the body joint i hangs
from, -1 the base). The coordinates of a robot with mimic joints are its independent
joints: joint i reads coordinate ``src[i]`` times ``mult[i]`` plus ``offset[i]``
(``Model.mimic_matrix``, as ``robot/mimic.py``), and the results are mapped back by G^T.

A free-floating base is the CPU's *instantaneous chain* (``robot/floating.virtual_chain``,
``core/floating.py``): six virtual joints at zero, then the chain or tree, no gravity in
``P``; ``gw`` holds the world's gravity, which each state brings in as the base's
acceleration -R^T g. Its n bodies are its nv = n_joints + 6 velocity coordinates; q has
nv + 1 numbers (``nq``).
"""
import weakref
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..core import layout
from ..core.floating import GW
from ..robot.floating import virtual_chain
from .runtime import cuda

_CACHE = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class DeviceModel:
    n: int                 # bodies (every joint, mimic joints included)
    k: int                 # coordinates (the independent joints)
    chain: bool            # parent[i] == i - 1 for every body
    mimic: bool            # some joint follows another
    floating: bool         # a free-floating base (the instantaneous chain)
    host: tuple            # (P, parent, src, mult, offset, gw) as NumPy arrays

    @cached_property
    def arrays(self):
        """(P, parent, src, mult, offset, gw) on the card."""
        return tuple(cuda.to_device(a) for a in self.host)

    @property
    def structure(self):
        """(P, parent, src, mult, offset) on the card: ``arrays`` less gw, for the kernels
        that take gravity from P (the derivatives')."""
        return self.arrays[:5]

    @property
    def key(self):
        """What the kernels are specialized on."""
        return self.n, self.k, self.chain, self.mimic, self.floating

    @property
    def nq(self):
        """Numbers of a configuration: k, or nv + 1 on a floating base (the quaternion)."""
        return self.k + 1 if self.floating else self.k


def device_model(robot, op):
    """``robot``'s DeviceModel (built on first use). Mimic joints on a floating base are
    refused."""
    dm = _CACHE.get(robot)
    if dm is None:
        if robot.is_floating and robot.model.has_mimic_joints:
            raise NotImplementedError(
                f"serial_dynamics.gpu.{op}: mimic joints on a free-floating base are not on "
                f"the card yet; call robot.{op}(...) on the CPU for this robot")
        dm = _CACHE[robot] = (_build(virtual_chain(robot.model), robot.model.gravity)
                              if robot.is_floating else _build(robot.model))
    return dm


def _build(model, world_gravity=None):
    """The DeviceModel of a fixed-base ``model``, or of a floating base's instantaneous chain
    (``world_gravity`` given: gw's gravity)."""
    n, floating = model.dof, world_gravity is not None
    parent = getattr(model, "parent", None)
    parent = np.arange(n, dtype=np.int64) - 1 if parent is None else np.asarray(parent, np.int64)
    if model.has_mimic_joints:
        G, offset = model.mimic_matrix
        src = np.argmax(G != 0.0, axis=1)
        mult = G[np.arange(n), src]
    else:
        src, mult, offset = np.arange(n), np.ones(n), np.zeros(n)
    gw = np.zeros((1, GW))          # one row: the kernels copy it as they copy a state's
    if floating:
        gw[0, 6:] = world_gravity
    host = (layout.pack(model, root=6 if floating else 0), parent, src.astype(np.int64),
            np.ascontiguousarray(mult, float), np.ascontiguousarray(offset, float), gw)
    return DeviceModel(n=n, k=len(model.independent),
                       chain=bool(np.all(parent == np.arange(n) - 1)),
                       mimic=bool(model.has_mimic_joints), floating=floating, host=host)
