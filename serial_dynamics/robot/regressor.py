"""The torque regressor Y(q, qd, qdd): inverse dynamics linear in the inertial parameters.

    tau = inverse_dynamics(q, qd, qdd) == Y @ robot.inertial_parameters()

Columns (``parameter_names``), p in all:

- 10 per moving body, base to tip: [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] -- mass,
  first moment m c and rotational inertia about the body's origin, in the body's URDF link
  frame (the child link of its joint, with the fixed links lumped into it as the loader
  does), which is Pinocchio's joint frame: the order and convention of Pinocchio's
  ``Inertia.toDynamicParameters()``, so ``pinocchio.computeJointTorqueRegressor`` gives the
  same columns;
- with armature columns (``armature=None``: when some joint has armature > 0; True/False
  force them), one per joint, [Ia1 .. Ian], the column qdd_i e_i;
- with ``friction=True``, three blocks of one column per joint, [fv..], [fc..], [fo..]:
  qd_i e_i, sign(qd_i) e_i (sign(0) = 0) and e_i, the torque the actuator supplies against
  viscous, Coulomb and constant (offset) friction. ``inertial_parameters(friction=True)``
  takes fv, fc from ``robot.dissipation`` (viscous, Coulomb) and fo = 0, so
  ``Y @ phi == inverse_dynamics - robot.dissipation_torques(qd)`` for a dissipation model
  without the Stribeck term (its exponential low-speed rise is not linear in a parameter
  and has no column).

Mimic joints (``MimicRobot``): the columns are those of every body of the chain (and the
armature of every joint), the rows the independent joints', Y = G^T Y_all; the friction
columns are the independent joints' (``robot.dissipation``).

The regressor is that of ``inverse_dynamics`` with the base at rest, gravity from the model
and no tip wrench (a wrench does not depend on the parameters: subtract J^T w from the
measured torques).

Paths: a single state of C-contiguous float64 vectors goes to the compiled single-state
entry point (``core/regressor.py``, on a chain or a fixed-base tree), float64 (N, n) arrays straight to the batch kernel
(split over the cores from ``PARALLEL_MIN`` states), anything else is validated as the
reference does (its ValueError names the culprit) and then goes to the batch kernel. The
states are independent of each other: a state gives the same bits alone, in any batch and
from any thread. ``backend="numpy"`` runs ``algorithms/regressor.py``; the tests hold the
two to 1e-12, Y @ phi to inverse dynamics at 1e-12 and the columns to Pinocchio's at 1e-9.
"""
from __future__ import annotations

import weakref

import numpy as np

from ..algorithms import regressor as reference
from ..algorithms._batch import as_batch
from .batches import kernel_rows, run_split
from ..core import K, OK
from ..core.regressor import ARMATURE_COLUMNS, FRICTION_COLUMNS, regressor_layout

PARAMETERS = reference.PARAMETERS
FRICTION = ("fv", "fc", "fo")
PARALLEL_MIN = 512          # states; a batch this large is split over the cores
_INFO = weakref.WeakKeyDictionary()         # Robot -> _info(robot)
_empty = np.empty
_F8 = np.dtype(np.float64)


def _info(robot):
    """(the kernels' layout of robot's model or None, some armature > 0), cached per Robot
    (its model and compiled layout never change)."""
    info = _INFO.get(robot)
    if info is None:
        m = robot.model
        # chains and fixed-base trees (a floating base: robot/floating.py's reference)
        L = (regressor_layout(robot._P, m.A) if robot._k is not None and not robot.is_floating
             else None)
        info = _INFO.setdefault(robot, (L, bool(np.any(m.armature > 0))))
    return info


def armature_on(robot, armature):
    if armature is None:
        return _info(robot)[1]
    if armature is True or armature is False:
        return armature
    if not isinstance(armature, (bool, np.bool_)):
        raise ValueError(f"armature must be None (columns when some joint has armature > 0), "
                         f"True or False; got {armature!r}")
    return bool(armature)


def check_friction(friction):
    if friction is True or friction is False:
        return friction
    if not isinstance(friction, (bool, np.bool_)):
        raise ValueError(f"friction must be True or False; got {friction!r}")
    return bool(friction)


def parameter_names(robot, friction=False, armature=None):
    """The p column names: m1, mx1, .., Izz1, m2, .., then Ia1.., then fv1.., fc1.., fo1..
    (1-based numbers of the chain's joints; friction: of ``robot``'s joints, the independent
    ones where the chain has mimic joints); on a floating base the base's m0, mx0, .., Izz0
    first."""
    friction, arm = check_friction(friction), armature_on(robot, armature)
    n_all = robot.model.dof
    names = [f"{s}0" for s in PARAMETERS] if robot.is_floating else []
    names += [f"{s}{i + 1}" for i in range(n_all) for s in PARAMETERS]
    names += [f"Ia{i + 1}" for i in range(n_all)] if arm else []
    if friction:
        names += [f"{s}{j + 1}" for s in FRICTION for j in robot.model.independent]
    return names


