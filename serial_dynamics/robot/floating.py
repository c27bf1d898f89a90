"""``Floating``: what ``FloatingRobot`` (``facade.py``) overrides: a chain on a free-floating base (a satellite, a drone, a
walking body): ``sd.load_urdf(..., floating_base=True)`` or a URDF whose root joint is
``type="floating"``.

Coordinates (Pinocchio's free-flyer; docs/modelling.md): q = [x, y, z, qx, qy, qz, qw,
joints] (``nq`` = n + 7), v = [base linear velocity, base angular velocity (both in the base
frame), joint rates] (``nv`` = n + 6); ``dof`` = n joints. Generalized forces are [base
force; base moment] (base frame, about the base origin) then joint torques; forward dynamics
takes joint torques (n,) (the base is free) or (n+6,). Poses and Jacobians are in the WORLD
frame, and a tip ``wrench`` is given in world coordinates. Gravity is the world's.

Backends. ``"numpy"`` runs the reference (``algorithms/floating.py``). ``"numba"`` (the
default) runs ``core/floating.py``: the compiled kernels on the *instantaneous chain*
(``virtual_chain``): the base's six degrees of freedom as three prismatic joints along the
base's x, y, z axes and three revolute joints about them, all at zero, the base's inertia
on the last, which Newton-Euler, the CRBA, the Cholesky route and articulated bodies (FDfb)
take as one free-flyer root joint (``P[n, ROOT]`` = 6). There the virtual joints' rates
are v's base part, so the chain's mass matrix is M and its generalized forces are the base
wrench in the base frame; only the accelerations differ, by the velocity products of the
virtual joints. The tests hold both backends to Pinocchio's free-flyer.

Beyond the dynamics: the Coriolis matrix (NOC in a frame turning with the base), the
regressor (the base's ten parameters first), both derivatives, dT/dq (the joints'; zeros on
the base); compiled, the regressor and the derivatives are the fixed-base kernels on the
instantaneous chain or tree with the base's columns added (``core/regressor.floating_regressor``,
one call a state; ``core/floating_derivatives.py``, a batch's states in SIMD lanes). Not available
on a floating base: a ``base_motion`` (the base moves by its own dynamics).
"""
from __future__ import annotations

import numpy as np

from ..algorithms import floating as fb
from ..algorithms import derivatives as derivatives_reference
from ..algorithms import kinematics
from ..algorithms import regressor as ref_regressor
from ..algorithms._batch import skew
from .charts import FREE_FLYER
from ..algorithms.energy import kinetic_energy_gradient as ke_gradient_reference
from ..algorithms.rnea import _wrench_batch as rnea_wrench_rows
from ..core import ENTRY_POINTS, OK
from ..core import K as CHAIN
from ..core.dispatch import TREE
from ..core.layout import TREE as TREE_FLAG
from ..core import flags as F
from ..core.layout import B, W_ALL
from ..core.layout import pack as layout_pack
from ..core.regressor import regressor_layout
from ..model import Model
from .batches import kernel_rows, run_split
from . import regressor
from .wrenches import generalized_forces
from .common import PARALLEL_MIN
from .derivatives import PARALLEL_MIN as DERIVATIVES_PARALLEL_MIN
from .common import aba_by_default
from .common import into as _into
from .kinematics import KINEMATICS_KERNELS

FD_METHODS = ("auto", "aba", "cholesky")
_FD_FLAGS = {"aba": F.ABA, "cholesky": 0}
_QD_QDD = F.QD | F.QDD
_empty = np.empty
FLOATING_KERNELS = tuple(k for k in ENTRY_POINTS if k.startswith("floating")   # warmup(): the
                         and "derivatives" not in k and "regressor" not in k)  # dynamics
_ZERO_ROW = np.zeros((1, 1))  # an input floating_rows does not read
CHUNK = 1024                  # states per chunk of a batch (a whole number of SIMD blocks)
_GW_BAD = np.zeros(0)        # a gw that no entry point accepts (status 2): the general path
_V_NAMES = {"qd": "v", "qdd": "a"}    # a floating base's names of the rates


