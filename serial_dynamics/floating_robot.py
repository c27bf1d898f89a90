"""``FloatingRobot``: the facade of a chain on a free-floating base (a satellite, a drone, a
walking body): ``sd.load_urdf(..., floating_base=True)`` or a URDF whose root joint is
``type="floating"``.

Coordinates (Pinocchio's free-flyer; docs/modelling.md): q = [x, y, z, qx, qy, qz, qw,
joints] (``nq`` = n + 7), v = [base linear velocity, base angular velocity (both in the base
frame), joint rates] (``nv`` = n + 6); ``dof`` = n joints. Generalized forces are [base
force; base moment] (base frame, about the base origin) then joint torques; forward dynamics
takes joint torques (n,) (the base is free) or (n+6,). Poses and Jacobians are in the WORLD
frame, and a tip ``wrench`` is given in world coordinates. Gravity is the world's.

Backends. ``"numpy"`` runs the reference (``algorithms/floating.py``). ``"numba"`` (the
default) runs the fixed-base compiled kernels on the *instantaneous chain*: the base's six
degrees of freedom as three prismatic joints along the base's x, y, z axes and three revolute
joints about them, all at zero, the base's inertia on the last (``virtual_chain``). At that
configuration the virtual joints' rates are v's base part, so the chain's mass matrix is M
and its generalized forces are the base wrench in the base frame; only the accelerations
differ, by the velocity products of the virtual joints (``_to_chain``, ``_from_chain``):
qdd_p = a_lin + omega x v_O, qdd_r = alpha - (wy wz, -wx wz, wx wy). Gravity, R^T g per
state, enters as the base's acceleration (layout.W_ACC), the tip wrench in base coordinates.
The tests hold both backends to Pinocchio's free-flyer.

Not available on a floating base yet: the Coriolis matrix, the regressor, the dynamics
derivatives, a ``base_motion``.
"""
from __future__ import annotations

import numpy as np

from .algorithms import floating as fb
from .algorithms import kinematics
from .algorithms._batch import skew
from .algorithms.aba import CROSSOVER
from .batches import kernel_rows, run_split
from .core import K
from .core import flags as F
from .core.layout import B, W_ACC, W_ALL
from .core.layout import pack as layout_pack
from .model import Model
from .robot import PARALLEL_MIN, Robot, _into

FD_METHODS = ("auto", "aba", "cholesky")
_ZERO6 = np.zeros(6)
_W_BAD = np.zeros(0)         # a w that no entry point accepts (status 2): the general path