def inertial_parameters(robot, friction=False, armature=None):
    """phi (p,), the parameters ``regressor`` multiplies, in the order of ``parameter_names``:
    each body's [m, m c, I_O] in its link frame (from the model as loaded, payload included),
    the armature, and (``friction=True``) robot.dissipation's viscous and Coulomb
    coefficients and a zero offset."""
    friction, arm = check_friction(friction), armature_on(robot, armature)
    m = robot.model
    phi = [reference.link_frame_parameters(m.mass, m.com, m.inertia).ravel()]
    phi += [np.array(m.armature, dtype=float)] if arm else []
    if friction:
        d = robot.dissipation
        phi += [np.array(d.viscous, dtype=float), np.array(d.coulomb, dtype=float),
                np.zeros(robot.dof)]
    return np.concatenate(phi)


def regressor(robot, q, qd, qdd, friction=False, armature=None):
    """Y (n, p) for one state, (N, n, p) for a batch; see the module docstring."""
    L, arm = _INFO.get(robot) or _info(robot)
    friction, arm = check_friction(friction), arm if armature is None else armature_on(robot, armature)
    if L is not None:
        n = robot._n
        flags, p = kernel_columns(n, arm, friction)
        N = _plain_batch(n, q, qd, qdd)       # float64 (N, n) arrays: the batch kernel, checked there
        if N:
            Y = _empty((N, n, p))
            if _parallel(L, (q, qd, qdd), flags, Y) == OK:
                return Y
        else:
            Y = _empty((n, p))
            if K.regressor(L, q, qd, qdd, flags, Y) == OK:     # the single-state fast path
                return Y
    single, (q, qd, qdd) = as_batch(robot.model, ("q", q), ("qd", qd), ("qdd", qdd))
    if single:
        q, qd, qdd = q[0], qd[0], qdd[0]
    Y = rigid_columns(robot, q, qd, qdd, arm)
    if friction:
        Y = np.concatenate([Y, friction_columns(qd)], axis=-1)
    return Y


def kernel_columns(n, arm, friction):
    """(the regressor kernels' flags, p) of n joints' columns: each body's ten, then the
    armature's n and the friction's 3 n as asked (core/regressor.py)."""
    flags = (ARMATURE_COLUMNS if arm else 0) | (FRICTION_COLUMNS if friction else 0)
    return flags, 10 * n + (n if arm else 0) + (3 * n if friction else 0)


def friction_columns(qd):
    """(.., n, 3 n): [diag(qd), diag(sign qd), 1] -- viscous, Coulomb (sign(0) = 0), offset."""
    qd = np.asarray(qd, dtype=float)
    eye = np.eye(qd.shape[-1])
    return np.concatenate([qd[..., :, None] * eye, np.sign(qd)[..., :, None] * eye,
                           np.broadcast_to(eye, qd.shape[:-1] + eye.shape)], axis=-1)


def rigid_columns(robot, q, qd, qdd, arm):
    """The body (and armature) columns of every body of the chain or tree, for validated states:
    1-D (one state) or (N, n_all)."""
    if _info(robot)[0] is None:
        return reference.regressor(robot.model, q, qd, qdd, armature=arm)
    single = q.ndim == 1
    rows = [np.atleast_2d(x) for x in (q, qd, qdd)]
    N = max(r.shape[0] for r in rows)
    rows = [kernel_rows(r) for r in rows]
    n = robot.model.dof
    Y = np.empty((N, n, 10 * n + (n if arm else 0)))
    _parallel(_info(robot)[0], rows, ARMATURE_COLUMNS if arm else 0, Y)
    return Y[0] if single else Y


def _plain_batch(n, q, qd, qdd):
    """N when q, qd, qdd are float64 (N, n) or (1, n) ndarrays (one at least (N, n)), else 0."""
    if getattr(q, "ndim", 0) != 2:
        return 0
    for x in (q, qd, qdd):
        if type(x) is not np.ndarray or x.dtype is not _F8 or x.ndim != 2 or x.shape[1] != n:
            return 0
    N = max(q.shape[0], qd.shape[0], qdd.shape[0])
    for x in (q, qd, qdd):
        if x.shape[0] != N and x.shape[0] != 1:
            return 0
    return N


def _parallel(L, rows, flags, Y):
    """The batch kernel over the states, split over the cores from PARALLEL_MIN states.
    Returns the kernel's status (0 ok)."""
    return run_split(K.regressor_batch, L, Y.shape[0], rows, (flags,), (Y,), PARALLEL_MIN)
