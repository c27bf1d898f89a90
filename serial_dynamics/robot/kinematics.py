"""The glue behind ``Robot``'s kinematics methods on the compiled core
(``core/kinematics.py``: one kernel per quantity for every kind of robot, a batch a call):
frame poses, Jacobians and accelerations, the first moment of mass, the centroidal
momentum and the Coriolis matrix. ``Robot`` calls these on the numba backend; the numpy
backend runs ``algorithms/``.

Paths, as the dynamics': one state of float64 vectors goes straight to its kernel (a pose
or a Jacobian to a single-state entry point, the others as a one-row batch, ``x[None]``);
anything else, or a state the kernel refuses (a length, a
NaN, batch sizes to broadcast), takes ``general``: the robot's ``_states`` (which names the
culprit and broadcasts) and a second run. The kernels read the robot's packed model ``P``,
its ``_base`` (a floating base's inertia; zeros on a fixed base) and each link's placement
in its body (``frame``, kept per robot). A mimic robot calls these with every joint's
state (``robot/mimic.py``).
"""
from __future__ import annotations

import numpy as np

from ..algorithms.kinematics import frame_of
from ..core import K, OK

KINEMATICS_KERNELS = ("frame_pose", "frame_jacobian", "frame_acceleration",   # warmup(kinematics=True)
                      "frame_pose_one", "frame_jacobian_one")
_empty = np.empty
_F8 = np.dtype(float)


def one(x):
    """x is one state as the kernels take it: a float64 vector."""
    return x.__class__ is np.ndarray and x.ndim == 1 and x.dtype is _F8


def frame(robot, link):
    """(body, F): ``link``'s joint frame and its placement there as one vector [R, p]."""
    f = robot._frames.get(link)
    if f is None:
        body, R, p = frame_of(robot.model, link)
        f = robot._frames[link] = (body, np.concatenate((R.ravel(), p)))
    return f


def general(robot, kernel, extra, shape, *named):
    """``kernel(P, rows..., *extra, out)`` on the states as given, each one state or a batch
    of them; out (*shape) or (N, *shape); where the kernel refuses them, ``robot._states``
    and again."""
    rows = [np.asarray(x, dtype=float) for _, x in named]
    single = all(a.ndim == 1 for a in rows)
    rows = [a.reshape(1, -1) if a.ndim == 1 else a for a in rows]
    out = _empty((rows[0].shape[0],) + shape) if rows[0].ndim == 2 else None
    if any(a.ndim != 2 for a in rows) or kernel(robot._P, *rows, *extra, out) != OK:
        single, rows = robot._states(*named)
        out = _empty((rows[0].shape[0],) + shape)
        if kernel(robot._P, *rows, *extra, out) != OK:
            raise RuntimeError("a kinematics kernel refused validated states")
    return out[0] if single else out


def frame_pose(robot, q, link):
    body, F = frame(robot, link)
    if one(q):
        X = _empty((4, 4))
        if K.frame_pose_one(robot._P, q, body, F, X) == OK:
            return X
    return general(robot, K.frame_pose, (body, F), (4, 4), ("q", q))


def frame_jacobian(robot, q, link):
    body, F = frame(robot, link)
    if one(q):
        J = _empty((6, robot._nv))
        if K.frame_jacobian_one(robot._P, q, body, F, J) == OK:
            return J
    return general(robot, K.frame_jacobian, (body, F), (6, robot._nv), ("q", q))


def frame_acceleration(robot, q, qd, qdd, link):
    if qdd is None:
        qdd = np.zeros(np.shape(qd))
    body, F = frame(robot, link)
    if one(q) and one(qd) and one(qdd):
        A = _empty(6)
        if K.frame_acceleration(robot._P, q[None], qd[None], qdd[None], body, F, A[None]) == OK:
            return A
    return general(robot, K.frame_acceleration, (body, F), (6,), ("q", q), ("qd", qd),
                   ("qdd", qdd))


def mass_moment(robot, q):
    """[sum m c; sum m] (4,) or (N, 4): first moment (kg m) and mass (kg)."""
    if one(q):
        mc = _empty(4)
        if K.mass_moment(robot._P, q[None], robot._base, mc[None]) == OK:
            return mc
    return general(robot, K.mass_moment, (robot._base,), (4,), ("q", q))


def centroidal_momentum(robot, q, qd):
    if one(q) and one(qd):
        h = _empty(6)
        if K.centroidal(robot._P, q[None], qd[None], robot._base, h[None]) == OK:
            return h
    return general(robot, K.centroidal, (robot._base,), (6,), ("q", q), ("qd", qd))


def coriolis_matrix(robot, q, qd):
    nv = robot._nv
    if one(q) and one(qd):
        C = _empty((nv, nv))
        if K.coriolis(robot._P, q[None], qd[None], robot._base, C[None]) == OK:
            return C
    return general(robot, K.coriolis, (robot._base,), (nv, nv), ("q", q), ("qd", qd))