class FloatingRobot(Robot):
    """A ``Robot`` whose base floats (``is_floating``); see the module docstring."""

    is_floating = True

    def __init__(self, model, dissipation=None, backend=None, **kwargs):
        if np.any(model.mimic_leader >= 0):
            raise ValueError(f"chain {model.base_link!r} -> {model.tip_link!r} has mimic joints; "
                             "a floating base with mimic joints is not supported: load it with "
                             "floating_base=False, or make the mimic joints independent")
        super().__init__(model, dissipation, backend, **kwargs)
        self._nq, self._nv = model.dof + 7, model.dof + 6
        self._chain = layout_pack(virtual_chain(model)) if self._compiled else None

    nq = property(lambda self: self._nq, doc="n + 7: [x, y, z, qx, qy, qz, qw, joints]")
    nv = property(lambda self: self._nv, doc="n + 6: [v_O, omega (base frame), joints]")

    def __repr__(self):
        return (f"FloatingRobot({self.model.name!r}, dof={self.dof}, floating base "
                f"{self.base_link!r} -> {self.tip_link!r}, joints={self.joint_names})")

    # ------------------------------------------------------------- dynamics
    def inverse_dynamics(self, q, qd, qdd, wrench=None, base_motion=None, out=None):
        """tau (n+6,): [base force; base moment] (base frame) and joint torques for the
        accelerations qdd = dv/dt (n+6); ``wrench`` on the tip, world coordinates."""
        _no_base_motion(base_motion)
        if not self._compiled:
            return _into(out, fb.inverse_dynamics(self.model, q, qd, qdd, wrench))
        if self._single(q, qd) and type(qdd) is np.ndarray and qdd.shape == (self.nv,):
            qv, w, flags = self._single_inputs(q, wrench, F.QD | F.QDD)
            o = np.empty(self._nv) if out is None else out
            if K.rnea_wrench(self._chain, qv, qd, _to_chain(qd, qdd), w, flags,
                             o) == 0:
                return o
        single, q, R, s = fb.as_batch(self.model, q, v=qd, a=qdd)
        v, a = (np.zeros((q.shape[0], self.nv)) if s[k] is None else s[k] for k in ("v", "a"))
        return _into(out, self._rnea(single, q, R, v, _to_chain(v, a), wrench, F.QD | F.QDD))

    def _rnea(self, single, q, R, v, qdd_chain, wrench, flags):
        qv, w, flags = self._chain_inputs(q, R, wrench, flags)
        N = qv.shape[0]
        tau = np.empty((N, self.nv))
        run_split(K.rnea_batch, self._chain, N, (qv, kernel_rows(v), kernel_rows(qdd_chain), w),
                  (flags,), (tau,), PARALLEL_MIN, B)
        return tau[0] if single else tau

    def _single(self, q, v):
        """q and v are one state of float64 vectors of the right lengths (the fast path)."""
        return (type(q) is np.ndarray and type(v) is np.ndarray and q.shape == (self._nq,)
                and v.shape == (self._nv,) and q.dtype == v.dtype == np.float64)

    def _single_inputs(self, q, wrench, flags):
        """``_chain_inputs`` of one state, in scalars (a zero quaternion or a bad wrench:
        flags that no kernel accepts, so that the general path names the culprit)."""
        x, y, z, s = q[3:7].tolist()
        nrm = (x * x + y * y + z * z + s * s) ** 0.5
        if not nrm > 1e-12 or (wrench is not None and np.shape(wrench) != (6,)):
            return q, _W_BAD, flags
        x, y, z, s = x / nrm, y / nrm, z / nrm, s / nrm
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * s), 2 * (x * z + y * s)],
                      [2 * (x * y + z * s), 1 - 2 * (x * x + z * z), 2 * (y * z - x * s)],
                      [2 * (x * z - y * s), 2 * (y * z + x * s), 1 - 2 * (x * x + y * y)]])
        qv = np.concatenate((_ZERO6, q[7:]))
        w = np.zeros(W_ALL)
        w[W_ACC:W_ACC + 3] = -(self.model.gravity @ R)         # -R^T g
        if wrench is not None:
            wr = np.asarray(wrench, dtype=float)
            w[:3], w[3:6] = wr[:3] @ R, wr[3:] @ R
            flags |= F.WRENCH
        return qv, w, flags | F.BASE

    def _chain_inputs(self, q, R, wrench, flags):
        """The instantaneous chain's q (zeros for the base), and its external vector w:
        the tip wrench and gravity as the base's acceleration -R^T g, base coordinates."""
        N = q.shape[0]
        qv = np.zeros((N, self.nv))
        qv[:, 6:] = q[:, 7:]
        w = np.zeros((N, W_ALL))
        w[:, W_ACC:W_ACC + 3] = -np.einsum("nji,j->ni", R, self.model.gravity)
        if wrench is not None:
            wr = np.broadcast_to(np.asarray(wrench, dtype=float), (N, 6))
            if not np.all(np.isfinite(wr)):
                raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
            w[:, :3] = np.einsum("nji,nj->ni", R, wr[:, :3])
            w[:, 3:6] = np.einsum("nji,nj->ni", R, wr[:, 3:])
            flags |= F.WRENCH
        return qv, w, flags | F.BASE

    def mass_matrix(self, q, out=None):
        """M (n+6, n+6), in the order of v."""
        if not self._compiled:
            return _into(out, fb.mass_matrix(self.model, q))
        single, q, _, _ = fb.as_batch(self.model, q)
        qv = np.zeros((q.shape[0], self.nv))
        qv[:, 6:] = q[:, 7:]
        M = np.empty((q.shape[0], self.nv, self.nv))
        run_split(K.crba_batch, self._chain, q.shape[0], (qv,), (), (M,), PARALLEL_MIN, B)
        return _into(out, M[0] if single else M)

    def bias_torques(self, q, qd, wrench=None, base_motion=None, out=None):
        """b (n+6,) = inverse_dynamics(q, v, 0, wrench)."""
        _no_base_motion(base_motion)
        return self.inverse_dynamics(q, qd, None, wrench, out=out)

    def gravity_torques(self, q, out=None):
        """g (n+6,): what holds the whole robot still against gravity (the base's part is
        the weight, carried by whatever holds the base)."""
        return self.inverse_dynamics(q, None, None, out=out)

    def forward_dynamics(self, q, qd, tau, wrench=None, method="auto", base_motion=None,
                         out=None):
        """a = dv/dt (n+6,) for joint torques ``tau`` (n,) (the base free) or generalized
        forces (n+6,). ``method``: "auto", "aba" (articulated bodies through the floating
        root, FDfb) or "cholesky" (M a = tau - b)."""
        _no_base_motion(base_motion)
        if method not in FD_METHODS:
            raise ValueError(f"forward-dynamics method {method!r} unknown for a floating base; "
                             f"use one of {FD_METHODS}")
        if method == "auto":
            method = "aba" if self.dof + 6 >= CROSSOVER else "cholesky"
        if not self._compiled:
            return _into(out, fb.forward_dynamics(self.model, q, qd, tau, wrench, method))
        flags = F.QD | (F.ABA if method == "aba" else 0)
        if self._single(q, qd) and type(tau) is np.ndarray and tau.shape in ((self._n,), (self._nv,)):
            qv, w, flags = self._single_inputs(q, wrench, flags)
            o = np.empty(self._nv) if out is None else out
            if tau.shape[0] == self._n:
                tau = np.concatenate((_ZERO6, tau))
            if K.fd(self._chain, qv, qd, tau, w, flags, o) == 0:
                return _from_chain(qd, o)
        single, q, R, s = fb.as_batch(self.model, q, v=qd, tau=tau)
        qv, w, flags = self._chain_inputs(q, R, wrench, F.QD | (F.ABA if method == "aba" else 0))
        N = qv.shape[0]
        qdd = np.empty((N, self.nv))
        run_split(K.fd_batch, self._chain, N, (qv, kernel_rows(s["v"]), kernel_rows(s["tau"]), w),
                  (flags,), (qdd,), PARALLEL_MIN, B)
        a = _from_chain(np.broadcast_to(s["v"], (N, self.nv)), qdd)
        return _into(out, a[0] if single else a)

    def coriolis_matrix(self, q, qd):
        raise NotImplementedError("the Coriolis matrix of a floating base is not available; "
                                  "use bias_torques(q, v) for C v + g")

    def regressor(self, *args, **kwargs):
        raise NotImplementedError("the regressor of a floating base is not available")

    def inertial_parameters(self, *args, **kwargs):
        raise NotImplementedError("the regressor of a floating base is not available")

    def inverse_dynamics_derivatives(self, *args, **kwargs):
        raise NotImplementedError("dynamics derivatives of a floating base are not available")

    def forward_dynamics_derivatives(self, *args, **kwargs):
        raise NotImplementedError("dynamics derivatives of a floating base are not available")

    # ------------------------------------------------------------- kinematics, energy, momentum
    def forward_kinematics(self, q, link=None):
        """4x4 pose of ``link`` (default: the tip) in the world."""
        single, q, R, _ = fb.as_batch(self.model, q)
        X = kinematics.forward_kinematics(self.model, q[:, 7:], link)
        B = np.zeros_like(X)
        B[:, :3, :3], B[:, :3, 3], B[:, 3, 3] = R, q[:, :3], 1.0
        return (B @ X)[0] if single else B @ X

    def jacobian(self, q, link=None):
        """6 x (n+6) Jacobian of ``link``'s origin, [linear; angular] velocity in world axes,
        times v: the base's columns [R, -R [r]x; 0, R] (r: the link origin in the base
        frame), the joints' columns R J_fixed."""
        single, q, R, _ = fb.as_batch(self.model, q)
        N = q.shape[0]
        r = kinematics.forward_kinematics(self.model, q[:, 7:], link)[:, :3, 3]
        J = np.zeros((N, 6, self.nv))
        J[:, :3, :3] = R
        J[:, :3, 3:6] = -R @ skew(r)
        J[:, 3:, 3:6] = R
        Jj = kinematics.jacobian(self.model, q[:, 7:], link)
        J[:, :3, 6:], J[:, 3:, 6:] = R @ Jj[:, :3], R @ Jj[:, 3:]
        return J[0] if single else J

    def kinetic_energy(self, q, qd):
        """T = 1/2 v^T M v (J)."""
        if not self._compiled:
            return fb.kinetic_energy(self.model, q, qd)
        M = self.mass_matrix(q)
        v = np.broadcast_to(np.asarray(qd, dtype=float), M.shape[:-1])
        return 0.5 * np.einsum("...i,...ij,...j->...", v, M, v)

    def potential_energy(self, q):
        return fb.potential_energy(self.model, q)

    def center_of_mass(self, q):
        """(3,): the center of mass of the base and the chain, world frame."""
        return fb.center_of_mass(self.model, q)

    def centroidal_momentum(self, q, qd):
        """(6,): [linear momentum; angular momentum about the center of mass], world axes."""
        return fb.centroidal_momentum(self.model, q, qd)

    def integrate(self, q, qd, dt):
        """q moved by v dt: the base pose on SE(3) (exponential map), the joints by qd dt."""
        return fb.integrate(self.model, q, qd, dt)

    def random_state(self, rng=None, batch=None, speed=1.0):
        """(q, v): the base within 1 m of the origin with a uniformly random unit quaternion,
        joints within their limits (+-pi where unlimited), velocities in +-speed."""
        return fb.random_state(self.model, rng, batch, speed)

    def neutral(self):
        """q (n+7,) with the base at the origin, unrotated, and every joint at zero."""
        return np.concatenate([np.zeros(6), [1.0], np.zeros(self.dof)])

    # ------------------------------------------------------------- space robotics
    def base_reaction(self, q, qd_joints):
        """v_base (6,) or (N, 6) = -M_bb^-1 M_bj qd: the base's motion [v_O; omega] (base
        frame) that a joint motion causes when the total momentum is zero (no external
        force; Umetani & Yoshida 1989)."""
        single, q, _, _ = fb.as_batch(self.model, q)
        M = fb.mass_matrix_joints(self.model, q[:, 7:])
        qdj = np.broadcast_to(np.asarray(qd_joints, dtype=float), (q.shape[0], self.dof))
        vb = -np.linalg.solve(M[:, :6, :6], np.einsum("nij,nj->ni", M[:, :6, 6:], qdj)[..., None])
        return vb[:, :, 0][0] if single else vb[:, :, 0]

    def generalized_jacobian(self, q, link=None):
        """J* (6, n): ``link``'s twist [linear; angular] (world axes) from the joint rates
        alone at zero total momentum, J* = J_j - J_b M_bb^-1 M_bj (Umetani & Yoshida 1989)."""
        single, q, _, _ = fb.as_batch(self.model, q)
        M = fb.mass_matrix_joints(self.model, q[:, 7:])
        J = self.jacobian(q, link)
        Js = J[:, :, 6:] - J[:, :, :6] @ np.linalg.solve(M[:, :6, :6], M[:, :6, 6:])
        return Js[0] if single else Js

    def warmup(self):
        """Nothing to compile (the NumPy reference runs a floating base); returns self."""
        return self