class Floating:
    """What a free-floating base overrides (``is_floating``); see the module docstring."""

    is_floating = True
    chart = FREE_FLYER       # q on SE(3) x R^n: sim/ steps in this chart (charts.py)
    _fd_flags = _FD_FLAGS

    def __init__(self, model, dissipation=None, backend=None, **kwargs):
        super().__init__(model, dissipation, backend, **kwargs)
        self._nq, self._nv = model.dof + 7, model.dof + 6
        self._nvnv = (self._nv, self._nv)
        # the floating kernels of the table self._k (K, or the tree table), on the
        # instantaneous chain or tree; self._k None: the NumPy reference (fb)
        self._fd_auto = _FD_FLAGS["aba" if aba_by_default(model, True) else "cholesky"]
        self._chain = self._regressor_layout = None
        if self._k is not None:
            chain = virtual_chain(model)
            self._chain = layout_pack(chain, root=6, gravity=model.gravity)
            # regressor(): the instantaneous tree's layout with its link frames
            self._regressor_layout = regressor_layout(self._chain, chain.A)
        self._gw = np.concatenate((np.zeros(6), model.gravity))   # core/floating.py's gw
        I = model.base_I_O       # the base body in core/kinematics.py's layout
        self._base = np.r_[model.base_mass, model.base_h,
                           I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]

    nq = property(lambda self: self._nq, doc="n + 7: [x, y, z, qx, qy, qz, qw, joints]")
    nv = property(lambda self: self._nv, doc="n + 6: [v_O, omega (base frame), joints]")

    def __repr__(self):
        return (f"FloatingRobot({self.model.name!r}, dof={self.dof}, floating base "
                f"{self.base_link!r} -> {self.tip_link!r}, joints={self.joint_names})")

    # ------------------------------------------------------------- dynamics
    # Compiled (core/floating.py): a single state of C-contiguous float64 vectors goes
    # straight to the single-state entry point, which answers 3 for other argument types
    # and 1 or 2 for a bad value or length; those calls, and batches, take the general
    # path: validation with the reference's messages, then one batch kernel call.
    def inverse_dynamics(self, q, qd, qdd, wrench=None, base_motion=None, out=None,
                         wrenches=None):
        """tau (n+6,): [base force; base moment] (base frame) and joint torques for the
        accelerations qdd = dv/dt (n+6); ``wrench`` on the tip, world coordinates."""
        if wrenches is not None:     # wrenches on links: - sum_k J_k^T w_k (robot/wrenches.py)
            return _into(out, self.inverse_dynamics(q, qd, qdd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        if self._k is not None and base_motion is None:        # the single-state fast path
            o = _empty(self._nv) if out is None else out
            if wrench is None:       # gravity from self._chain: one argument fewer
                if self._k.floating_rnea(self._chain, q, qd, qdd, _QD_QDD, o) == OK:
                    return o
            elif self._k.floating_rnea_wrench(self._chain, q, qd, qdd,
                                              *self._gw_single(wrench, _QD_QDD), o) == OK:
                return o
        _no_base_motion(base_motion)
        if self._k is None:
            return _into(out, fb.inverse_dynamics(self.model, q, qd, qdd, wrench))
        return _into(out, self._rnea_rows(q, qd, qdd, wrench))

    def _rnea_rows(self, q, qd, qdd, wrench):
        """inverse_dynamics's general path: validated like the reference, then one batch
        kernel call (as Robot's ``_rnea_general``)."""
        single, q, _, s = fb.as_batch(self.model, q, False, v=qd, a=qdd)
        N = q.shape[0]
        v, a = (np.zeros((1, self._nv)) if s[k] is None else kernel_rows(s[k]) for k in ("v", "a"))
        gw, flags = self._gw_rows(wrench, N, F.QD | F.QDD)
        tau = np.empty((N, self._nv))
        run_split(_on_chain, self._chain, N, (kernel_rows(q), v, a, _ZERO_ROW, gw),
                  (flags, "rnea"), (tau,), PARALLEL_MIN, B)
        return tau[0] if single else tau

    def _gw_single(self, wrench, flags):
        """gw (core/floating.py) of a single call: [wrench (world); gravity (world)]."""
        if wrench is None:
            return self._gw, flags
        if type(wrench) is not np.ndarray or wrench.shape != (6,):
            return _GW_BAD, flags                    # the general path names it
        return np.concatenate((wrench, self.model.gravity)), flags | F.WRENCH

    def _gw_rows(self, wrench, N, flags):
        if wrench is None:
            return self._gw[None], flags
        w = rnea_wrench_rows(wrench, N)              # raises naming a bad wrench
        return np.concatenate([w, np.broadcast_to(self.model.gravity, (w.shape[0], 3))], axis=1), \
            flags | F.WRENCH

    _v_parent = property(lambda self: velocity_parents(self.model.parent))

    def mass_matrix(self, q, out=None):
        """M (n+6, n+6), in the order of v."""
        if self._k is not None:
            o = _empty(self._nvnv) if out is None else out
            if self._k.floating_crba(self._chain, q, o) == OK:
                return o
        else:
            return _into(out, fb.mass_matrix(self.model, q))
        single, q, _, _ = fb.as_batch(self.model, q, False)
        N = q.shape[0]
        M = np.empty((N, self._nv, self._nv))
        run_split(_on_chain, self._chain, N, (kernel_rows(q), _ZERO_ROW, _ZERO_ROW, _ZERO_ROW,
                                              self._gw[None]), (0, "crba"), (M,), PARALLEL_MIN, B)
        return _into(out, M[0] if single else M)

    def bias_torques(self, q, qd, wrench=None, base_motion=None, out=None, wrenches=None):
        """b (n+6,) = inverse_dynamics(q, v, 0, wrench)."""
        if wrenches is not None:
            return _into(out, self.bias_torques(q, qd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        _no_base_motion(base_motion)
        if self._k is None:
            return _into(out, fb.bias(self.model, q, qd, wrench))
        # Floating's own (a kind deriving from this one, mimic.py, calls it with whole states)
        return Floating.inverse_dynamics(self, q, qd, np.zeros(self._nv), wrench, out=out)

    def gravity_torques(self, q, out=None):
        """g (n+6,): what holds the whole robot still against gravity (the base's part is
        the weight, carried by whatever holds the base)."""
        if self._k is None:
            return _into(out, fb.gravity_forces(self.model, q))
        zero = np.zeros(self._nv)
        return Floating.inverse_dynamics(self, q, zero, zero, out=out)

    def forward_dynamics(self, q, qd, tau, wrench=None, method="auto", base_motion=None,
                         out=None, wrenches=None):
        """a = dv/dt (n+6,) for joint torques ``tau`` (n,) (the base free) or generalized
        forces (n+6,). ``method``: "auto", "aba" (articulated bodies through the floating
        root, FDfb) or "cholesky" (M a = tau - b)."""
        if wrenches is not None:     # wrenches on links: tau + sum_k J_k^T w_k
            return _into(out, self.forward_dynamics(
                q, qd, np.asarray(tau, dtype=float) + generalized_forces(self, q, wrenches),
                wrench, method, base_motion))
        flags = self._fd_auto if method == "auto" else self._fd_flags.get(method)
        if self._k is not None and base_motion is None and flags is not None:   # the fast path
            o = _empty(self._nv) if out is None else out
            if wrench is None:
                if self._k.floating_fd(self._chain, q, qd, tau, self._gw, flags, o) == OK:
                    return o
            elif self._k.floating_fd(self._chain, q, qd, tau, *self._gw_single(wrench, flags), o) == OK:
                return o
        _no_base_motion(base_motion)
        if flags is None:
            raise ValueError(f"forward-dynamics method {method!r} unknown for a floating base; "
                             f"use one of {FD_METHODS}")
        if self._k is None:
            method = "aba" if flags & F.ABA else "cholesky"
            return _into(out, fb.forward_dynamics(self.model, q, qd, tau, wrench, method))
        single, q, _, s = fb.as_batch(self.model, q, False, v=qd, tau=tau)
        N = q.shape[0]
        gw, flags = self._gw_rows(wrench, N, flags)
        a = np.empty((N, self._nv))
        run_split(_on_chain, self._chain, N, (kernel_rows(q), kernel_rows(s["v"]), _ZERO_ROW,
                                              kernel_rows(s["tau"]), gw), (flags, "fd"), (a,),
                  PARALLEL_MIN, B)
        return _into(out, a[0] if single else a)

    def coriolis_matrix(self, q, qd):
        """C (n+6, n+6) with C v = b - g and dM/dt - 2 C skew-symmetric (the NOC,
        ``algorithms/floating.coriolis_matrix``; compiled: core/kinematics.coriolis)."""
        if self._P is None:
            return fb.coriolis_matrix(self.model, q, qd)
        return super().coriolis_matrix(q, qd)

    def regressor(self, q, qd, qdd, friction=False, armature=None):
        """Y (n+6, p) or (N, n+6, p) with inverse_dynamics(q, v, a) == Y @
        inertial_parameters() (less the friction torques with ``friction=True``): the base's
        ten columns [m0, mx0, .., Izz0] (base link frame), each body's ten, then the joints'
        armature and friction columns (zero in the base's rows); ``robot/regressor.py`` for
        the columns. Compiled: the fixed-base regressor kernel (``core/regressor.py``) on the
        instantaneous chain or tree, as ``inverse_dynamics_derivatives`` uses it (its five
        massless virtual bodies' columns and the virtual joints' armature dropped); the NumPy
        reference: the same algorithm, ``algorithms/regressor.regressor`` on the
        instantaneous tree."""
        friction, arm = regressor.check_friction(friction), regressor.armature_on(self, armature)
        if self._k is not None:
            flags, p = regressor.kernel_columns(self.model.dof, arm, friction)
            p += 10                                       # the base's ten columns first
            o = _empty((self._nv, p))                     # the single-state fast path
            if CHAIN.floating_regressor(self._regressor_layout, q, qd, qdd, self._gw, flags,
                                        o) == OK:
                return o
            single, q, _, s = fb.as_batch(self.model, q, False, v=qd, a=qdd)
            Y = np.empty((q.shape[0], self._nv, p))
            run_split(CHAIN.floating_regressor_batch, self._regressor_layout, q.shape[0],
                      [kernel_rows(x) for x in (q, s["v"], s["a"], self._gw[None])], (flags,),
                      (Y,), regressor.PARALLEL_MIN)
            return Y[0] if single else Y
        single, q, R, s = fb.as_batch(self.model, q, v=qd, a=qdd)
        nv = self._nv
        v = np.zeros((q.shape[0], nv)) if s["v"] is None else s["v"]
        a = np.zeros((q.shape[0], nv)) if s["a"] is None else s["a"]
        qv, v, rates, _ = _instantaneous(self.model, q, R, v, a)
        # the fixed-base regressor of the instantaneous tree, its five massless virtual
        # bodies' columns dropped: the base's ten (its sixth body) first, as the core's
        Y = ref_regressor.regressor(virtual_chain(self.model), qv, v, rates)[..., 50:]
        extra = []
        if arm:
            extra.append(s["a"][:, 6:, None] * np.eye(self.model.dof))   # every joint's
        if friction:
            extra.append(regressor.friction_columns(s["v"][:, 6:]))
        if extra:                                          # joint columns: zero base rows
            J = np.concatenate(extra, axis=2)
            Y = np.concatenate([Y, np.concatenate([np.zeros((J.shape[0], 6, J.shape[2])), J],
                                                  axis=1)], axis=2)
        return Y[0] if single else Y

    def inertial_parameters(self, friction=False, armature=None):
        """phi (p,) that ``regressor`` multiplies: the base's ten parameters (base link frame,
        inertia about its origin), then ``Robot.inertial_parameters``'s."""
        m = self.model
        base = ref_regressor.link_frame_parameters([m.base_mass], [m.base_com], [m.base_inertia])
        return np.concatenate([base.ravel(), regressor.inertial_parameters(self, friction, armature)])

    def inverse_dynamics_derivatives(self, q, qd, qdd, wrench=None, base_motion=None):
        """(d tau/d q, d tau/d v), each (n+6, n+6) or (N, n+6, n+6); d tau/d a is M. The q
        direction is the tangent of q (Pinocchio's q (+) dq: the base's [dp; dtheta], base
        frame, then the joints). In the base frame nothing but gravity sees the base's pose:
        tau(q, v, a) is the gravity-free tau(q, v, a - [R^T g; 0]) of the instantaneous tree
        (virtual_chain), whose joints' derivatives the fixed-base recursion computes, and
        R -> R Exp(dtheta) turns g_b = R^T g by g_b x dtheta: d tau/d dtheta = -M[:, :3]
        [g_b]x, d tau/d dp = 0 (compiled: core/floating_derivatives.py). A tip ``wrench``
        (world coordinates, as ``inverse_dynamics``'s) turns with the base too, as R^T w."""
        _no_base_motion(base_motion)
        if self._k is not None:                           # the single-state fast path
            o = _empty((2, self._nv, self._nv))
            if self._k.floating_rnea_derivatives(self._chain, q, qd, qdd,
                                                 *self._gw_single(wrench, 0), o) == OK:
                return o[0], o[1]
        # the general path: the quaternion as given (the kernels normalize it, as above)
        single, q, R, s = fb.as_batch(self.model, q, self._k is None, v=qd, a=qdd)
        N, nv = q.shape[0], self._nv
        v = np.zeros((1, nv)) if s["v"] is None else s["v"]
        a = np.zeros((1, nv)) if s["a"] is None else s["a"]
        if self._k is not None:
            gw, flags = self._gw_rows(wrench, N, 0)
            dq, dv = np.empty((N, nv, nv)), np.empty((N, nv, nv))
            run_split(self._k.floating_rnea_derivatives_batch, self._chain, N,
                      [kernel_rows(x) for x in (q, v, a, gw)], (flags,), (dq, dv),
                      DERIVATIVES_PARALLEL_MIN)
            return (dq[0], dv[0]) if single else (dq, dv)
        _no_reference_wrench(wrench)
        qv, v, rates, g_b = _instantaneous(self.model, q, R, v, a)
        dq, dv = derivatives_reference.inverse_dynamics_derivatives(
            virtual_chain(self.model), qv, v, rates)
        M = fb.mass_matrix(self.model, q)
        dq[:, :, :6] = 0.0
        dq[:, :, 3:6] = -M[:, :, :3] @ skew(g_b)
        dv = dv + M @ _products_jacobian(v)
        return (dq[0], dv[0]) if single else (dq, dv)

    def forward_dynamics_derivatives(self, q, qd, tau, wrench=None, base_motion=None):
        """(d a/d q, d a/d v, d a/d tau) = (-M^-1 d tau/d q, -M^-1 d tau/d v, M^-1) at the
        accelerations of ``tau`` (n joint torques or n + 6 generalized forces), each
        (n+6, n+6) or (N, ...); the q direction and ``wrench`` as in
        ``inverse_dynamics_derivatives``."""
        _no_base_motion(base_motion)
        if self._k is not None:                           # the single-state fast path
            o = _empty((3, self._nv, self._nv))
            if self._k.floating_fd_derivatives(self._chain, q, qd, tau,
                                               *self._gw_single(wrench, 0), o) == OK:
                return o[0], o[1], o[2]
            single, q, _, s = fb.as_batch(self.model, q, False, v=qd, tau=tau)
            N, nv = q.shape[0], self._nv
            gw, flags = self._gw_rows(wrench, N, 0)
            out = tuple(np.empty((N, nv, nv)) for _ in range(3))
            run_split(self._k.floating_fd_derivatives_batch, self._chain, N,
                      [kernel_rows(x) for x in (q, s["v"], s["tau"], gw)], (flags,),
                      out, DERIVATIVES_PARALLEL_MIN)
            return tuple(x[0] for x in out) if single else out
        _no_reference_wrench(wrench)
        a = self.forward_dynamics(q, qd, tau)
        dq, dv = self.inverse_dynamics_derivatives(q, qd, a)
        Minv = np.linalg.inv(self.mass_matrix(q))
        Minv = 0.5 * (Minv + np.swapaxes(Minv, -1, -2))
        return -Minv @ dq, -Minv @ dv, Minv

    def kinetic_energy_gradient(self, q, qd):
        """dT/dq at fixed v (n+6,): six zeros (T = 1/2 v^T M v does not depend on the base's
        pose at a fixed twist in the base frame), then the joints' dT/dq_j, one state: the
        fixed-base recursion on the instantaneous chain or tree (its virtual joints at zero,
        their rates the twist: the same T)."""
        q, v = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        if q.shape != (self._nq,) or v.shape != (self._nv,):
            raise ValueError(f"q and qd: give one state, ({self._nq},) and ({self._nv},)")
        qv = np.concatenate([np.zeros(6), q[7:]])
        if self._k is not None:
            out = np.empty(self._nv)
            if self._k.kinetic_energy_gradient(self._chain, qv, v, out) == OK:
                out[:6] = 0.0
                return out
        out = ke_gradient_reference(virtual_chain(self.model), qv, v)
        out[:6] = 0.0
        return out

    @property
    def packed_dynamics_model(self):
        """The packed model the compiled mass-matrix and Newton-Euler kernels take: the
        instantaneous chain (or tree) with the free-flyer root (core/floating.py), or None."""
        return self._chain

    compiled_chain = None    # sim/'s whole-step kernels know no floating base (sim/group.py)

    # ------------------------------------------------------------- kinematics, energy, momentum
    # compiled: Robot's methods, whose kernels take the base pose as the root of q
    # (core/kinematics.py); the numpy backend: algorithms/floating.py and the fixed
    # base's kinematics moved by the base pose
    def _states(self, *named):
        d = {_V_NAMES.get(name, name): x for name, x in named}   # errors say v and a
        single, q, _, s = fb.as_batch(self.model, d.pop("q"), False, **d)
        return single, [q] + [s[name] for name in d]

    def forward_kinematics(self, q, link=None):
        """4x4 pose of ``link`` (default: the tip) in the world."""
        if self._P is not None:
            return super().forward_kinematics(q, link)
        single, q, R, _ = fb.as_batch(self.model, q)
        X = kinematics.forward_kinematics(self.model, q[:, 7:], link)
        B = np.zeros_like(X)
        B[:, :3, :3], B[:, :3, 3], B[:, 3, 3] = R, q[:, :3], 1.0
        return (B @ X)[0] if single else B @ X

    def jacobian(self, q, link=None):
        """6 x (n+6) Jacobian of ``link``'s origin, [linear; angular] velocity in world axes,
        times v: the base's columns [R, -R [r]x; 0, R] (r: the link origin in the base
        frame), the joints' columns R J_fixed."""
        if self._P is not None:
            return super().jacobian(q, link)
        single, q, R, _ = fb.as_batch(self.model, q)
        N = q.shape[0]
        r = kinematics.forward_kinematics(self.model, q[:, 7:], link)[:, :3, 3]
        J = np.zeros((N, 6, self._nv))
        J[:, :3, :3] = R
        J[:, :3, 3:6] = -R @ skew(r)
        J[:, 3:, 3:6] = R
        Jj = kinematics.jacobian(self.model, q[:, 7:], link)
        J[:, :3, 6:], J[:, 3:, 6:] = R @ Jj[:, :3], R @ Jj[:, 3:]
        return J[0] if single else J

    def kinetic_energy(self, q, qd):
        """T = 1/2 v^T M v (J)."""
        if self._k is None:
            return fb.kinetic_energy(self.model, q, qd)
        M = self.mass_matrix(q)
        v = np.broadcast_to(np.asarray(qd, dtype=float), M.shape[:-1])
        return 0.5 * np.einsum("...i,...ij,...j->...", v, M, v)

    def potential_energy(self, q):
        """V = -m g . c (J), zero with the center of mass at the world origin."""
        if self._P is None:
            return fb.potential_energy(self.model, q)
        return super().potential_energy(q)

    def center_of_mass(self, q):
        """(3,): the center of mass of the base and the chain, world frame."""
        if self._P is None:
            return fb.center_of_mass(self.model, q)
        return super().center_of_mass(q)

    def centroidal_momentum(self, q, qd):
        """(6,): [linear momentum; angular momentum about the center of mass], world axes."""
        if self._P is None:
            return fb.centroidal_momentum(self.model, q, qd)
        return super().centroidal_momentum(q, qd)

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

    def warmup(self, batch=False, kinematics=False):
        """Compile or load the floating-base kernels (core/floating.py) and call each once,
        single state and (``batch``) batch, so that the first real call is fast; with
        ``kinematics`` also the link poses, Jacobians and frame accelerations. Returns self."""
        if self._k is not None:
            CHAIN.load_all(k for k in FLOATING_KERNELS if ("tree" in k) != self.model.is_chain)
        states = (self.random_state(0), self.random_state(0, batch=2))
        for q, v in states if batch else states[:1]:
            self.inverse_dynamics(q, v, v)
            self.mass_matrix(q)
            for method in ("aba", "cholesky"):
                self.forward_dynamics(q, v, v, method=method)
        if kinematics:
            CHAIN.load_all(KINEMATICS_KERNELS if self._P is not None else ())
            self._warm_kinematics(*states[0])
        return self


def virtual_chain(model) -> Model:
    """The instantaneous chain of a floating ``model`` (module docstring): prismatic joints
    along the base's x, y, z, revolute joints about them (massless, the last carrying the
    base's inertia), then the chain; no gravity (it comes with each call)."""
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
        armature=np.r_[np.zeros(6), model.armature],
        parent=velocity_parents(model.parent))


def _instantaneous(model, q, R, v, a):
    """(qv, v, rates, g_b): the instantaneous tree's joint positions (the virtual joints at
    zero), rates (v) and accelerations (a + the virtual joints' velocity products, gravity
    entering as the base acceleration -g_b, g_b = R^T g), N states (rows broadcast)."""
    N, nv = q.shape[0], v.shape[-1]
    v, a = np.broadcast_to(v, (N, nv)), np.array(np.broadcast_to(a, (N, nv)))
    g_b = np.einsum("nji,j->ni", R, model.gravity)
    a[:, :3] -= g_b                                             # gravity as acceleration
    qv = np.concatenate([np.zeros((N, 6)), q[:, 7:]], axis=1)
    return qv, v, a + _velocity_products(v), g_b


def _velocity_products(v):
    """(N, n+6): what the instantaneous tree's joint accelerations add to a = dv/dt (as
    core/floating._products): [omega x v_O; -wy wz; wx wz; -wx wy; 0 for the joints]."""
    p = np.zeros_like(v)
    vo, w = v[:, 0:3], v[:, 3:6]
    p[:, 0] = w[:, 1] * vo[:, 2] - w[:, 2] * vo[:, 1]        # omega x v_O
    p[:, 1] = w[:, 2] * vo[:, 0] - w[:, 0] * vo[:, 2]
    p[:, 2] = w[:, 0] * vo[:, 1] - w[:, 1] * vo[:, 0]
    p[:, 3], p[:, 4], p[:, 5] = -w[:, 1] * w[:, 2], w[:, 0] * w[:, 2], -w[:, 0] * w[:, 1]
    return p


def _products_jacobian(v):
    """d/dv of ``_velocity_products``, (N, n+6, n+6)."""
    N = v.shape[0]
    J = np.zeros((N, v.shape[1], v.shape[1]))
    vo, w = v[:, 0:3], v[:, 3:6]
    J[:, 0:3, 0:3] = skew(w)                                   # d(omega x v_O)/d v_O
    J[:, 0:3, 3:6] = -skew(vo)                                 #               /d omega
    J[:, 3, 4], J[:, 3, 5] = -w[:, 2], -w[:, 1]
    J[:, 4, 3], J[:, 4, 5] = w[:, 2], w[:, 0]
    J[:, 5, 3], J[:, 5, 4] = -w[:, 1], -w[:, 0]
    return J


def velocity_parents(parent):
    """The parent of each coordinate of v = [v_O, omega, joints]: the base's six a chain, a
    root joint's the last of them (M's sparsity; the virtual chain's parent array)."""
    return np.r_[np.arange(6) - 1, np.where(parent < 0, 5, parent + 6)]


def _on_chain(P, q, v, a, tau, gw, flags, kind, out):
    """N floating states through a batch kernel of the instantaneous chain or tree (``kind``:
    "rnea", "fd", "crba": ``floating_rnea_batch``, ..., the free-flyer root's), CHUNK states at a time: their rows
    (core/floating.py floating_rows) in small buffers reused from chunk to chunk (no fresh
    pages to fault in, in cache), then the kernel, then (forward dynamics) the accelerations
    converted back. Every state as in one call (chunks are whole SIMD blocks). Returns the
    largest status (run_split calls it once per thread)."""
    N, nv = out.shape[0], P.shape[0] - 1
    K = TREE if P[nv, TREE_FLAG] != 0.0 else CHAIN     # the instantaneous chain, or tree
    c = min(N, CHUNK)
    qv, w = np.empty((c, nv)), np.empty((c, W_ALL))
    qdd = np.empty((c if kind == "rnea" else 0, nv))
    status = 0
    for k in range(0, N, CHUNK):
        e = min(N, k + CHUNK)
        rows = lambda x: x if x.shape[0] == 1 else x[k:e]       # noqa: E731
        m = e - k
        status = max(status, K.floating_rows(rows(q), rows(v), rows(a), rows(gw), flags,
                                             qv[:m], qdd[:m], w[:m]))
        if kind == "rnea":
            status = max(status, K.floating_rnea_batch(
                P, qv[:m], rows(v), qdd[:m], w[:m], (flags & F.WRENCH) | _QD_QDD | F.BASE, out[k:e]))
        elif kind == "fd":
            status = max(status, K.floating_fd_batch(P, qv[:m], rows(v), rows(tau), w[:m],
                                                     flags | F.QD | F.BASE, out[k:e]))
            K.floating_accelerations(rows(v), out[k:e])
        else:
            status = max(status, K.floating_crba_batch(P, qv[:m], out[k:e]))
    return status


def _no_reference_wrench(wrench):
    if wrench is not None:
        raise ValueError("the NumPy backend's derivatives of a floating base take no wrench: "
                         "subtract J^T w from tau, or use the compiled backend")


def _no_base_motion(base_motion):
    if base_motion is not None:
        raise ValueError("base_motion prescribes a fixed base's motion; a floating base moves "
                         "by its own dynamics (give its velocity in v)")

