"""Analytical derivatives of inverse and forward dynamics: the ``Robot`` methods'
batching, validation and mimic reduction (docs/derivatives.md).

    inverse_dynamics_derivatives(robot, q, qd, qdd)  -> (d tau/d q, d tau/d qd)
    forward_dynamics_derivatives(robot, q, qd, tau)  -> (d qdd/d q, d qdd/d qd, d qdd/d tau)

with [.., i, j] = d (output)_i / d (input)_j; d tau/d qdd is the mass matrix and
d qdd/d tau = M^-1. Both take the tip wrench and the base motion of ``inverse_dynamics``.
The algorithm is forward-mode differentiation of the Newton-Euler recursion
(``algorithms/derivatives.py``, the reference; ``core/derivatives.py``, compiled).

Paths, as ``Robot.inverse_dynamics``, on the robot's kernel table (``robot._k``: the chain's
kernels, or a fixed-base tree's, ``core/tree_derivatives.py``): one state as C-contiguous
float64 (n,) arrays goes straight to the compiled single-state entry point; anything else
is validated like the reference (same ValueError messages) and runs the batch kernel,
split over the cores for large batches (a state gives the same bits alone or in a batch).
``backend="numpy"`` runs the reference. A chain or tree with mimic joints (``MimicRobot``, q_all = G q + o) has
d tau/d q = G^T (d tau_all/d q_all) G (G constant), the same for qd, and the forward
derivatives solve with its reduced mass matrix G^T M G.
"""
from __future__ import annotations

import numpy as np

from ..algorithms import derivatives as reference
from ..algorithms._batch import as_batch
from .base_motion import check_base_motion
from .batches import kernel_rows, run_split, single_external
from ..core import OK, layout
from ..core import flags as F

_W0 = np.zeros(layout.W_WRENCH)      # w of a single call without wrench or base motion (not read)
_empty = np.empty
_WRENCH = F.WRENCH
# a batch of at least this many states is split over the cores (a derivative costs ~10
# inverse dynamics: splitting pays from far fewer states than Robot.PARALLEL_MIN)
PARALLEL_MIN = 256


def inverse_dynamics_derivatives(robot, q, qd, qdd, wrench=None, base_motion=None):
    """(d tau/d q, d tau/d qd), each (n, n) for one state or (N, n, n) for a batch."""
    if robot._k is not None and base_motion is None:      # fast path
        n = robot._n
        o = _empty((2, n, n))
        if (robot._k.rnea_derivatives(robot._P, q, qd, qdd, _W0, 0, o) if wrench is None else
                robot._k.rnea_derivatives(robot._P, q, qd, qdd, wrench, _WRENCH, o)) == OK:
            return o[0], o[1]
    return chain_derivatives(robot, q, qd, qdd, wrench, base_motion, base_motion is not None)


def forward_dynamics_derivatives(robot, q, qd, tau, wrench=None, base_motion=None):
    """(d qdd/d q, d qdd/d qd, d qdd/d tau), each (n, n) or (N, n, n)."""
    if robot._k is not None and base_motion is None:      # fast path
        n = robot._n
        o = _empty((3, n, n))
        if (robot._k.fd_derivatives(robot._P, q, qd, tau, _W0, 0, o) if wrench is None else
                robot._k.fd_derivatives(robot._P, q, qd, tau, wrench, _WRENCH, o)) == OK:
            return o[0], o[1], o[2]
    if robot._k is not None and base_motion is not None:      # one state with a base motion
        o = _empty((3, robot._n, robot._n))
        w, flags = _single_w(wrench, base_motion)
        if robot._k.fd_derivatives(robot._P, q, qd, tau, w, flags, o) == OK:
            return o[0], o[1], o[2]
    base_motion = check_base_motion(base_motion)
    if robot._k is None:
        return reference.forward_dynamics_derivatives(robot.model, q, qd, tau, wrench,
                                                      base_motion)
    single, (q, qd, tau) = as_batch(robot.model, ("q", q), ("qd", qd), ("tau", tau))
    N, n = q.shape[0], robot._n
    w, flags = robot._external_rows(wrench, base_motion, N, F.QD)
    out = tuple(np.empty((N, n, n)) for _ in range(3))
    if _run(robot, "fd_derivatives_batch", N, (q, qd, tau, w), flags, out) != OK:
        raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
    return tuple(x[0] for x in out) if single else out


def chain_derivatives(robot, q, qd, qdd, wrench, base_motion, single_first):
    """The model's own derivatives (every joint of the chain or tree): compiled, by the
    robot's kernel table (first the single-state entry point, with ``single_first``), or
    the reference."""
    if robot._k is not None and single_first:
        o = _empty((2, robot.model.dof, robot.model.dof))
        w, flags = _single_w(wrench, base_motion)
        if robot._k.rnea_derivatives(robot._P, q, qd, qdd, w, flags, o) == OK:
            return o[0], o[1]
    base_motion = check_base_motion(base_motion)
    if robot._k is None:
        return reference.inverse_dynamics_derivatives(robot.model, q, qd, qdd, wrench,
                                                      base_motion)
    single, (q, qd, qdd) = as_batch(robot.model, ("q", q), ("qd", qd), ("qdd", qdd))
    N, n = q.shape[0], robot.model.dof
    w, flags = robot._external_rows(wrench, base_motion, N, F.QD | F.QDD)
    out = (np.empty((N, n, n)), np.empty((N, n, n)))
    if _run(robot, "rnea_derivatives_batch", N, (q, qd, qdd, w), flags, out) != OK:
        raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
    return (out[0][0], out[1][0]) if single else out


def _single_w(wrench, base_motion):
    """(w, flags) of a single-state entry point: the wrench or an unread stand-in without a
    base motion; else batches.single_external."""
    if base_motion is None:
        return (_W0, 0) if wrench is None else (wrench, F.WRENCH)
    return single_external(base_motion, wrench, 0)


def _run(robot, kernel, N, arrays, flags, out):
    """A batch kernel over the rows ``arrays`` into the (N, n, n) arrays ``out``, split
    over the cores from PARALLEL_MIN states. Returns the kernel's status."""
    arrays = [kernel_rows(a) for a in arrays]
    return run_split(getattr(robot._k, kernel), robot._P, N, arrays, (flags,), out, PARALLEL_MIN)