def virtual_chain(model) -> Model:
    """The instantaneous chain of a floating ``model`` (module docstring): prismatic joints
    along the base's x, y, z, revolute joints about them (massless, the last carrying the
    base's inertia), then the chain; no gravity (it comes with each call)."""
    n = model.dof
    eye, zero = np.eye(3), np.zeros(3)
    names = [f"_base_{k}" for k in ("x", "y", "z", "rx", "ry", "rz")]
    frames = {link: (b + 6 if b >= 0 else 5, R, p) for link, (b, R, p) in model.frames.items()}
    return Model.build(
        name=model.name, joint_names=names + list(model.joint_names),
        joint_types=["prismatic"] * 3 + ["revolute"] * 3 + list(model.joint_types),
        link_names=names[:5] + [model.base_link] + list(model.link_names),
        base_link="_world", tip_link=model.tip_link,
        R_parent=np.concatenate([np.broadcast_to(eye, (6, 3, 3)), model.R_parent]),
        p_parent=np.concatenate([np.zeros((6, 3)), model.p_parent]),
        axis=np.concatenate([eye, eye, model.axis]),
        mass=np.r_[np.zeros(5), model.base_mass, model.mass],
        com=np.concatenate([np.zeros((5, 3)), [model.base_com], model.com]),
        inertia=np.concatenate([np.zeros((5, 3, 3)), [model.base_inertia], model.inertia]),
        gravity=zero, tip_R=model.tip_R, tip_p=model.tip_p, frames=frames,
        armature=np.r_[np.zeros(6), model.armature], check_mass_matrix=False)


