"""``Planar``: what ``PlanarRobot`` (``facade.py``) overrides: a planar chain on the planar
fast path.

A chain whose revolute axes are all parallel and whose prismatic axes are perpendicular
to them moves in a plane; its joint torques need only planar twists (omega_z; v_x, v_y) and
wrenches (n_z; f_x, f_y) (Angeles, Sec. 7.6.1): ``algorithms/planar.py`` (reference),
``core/planar.py`` (compiled) and ``core/planar_layout.py`` (Q, the detection ``planar_pack``).
``sd.Robot(model)`` returns a
``PlanarRobot`` for such a chain; it answers inverse dynamics, bias and gravity torques and
the mass matrix there (single states and batches, so that a state's result is bitwise the
same alone or in a batch), and everything else -- forward dynamics, a moving base (which
may turn the plane), the NumPy backend -- through ``Robot``. Results equal the general
path to round-off (test/robot/test_planar.py); bench/bench_planar.py measures the gain.
"""
from __future__ import annotations

import numpy as np

from ..core.planar_layout import planar_pack
from ..core import K, OK
from .wrenches import generalized_forces
from .common import QD as _QD
from .common import into as _into
from .common import QD_QDD as _QD_QDD
from .common import QD_QDD_W as _QD_QDD_W
from .common import QD_W as _QD_W

_empty = np.empty


class Planar:
    """What a planar chain overrides (``is_planar``); see the module docstring."""

    is_planar = True

    def __init__(self, model, dissipation=None, backend=None, **kwargs):
        super().__init__(model, dissipation, backend, **kwargs)
        if self._k is not None:          # the batch kernels of Robot's general path, planar
            self._Q = planar_pack(model)
            self._rnea_batch = ("planar_rnea_batch", self._Q)
            self._crba_batch = ("planar_crba_batch", self._Q)

    def inverse_dynamics(self, q, qd, qdd, wrench=None, base_motion=None, out=None,
                         wrenches=None):
        if wrenches is not None:     # wrenches on links: - sum_k J_k^T w_k (robot/wrenches.py)
            return _into(out, self.inverse_dynamics(q, qd, qdd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        if self._k is not None and base_motion is None:
            o = _empty(self._n) if out is None else out
            if (K.planar_rnea(self._Q, q, qd, qdd, _QD_QDD, o) if wrench is None else
                    K.planar_rnea_wrench(self._Q, q, qd, qdd, wrench, _QD_QDD_W, o)) == OK:
                return o
        return super().inverse_dynamics(q, qd, qdd, wrench, base_motion, out)

    def bias_torques(self, q, qd, wrench=None, base_motion=None, out=None, wrenches=None):
        if wrenches is not None:
            return _into(out, self.bias_torques(q, qd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        if self._k is not None and base_motion is None:
            o = _empty(self._n) if out is None else out
            if (K.planar_rnea(self._Q, q, qd, q, _QD, o) if wrench is None else
                    K.planar_rnea_wrench(self._Q, q, qd, q, wrench, _QD_W, o)) == OK:
                return o
        return super().bias_torques(q, qd, wrench, base_motion, out)

    def gravity_torques(self, q, out=None):
        if self._k is not None:
            o = _empty(self._n) if out is None else out
            if K.planar_rnea(self._Q, q, q, q, 0, o) == OK:
                return o
        return super().gravity_torques(q, out)

    def mass_matrix(self, q, out=None):
        if self._k is not None:
            o = _empty(self._nn) if out is None else out
            if K.planar_crba(self._Q, q, o) == OK:
                return o
        return super().mass_matrix(q, out)

