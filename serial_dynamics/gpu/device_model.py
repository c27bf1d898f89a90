"""A robot's model on the card: the packed joint-frame array ``P`` (``core/layout.py``),
the parent array of its bodies and the map of its coordinates to every joint, sent once
per robot and kept while the robot lives.

The kernels are written on the parent array (``parent[i] < i``: the body joint i hangs
from, -1 the base; ``Model.parent`` once models are trees, ``i - 1`` for a chain until
then). The coordinates of a robot with mimic joints are its independent joints: joint i
reads coordinate ``src[i]`` times ``mult[i]`` plus ``offset[i]`` (``Model.mimic_matrix``,
as ``robot/mimic.py``), and the results are mapped back by G^T.
"""
import weakref
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..core import layout
from .runtime import cuda

_CACHE = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class DeviceModel:
    n: int                 # bodies (every joint, mimic joints included)
    k: int                 # coordinates (the independent joints)
    chain: bool            # parent[i] == i - 1 for every body
    mimic: bool            # some joint follows another
    host: tuple            # (P, parent, src, mult, offset) as NumPy arrays

    @cached_property
    def arrays(self):
        """(P, parent, src, mult, offset) on the card."""
        return tuple(cuda.to_device(a) for a in self.host)

    @property
    def key(self):
        """What the kernels are specialized on."""
        return self.n, self.k, self.chain, self.mimic


def device_model(robot, op):
    """``robot``'s DeviceModel (built on first use). A free-floating base is refused."""
    if robot.is_floating:
        raise NotImplementedError(
            f"serial_dynamics.gpu.{op}: a free-floating base is not on the card yet (its "
            "kernels have no 6-DoF free-flyer root joint, which the CPU runs through "
            "core/floating.py); call robot." + op + "(...) on the CPU for this robot")
    dm = _CACHE.get(robot)
    if dm is None:
        dm = _CACHE[robot] = _build(robot.model)
    return dm


def _build(model):
    n = model.dof
    parent = getattr(model, "parent", None)
    parent = np.arange(n, dtype=np.int64) - 1 if parent is None else np.asarray(parent, np.int64)
    if model.has_mimic_joints:
        G, offset = model.mimic_matrix
        src = np.argmax(G != 0.0, axis=1)
        mult = G[np.arange(n), src]
    else:
        src, mult, offset = np.arange(n), np.ones(n), np.zeros(n)
    host = (layout.pack(model), parent, src.astype(np.int64), np.ascontiguousarray(mult, float),
            np.ascontiguousarray(offset, float))
    return DeviceModel(n=n, k=len(model.independent),
                       chain=bool(np.all(parent == np.arange(n) - 1)),
                       mimic=bool(model.has_mimic_joints), host=host)