def _velocity_products(v):
    """The instantaneous chain's velocity-product accelerations (module docstring), v (N, nv)
    or (nv,): of the base origin, omega x v_O; of the base's rotation, (wy wz, -wx wz, wx wy)."""
    if v.ndim == 1:                          # one state: in Python floats (the fast path)
        vx, vy, vz, wx, wy, wz = v[:6].tolist()
        return np.array([wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx,
                         -wy * wz, wx * wz, -wx * wy])
    vx, vy, vz, wx, wy, wz = (v[..., k] for k in range(6))
    return np.stack([wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx,
                     -wy * wz, wx * wz, -wx * wy], axis=-1)


def _to_chain(v, a):
    """The instantaneous chain's qdd for the accelerations a = dv/dt."""
    out = np.array(a, dtype=float)
    out[..., :6] += _velocity_products(v)
    return out


def _from_chain(v, qdd):
    """a = dv/dt from the instantaneous chain's qdd (``_to_chain`` inverted), in place."""
    qdd[..., :6] -= _velocity_products(v)
    return qdd


def _no_base_motion(base_motion):
    if base_motion is not None:
        raise ValueError("base_motion prescribes a fixed base's motion; a floating base moves "
                         "by its own dynamics (give its velocity in v)")


Robot._kinds["floating"] = FloatingRobot
