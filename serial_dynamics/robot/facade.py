"""``Robot``: the thin facade over a ``Model`` and the algorithms.

It holds the immutable model and the dissipation model, checks inputs, and calls the
algorithm functions. Every state argument accepts ``(n,)`` or a batch ``(N, n)``.

Backends: ``"numba"`` (default) runs inverse dynamics, the mass matrix, bias and gravity
torques, forward dynamics (Cholesky and articulated-body routes), frame poses and
Jacobians, the Coriolis matrix, the center of mass and the momentum through the compiled core
(``serial_dynamics/core/``); ``"numpy"`` runs the readable reference implementations
of ``algorithms/`` (the tests compare the two). Choose per robot with
``Robot(model, backend="numpy")`` or for the process with the environment variable
``SERIAL_DYNAMICS_BACKEND=numpy``. Forward dynamics by QR always runs the reference
code.

Paths. A single state given as C-contiguous float64 ``(n,)`` ndarrays goes straight to
the compiled entry point, which checks lengths and NaN/Inf itself (numba's dispatcher
checks the types and answers "other types" for anything else, no exception); anything
else (lists, batches, other dtypes or layouts, a bad value) takes the general path,
which validates like the reference (same ValueError messages) and calls the batch
kernels. A batch of at least ``PARALLEL_MIN`` states is
split over the machine's cores (the batch kernels release the GIL; each chunk is a
whole number of SIMD blocks, so the results are those of one serial call).

Thread safety: the model is immutable and every compiled call allocates its own scratch
memory (``core/data.py``), so one ``Robot`` may be called from several threads at once.
"""
from __future__ import annotations

import dataclasses
import os
from types import MappingProxyType

import numpy as np

from .. import contacts as _contacts
from . import derivatives as _derivatives
from . import kinematics as _kin
from . import regressor as _regressor
from . import task_space as _task_space
from ..algorithms import aba, crba, energy, forward, kinematics, noc, rnea
from ..algorithms._batch import as_batch
from .charts import EUCLIDEAN
from ..core.planar_layout import planar_pack
from .base_motion import check_base_motion
from .batches import kernel_rows as _rows
from .batches import run_split
from .batches import single_external as _external
from ..core import ENTRY_POINTS, K, OK, layout
from ..core.dispatch import TREE
from ..core import flags as F
from ..model.dissipation import Dissipation
from ..model.model import Model
from ..model.payload import Payload, attach
from .wrenches import generalized_forces
from .common import FD_METHODS, PARALLEL_MIN, QD, QD_QDD, QD_QDD_W, QD_W, aba_by_default
from .common import into as _into
from .floating import Floating
from .mimic import Mimic
from .planar import Planar

_empty = np.empty                          # one global lookup on the fast paths
_NO_WRENCH = np.zeros((1, 6))              # stands in for w in batch calls without one
_W0 = np.zeros(6)                          # and in single forward-dynamics calls (not read)
_QD_QDD, _QD, _QD_QDD_W, _QD_W = QD_QDD, QD, QD_QDD_W, QD_W     # module globals: one lookup
BACKENDS = ("numba", "numpy")
_FD_FLAGS = {"cholesky": F.QD, "aba": F.QD | F.ABA}
SINGLE_KERNELS = ("rnea", "rnea_wrench", "crba", "fd")     # warmup(): one state a call
BATCH_KERNELS = ("rnea_batch", "crba_batch", "fd_batch")    # warmup(batch=True): batches too
ROBOT_KERNELS = SINGLE_KERNELS + BATCH_KERNELS
PLANAR_KERNELS = tuple(k for k in ENTRY_POINTS if k.startswith("planar"))    # and, if planar


class Robot:
    """Dynamics of one robot: a serial chain or a kinematic tree. Build it with
    ``serial_dynamics.load_urdf``."""

    is_planar = False        # a planar chain on the planar fast path (PlanarRobot)
    is_floating = False      # a free-floating base (FloatingRobot)
    chart = EUCLIDEAN        # q's chart for integrators (sim/): q in R^n (charts.py)
    _fd_flags = _FD_FLAGS    # forward_dynamics(method=...): the kernels' flags

    def __new__(cls, model, *args, **kwargs):
        # Robot(model) builds the kind the model needs: kind_of(model), at the end of this
        # module; a kind's own constructor (with_payload's type(self)(...)) builds that kind
        return super().__new__(kind_of(model) if cls is Robot else cls)

    def __init__(self, model: Model, dissipation: Dissipation | None = None, backend=None,
                 _loaded=None, _payload=None, _P=None):
        self.model = model
        self._dissipation = Dissipation.from_model(model) if dissipation is None else dissipation
        backend = backend or os.environ.get("SERIAL_DYNAMICS_BACKEND", "numba")
        if backend not in BACKENDS:
            raise ValueError(f"backend {backend!r} unknown; use one of {BACKENDS}")
        self._backend = backend
        self._n, self._nn = model.dof, (model.dof, model.dof)
        # forward_dynamics(method="auto"): common.aba_by_default
        self._fd_auto = _FD_FLAGS["aba" if aba_by_default(model, False) else "cholesky"]
        # the kernel table: K's for a chain, the tree table (core/tree.py) for a tree, the
        # same names and signatures; None on the NumPy backend, its one meaning everywhere
        self._k = None if backend != "numba" else K if model.is_chain else TREE
        self._P = _P if _P is not None else layout.pack(model) if self._k is not None else None
        self._rnea_batch, self._crba_batch = ("rnea_batch", self._P), ("crba_batch", self._P)
        self._frames = {}          # link: (body, placement): robot/kinematics.frame
        self._nv = model.dof       # the Jacobian's columns (every joint, a floating base's 6)
        self._base = np.zeros(10)  # the base body's inertia (a fixed base's does not move)
        # with_payload's bookkeeping: the model (and P) as loaded, and the payload attached
        self._loaded, self._payload = _loaded or (model, self._P), _payload

    backend = property(lambda self: self._backend, doc='"numba" (compiled) or "numpy" (reference)')

    # ------------------------------------------------------------- description
    dof = property(lambda self: self.model.dof)
    nq = property(lambda self: self.dof, doc="the length of q (n + 7 on a floating base)")
    nv = property(lambda self: self.dof, doc="the length of qd (n + 6 on a floating base)")
    joint_names = property(lambda self: list(self.model.joint_names))
    joint_types = property(lambda self: list(self.model.joint_types))
    link_names = property(lambda self: list(self.model.link_names))
    base_link = property(lambda self: self.model.base_link)
    tip_link = property(lambda self: self.model.tip_link)
    gravity = property(lambda self: self.model.gravity)
    lower = property(lambda self: self.model.lower)
    upper = property(lambda self: self.model.upper)
    velocity_limit = property(lambda self: self.model.velocity_limit)
    effort_limit = property(lambda self: self.model.effort_limit)
    armature = property(lambda self: self.model.armature,
                        doc="reflected rotor inertia per joint, kg m^2 (N^2 J_rotor), base to tip")
    payload = property(lambda self: self._payload,
                       doc="the attached ``Payload`` (``with_payload``), or None")
    all_joint_names = property(lambda self: list(self.model.joint_names),
                               doc="every joint of the model (with mimic joints: MimicRobot)")

    def all_joint_positions(self, q):
        """Positions of every joint of the chain: q itself (mimic joints: MimicRobot)."""
        return np.asarray(q, dtype=float)

    def all_joint_velocities(self, qd):
        return np.asarray(qd, dtype=float)

    # ------------------------------------------------------------- payload
    def with_payload(self, mass, com=(0.0, 0.0, 0.0), inertia=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
                     link=None) -> "Robot":
        """A new Robot with a payload rigidly attached to ``link`` (default: the tip link):
        ``mass`` kg, ``com`` (x, y, z) m in the link's frame, ``inertia`` (ixx, iyy, izz,
        ixy, ixz, iyz) kg m^2 about the payload's center of mass, in the link's axes. It
        replaces any payload attached before; this Robot is unchanged. Nothing is
        recompiled (the compiled model is one array, ``core/layout.py``)."""
        payload = Payload.make(mass, com, inertia, self.tip_link if link is None else link)
        model0, P0 = self._loaded
        model, body = attach(model0, payload)
        P = None
        if P0 is not None:                     # the loaded P with one body's row replaced
            P = P0.copy()
            layout.set_inertia(P, body, model.mass[body], model.h[body], model.I_O[body])
        return type(self)(model, self._dissipation, self._backend, _loaded=self._loaded,
                          _payload=payload, _P=P)

    def without_payload(self) -> "Robot":
        """A new Robot as loaded, without payload (bitwise the results of the loaded one)."""
        model0, P0 = self._loaded
        return type(self)(model0, self._dissipation, self._backend, _P=P0)

    @property
    def dissipation(self) -> Dissipation:
        """Joint friction model (defaults from URDF <dynamics>); replace it with
        ``robot.dissipation = robot.dissipation.override(coulomb={...})``."""
        return self._dissipation

    @dissipation.setter
    def dissipation(self, value: Dissipation):
        if not isinstance(value, Dissipation) or tuple(value.joint_names) != tuple(self.joint_names):
            raise ValueError("dissipation must be a serial_dynamics.Dissipation for the joints "
                             f"{self.joint_names}")
        self._dissipation = value

    def __reduce__(self):
        """Pickled as data, never as compiled kernels: (this kind, the model as loaded, the
        dissipation, the backend, the payload). Unpickling rebuilds the facade the same way,
        so any kind travels unchanged and computes the same bits; the kernels come from the
        receiving machine's numba cache (sweep.run sends robots to Dask workers this way)."""
        model = self._loaded[0]
        fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(model)}
        fields.update({k: dict(v) for k, v in fields.items() if isinstance(v, MappingProxyType)})
        return (_unpickle, (type(self), type(model), fields, self._dissipation, self._backend,
                            self._payload))

    def __repr__(self):
        m = self.model
        ends = (repr(self.tip_link) if m.is_chain else
                f"tree to {[m.link_names[i] for i in range(m.dof) if not m.children[i]]}")
        return f"Robot({m.name!r}, dof={self.dof}, {self.base_link!r} -> {ends}, joints={self.joint_names})"

    # ------------------------------------------------------------- dynamics
    # Fast path: every call first tries the compiled single-state entry point, whose one
    # signature numba matches in C (~70 ns). It returns OK when it wrote the result;
    # NOT_FINITE, BAD_LENGTH or OTHER_TYPES (arguments of other types: lists, batches, other
    # dtypes or layouts, read-only arrays; see core.dispatch) send the call to the general
    # path, which validates like the reference, raises its ValueError naming the culprit,
    # or runs the batch kernels. No exception is caught to choose the path.
    # ``out``: an array of the result's shape (float64, writable) to write the result into
    # instead of a new one, as NumPy's out= (a 1 kHz loop then allocates nothing); returned.
    # After an error its contents are undefined.
    # ``base_motion``: a ``BaseMotion`` (a base with known motion), None for a base at rest.
    def inverse_dynamics(self, q, qd, qdd, wrench=None, base_motion=None, out=None,
                         wrenches=None):
        """tau = M(q) qdd + b(q, qd) - J^T w  (rigid body; no friction). N m / N."""
        if wrenches is not None:     # wrenches on links: - sum_k J_k^T w_k (robot/wrenches.py)
            return _into(out, self.inverse_dynamics(q, qd, qdd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        k = self._k
        if k is not None:
            o = _empty(self._n) if out is None else out
            if base_motion is None:
                if (k.rnea(self._P, q, qd, qdd, _QD_QDD, o) if wrench is None else
                        k.rnea_wrench(self._P, q, qd, qdd, wrench, _QD_QDD_W, o)) == OK:
                    return o
            elif k.rnea_wrench(self._P, q, qd, qdd, *_external(base_motion, wrench, _QD_QDD), o) == OK:
                return o
        return _into(out, self._rnea_general((("q", q), ("qd", qd), ("qdd", qdd)), wrench,
                                             base_motion))

    def mass_matrix(self, q, out=None):
        """M(q), the generalized inertia matrix."""
        k = self._k
        if k is None:
            return _into(out, crba.mass_matrix(self.model, q))
        o = _empty(self._nn) if out is None else out
        if k.crba(self._P, q, o) == OK:
            return o
        named = (("q", q),)
        single, (q,) = as_batch(self.model, *named, finite=False)
        q = _rows(q)
        M = np.empty((q.shape[0], self._n, self._n))
        kernel, model = self._crba_batch
        if _parallel(getattr(k, kernel), model, q.shape[0], (q,), (), M) != OK:
            self._not_finite(named)
        return _into(out, M[0] if single else M)

    def mass_matrix_factor(self, q):
        """(L, d) with M(q) = L^T diag(d) L, L unit lower triangular with the zeros a tree's
        branches put in M (Featherstone's LTDL, RBDA Sec. 6.5): what a caller solving with M
        many times keeps. Dense on a chain or with mimic joints."""
        return crba.ltdl(self.mass_matrix(q), self._v_parent)

    @property
    def _v_parent(self):
        """The parent of each velocity coordinate (M's sparsity; kinds override)."""
        return self.model.parent

    def bias_torques(self, q, qd, wrench=None, base_motion=None, out=None, wrenches=None):
        """b(q, qd) - J^T w = C(q, qd) qd + g(q) - J^T w (and the base motion's torques)."""
        if wrenches is not None:
            return _into(out, self.bias_torques(q, qd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        k = self._k
        if k is not None:
            o = _empty(self._n) if out is None else out
            if base_motion is None:
                if (k.rnea(self._P, q, qd, q, _QD, o) if wrench is None else
                        k.rnea_wrench(self._P, q, qd, q, wrench, _QD_W, o)) == OK:
                    return o
            elif k.rnea_wrench(self._P, q, qd, q, *_external(base_motion, wrench, _QD), o) == OK:
                return o
        return _into(out, self._rnea_general((("q", q), ("qd", qd), ("qdd", None)), wrench,
                                             base_motion))

    def gravity_torques(self, q, out=None):
        """g(q): the torques that hold the chain still (the textbook's gamma is -g)."""
        k = self._k
        if k is not None:
            o = _empty(self._n) if out is None else out
            if k.rnea(self._P, q, q, q, 0, o) == OK:
                return o
        return _into(out, self._rnea_general((("q", q), ("qd", None), ("qdd", None)), None, None))

    def coriolis_matrix(self, q, qd):
        """C(q, qd) from the natural orthogonal complement: C qd + g = b, Mdot - 2C skew."""
        if self._P is None:
            return noc.coriolis_matrix(self.model, q, qd)
        return _kin.coriolis_matrix(self, q, qd)

    def forward_dynamics(self, q, qd, tau, wrench=None, method="auto", base_motion=None,
                         out=None, wrenches=None):
        """qdd for applied torques tau (rigid body). ``method``: "auto" (Cholesky for short
        chains, articulated bodies from ``algorithms.aba.CROSSOVER`` joints on; on a tree
        by the depths of its joints: ``robot/common.aba_by_default``), "cholesky" (on a
        tree the sparse factor), "aba" (O(n)) or "qr" (for ill-conditioned chains). A batch
        takes its single states' route, so that each row is its single call's bits; on a
        floating tree "aba" is the faster batch (docs/speed.md)."""
        if wrenches is not None:     # wrenches on links: tau + sum_k J_k^T w_k
            return _into(out, self.forward_dynamics(
                q, qd, np.asarray(tau, dtype=float) + generalized_forces(self, q, wrenches),
                wrench, method, base_motion))
        flags = self._fd_auto if method == "auto" else self._fd_flags.get(method)
        k = self._k
        if flags is not None and k is not None:
            o = _empty(self._n) if out is None else out
            if base_motion is None:
                if k.fd(self._P, q, qd, tau, _W0 if wrench is None else wrench,
                        flags if wrench is None else flags | F.WRENCH, o) == OK:
                    return o
            elif k.fd(self._P, q, qd, tau, *_external(base_motion, wrench, flags), o) == OK:
                return o
        if k is None or flags is None:
            base_motion = check_base_motion(base_motion)
            if method == "auto":
                method = "aba" if flags & F.ABA else "cholesky"
            if method == "aba":
                return _into(out, aba.forward_dynamics(self.model, q, qd, tau, wrench,
                                                       base_motion=base_motion))
            if method not in FD_METHODS:
                raise ValueError(f"forward-dynamics method {method!r} unknown; use one of "
                                 f"{FD_METHODS}")
            return _into(out, forward.forward_dynamics(self.model, q, qd, tau, wrench, method,
                                                       base_motion=base_motion))
        named = (("q", q), ("qd", qd), ("tau", tau))
        single, (q, qd, tau) = as_batch(self.model, *named, finite=False)
        w, flags = self._external_rows(wrench, base_motion, q.shape[0], flags)
        q, qd, tau = _rows(q), _rows(qd), _rows(tau)
        N = max(q.shape[0], qd.shape[0], tau.shape[0])
        qdd = np.empty((N, self._n))
        if _parallel(k.fd_batch, self._P, N, (q, qd, tau, w), (flags,), qdd) != OK:
            self._not_finite(named)
        return _into(out, qdd[0] if single else qdd)

    # general path: validate like the reference, then one batch kernel call
    def _rnea_general(self, named, wrench, base_motion):
        base_motion = check_base_motion(base_motion)
        if self._k is None:
            return rnea.inverse_dynamics(self.model, *(x for _, x in named), wrench,
                                         base_motion=base_motion)
        single, (q, qd, qdd) = as_batch(self.model, *named, finite=False)   # the reference's errors
        N = q.shape[0]
        flags = (F.QD if named[1][1] is not None else 0) | (F.QDD if named[2][1] is not None else 0)
        q = _rows(q)
        qd = _rows(qd) if flags & F.QD else q             # unused by the kernel when absent
        qdd = _rows(qdd) if flags & F.QDD else q
        w, flags = self._external_rows(wrench, base_motion, N, flags)
        out = np.empty((N, self._n))
        kernel, model = self._rnea_batch if base_motion is None else ("rnea_batch", self._P)
        if _parallel(getattr(self._k, kernel), model, N, (q, qd, qdd, w), (flags,), out) != OK:
            self._not_finite(named)
        return out[0] if single else out

    def _not_finite(self, named):
        """A batch kernel saw a NaN or Inf (the states are checked there, not before: it
        saves a pass over them): raise the reference's ValueError naming the state and the
        joint, or else the wrench's."""
        as_batch(self.model, *named)
        raise ValueError("wrench has a NaN or Inf entry; give finite numbers")

    @staticmethod
    def _external_rows(wrench, base_motion, N, flags):
        """The batch kernels' external inputs w (layout.W_*): (N or 1, 6) wrench rows, or
        (N or 1, 15) with the base motion; and the flags that say what they hold."""
        base_motion = check_base_motion(base_motion)
        if wrench is None and base_motion is None:
            return _NO_WRENCH, flags
        w = _NO_WRENCH if wrench is None else _rows(rnea._wrench_batch(wrench, N))
        flags |= 0 if wrench is None else F.WRENCH
        if base_motion is None:
            return w, flags
        ext = np.repeat(base_motion.external()[None], w.shape[0], axis=0)
        ext[:, :layout.W_WRENCH] = w
        return ext, flags | F.BASE

    # ------------------------------------------------------------- identification, derivatives
    # (the batching, mimic reduction and kernel calls live in regressor.py and derivatives.py)
    def regressor(self, q, qd, qdd, friction=False, armature=None):
        """Y (n, p) or (N, n, p) with inverse_dynamics(q, qd, qdd) == Y @ inertial_parameters()
        (plus the friction torques fv qd + fc sign(qd) + fo with ``friction=True``). Columns:
        10 per body [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] (link frame, inertia about
        its origin: Pinocchio's toDynamicParameters), then the armature [Ia..] (``armature``
        None: when some joint has one; True/False force it), then [fv..], [fc..], [fo..].
        Names: ``regressor.parameter_names``; see ``regressor.py``."""
        return _regressor.regressor(self, q, qd, qdd, friction, armature)

    def inertial_parameters(self, friction=False, armature=None):
        """The standard parameters phi (p,) that ``regressor`` multiplies (same arguments, same
        order; friction from ``dissipation``: viscous, Coulomb, offset 0); see ``regressor.py``."""
        return _regressor.inertial_parameters(self, friction, armature)

    def inverse_dynamics_derivatives(self, q, qd, qdd, wrench=None, base_motion=None):
        """(d tau/d q, d tau/d qd), each (n, n) or (N, n, n); d tau/d qdd is M(q)."""
        return _derivatives.inverse_dynamics_derivatives(self, q, qd, qdd, wrench, base_motion)

    def forward_dynamics_derivatives(self, q, qd, tau, wrench=None, base_motion=None):
        """(d qdd/d q, d qdd/d qd, d qdd/d tau) = (-M^-1 d tau/d q, -M^-1 d tau/d qd, M^-1)."""
        return _derivatives.forward_dynamics_derivatives(self, q, qd, tau, wrench, base_motion)

    def kinetic_energy_gradient(self, q, qd):
        """dT/dq (n,) at fixed qd, T = 1/2 qd^T M(q) qd: C(q, qd)^T qd (one state)."""
        if self._k is not None:
            out = _empty(self._n)
            if self._k.kinetic_energy_gradient(self._P, np.asarray(q, float),
                                               np.asarray(qd, float), out) == OK:
                return out
        return energy.kinetic_energy_gradient(self.model, q, qd)

    @property
    def packed_model(self):
        """The packed model ``P`` (core/layout.py) the compiled kinematics kernels take for
        this robot (a floating base's: its virtual chain's), or None on the NumPy backend."""
        return self._P

    @property
    def packed_dynamics_model(self):
        """The packed model the compiled mass-matrix and Newton-Euler kernels take for this
        robot (``packed_model`` but on a floating base), or None on the NumPy backend."""
        return self._P

    @property
    def compiled_chain(self):
        """The packed model ``P`` that sim/'s compiled whole-step kernels (the semi-implicit
        Euler loop, the symplectic Euler step) run on in this robot's coordinates, or None
        where they cannot: the NumPy backend, the reduced system of mimic joints, a tree."""
        return self._P if self._k is K else None

    def dissipation_torques(self, qd):
        """delta(qd) of the current dissipation model (oppose the motion)."""
        return self._dissipation.torque(qd)

    # ------------------------------------------------------------- kinematics, energy
    # compiled: core/kinematics.py through robot/kinematics.py (every kind of robot: a
    # floating base's q has its pose first); the numpy backend: algorithms/
    def _states(self, *named):
        """(single, [(N, n) arrays]): the states checked (ValueError naming the culprit)."""
        return as_batch(self.model, *named)

    def forward_kinematics(self, q, link=None):
        """4x4 pose of ``link`` (default: the tip) in the base frame; (N, 4, 4) for (N, n)."""
        if self._P is None:
            return kinematics.forward_kinematics(self.model, q, link)
        return _kin.frame_pose(self, q, link)

    def jacobian(self, q, link=None):
        """6 x n geometric Jacobian of ``link``'s origin, [linear; angular], base frame."""
        if self._P is None:
            return kinematics.jacobian(self.model, q, link)
        return _kin.frame_jacobian(self, q, link)

    # task space (task_space.py: every kind, batches; rows as jacobian's)
    def frame_acceleration(self, q, qd, qdd, link=None):
        """[linear; angular] acceleration of ``link``'s origin (classical), = J qdd + J-dot qd."""
        if self._P is None:
            return _task_space.frame_acceleration(self, q, qd, qdd, link)
        return _kin.frame_acceleration(self, q, qd, qdd, link)

    def jacobian_dot_qd(self, q, qd, link=None):
        """J-dot qd (6,), the frame's bias acceleration: frame_acceleration at qdd = 0."""
        return self.frame_acceleration(q, qd, None, link)

    def operational_space_inertia(self, q, link=None, damping=0.0):
        """Lambda = (J M^-1 J^T + damping^2 1)^-1, 6 x 6 (undamped: refused where singular)."""
        return _task_space.operational_space_inertia(self, q, link, damping)

    def dynamically_consistent_inverse(self, q, link=None, damping=0.0):
        """J-bar = M^-1 J^T Lambda, n x 6 (Lambda damped as given)."""
        return _task_space.dynamically_consistent_inverse(self, q, link, damping)

    # contacts (serial_dynamics/contacts/: NumPy on the public methods; every kind inherits
    # these, each kind's own mass matrix, Jacobians and bias torques answering)
    def contact_points(self):
        """[sd.Contact]: the URDF's <collision> spheres (their centres) and box corners."""
        return _contacts.contact_points(self)

    def constrained_forward_dynamics(self, q, v, tau, contacts, baumgarte=None, mu=1e-6,
                                     tolerance=1e-12, max_iterations=100):
        """(a, f): accelerations (nv,) and contact forces (k, 3) or (k, 6) (world axes, on the
        robot) with M a + b = tau + J^T f and every contact's acceleration zero; ``tau`` as
        ``forward_dynamics`` takes it. docs/contacts.md: the solver and its settings."""
        return _contacts.constrained_forward_dynamics(self, q, v, tau, contacts, baumgarte, mu,
                                                      tolerance, max_iterations)

    def contact_inverse_dynamics(self, q, v, a, contacts, friction=None,
                                 normal=(0.0, 0.0, 1.0), tolerance=1e-9):
        """(tau, f): torques (nv,) (a floating base's six rows zero) and contact forces with
        M a + b = tau + J^T f: minimum-norm, or (``friction=mu``) in the Coulomb cones."""
        return _contacts.contact_inverse_dynamics(self, q, v, a, contacts, friction, normal,
                                                  tolerance)

    def kinetic_energy(self, q, qd):
        """T = 1/2 qd^T M(q) qd (J), with this robot's (compiled) mass matrix."""
        if self._k is None:
            return energy.kinetic_energy(self.model, q, qd)
        single, (q, qd) = as_batch(self.model, ("q", q), ("qd", qd))
        T = 0.5 * np.einsum("ni,nij,nj->n", qd, self.mass_matrix(_rows(q)), qd)
        return T[0] if single else T

    def potential_energy(self, q):
        """V = -m g . c (J), zero with the center of mass at the base origin."""
        if self._P is None:
            return energy.potential_energy(self.model, q)
        mc = _kin.mass_moment(self, q)
        return -(mc[:3] if mc.ndim == 1 else mc[:, :3]) @ self.model.gravity

    def center_of_mass(self, q):
        """(3,): the center of mass of the moving bodies, base frame (m)."""
        if self._P is None:
            return energy.center_of_mass(self.model, q)
        mc = _kin.mass_moment(self, q)
        return mc[:3] / mc[3] if mc.ndim == 1 else mc[:, :3] / mc[:, 3:]

    def centroidal_momentum(self, q, qd):
        """(6,): [linear momentum; angular momentum about the center of mass] of the moving
        bodies, base axes (kg m/s, kg m^2/s)."""
        if self._P is None:
            return energy.centroidal_momentum(self.model, q, qd)
        return _kin.centroidal_momentum(self, q, qd)

    def total_energy(self, q, qd):
        return self.kinetic_energy(q, qd) + self.potential_energy(q)

    def kernels(self, batch=False, kinematics=False):
        """The compiled kernels of the dynamics methods (what ``warmup`` loads): those of one
        state a call, with ``batch`` those of batches too, with ``kinematics`` those of
        ``forward_kinematics``, ``jacobian`` and ``frame_acceleration``; () on the numpy
        backend."""
        if self._k is None:
            return ()
        names = SINGLE_KERNELS + (BATCH_KERNELS if batch else ())
        if self._k is TREE:
            names = tuple("tree_" + name for name in names)
        else:
            names += tuple(k for k in PLANAR_KERNELS if self.is_planar
                           and (batch or not k.endswith("batch")))
        return names + (_kin.KINEMATICS_KERNELS if kinematics else ())

    def warmup(self, batch=False, kinematics=False):
        """Compile or load the fast paths once (numba backend: the kernels of the Robot
        methods for one state, ``kernels()``; with ``batch`` for batches too; with
        ``kinematics`` those of the link poses, Jacobians and frame accelerations; from the
        numba cache when it is warm), so that the first real call is fast. Nodes call this
        before they report ready; what else a program calls compiles on its first use (a
        cold compile of every batch kernel is about half of the whole). Returns self."""
        K.load_all(self.kernels(batch, kinematics))
        q = np.zeros(self.dof)
        qb = np.zeros((2, self.dof))
        w = np.zeros(6)
        for x in (q, qb) if batch else (q,):
            self.inverse_dynamics(x, x, x)
            self.inverse_dynamics(x, x, x, wrench=w)
            self.bias_torques(x, x)
            self.gravity_torques(x)
            self.mass_matrix(x)
            for method in ("cholesky", "aba"):
                self.forward_dynamics(x, x, x, method=method)
        if kinematics:
            self._warm_kinematics(self.neutral(), np.zeros(self.nv))
        return self

    def _warm_kinematics(self, q, v):
        """One call of each kinematics method ``warmup(kinematics=True)`` loads."""
        self.forward_kinematics(q)
        self.jacobian(q)
        self.frame_acceleration(q, v, v)

    def neutral(self):
        """q at rest: every joint at zero (a floating base also at the world origin)."""
        return np.zeros(self.nq)

    def integrate(self, q, qd, dt):
        """q + qd dt (a floating base moves its pose on SE(3): FloatingRobot)."""
        return np.asarray(q, dtype=float) + np.asarray(qd, dtype=float) * dt

    def random_state(self, rng=None, batch=None, speed=1.0):
        """(q, qd) drawn uniformly within the joint limits (+-pi where unlimited) and
        velocities in +-speed; handy for tests and benchmarks."""
        rng = np.random.default_rng(rng)
        shape = (self.dof,) if batch is None else (batch, self.dof)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        return rng.uniform(lo, hi, shape), rng.uniform(-speed, speed, shape)


def _unpickle(kind, model_type, fields, dissipation, backend, payload):
    """``Robot.__reduce__``'s inverse: the model's read-only arrays and mapping views as
    built, then the facade, then the payload attached as ``with_payload`` attaches it."""
    for key, value in fields.items():
        if isinstance(value, dict):
            fields[key] = MappingProxyType(value)
        for a in value.values() if isinstance(value, dict) else (value,):
            for x in a if isinstance(a, tuple) else (a,):
                if isinstance(x, np.ndarray):
                    x.setflags(write=False)
    robot = kind(model_type(**fields), dissipation, backend)
    if payload is None:
        return robot
    return robot.with_payload(payload.mass, payload.com, payload.inertia, payload.link)


def _parallel(kernel, P, N, arrays, extra, out):
    """A batch kernel over ``N`` states, split over the cores from PARALLEL_MIN states in
    whole SIMD blocks (``layout.B``): every state as in one serial call."""
    return run_split(kernel, P, N, arrays, extra, (out,), PARALLEL_MIN, layout.B)


# ----------------------------------------------------------------- the kinds of robot
# Each kind overrides what it changes (its module says how); nothing outside robot/ reads a
# kind's private state (test/robot/test_kinds.py).
class FloatingRobot(Floating, Robot):
    """A chain on a free-floating base: q on SE(3) x R^n, v = [base twist; joint rates]
    (floating.py)."""


class MimicRobot(Mimic, Robot):
    """A chain with mimic joints: the reduced system of its independent joints (mimic.py)."""


class PlanarRobot(Planar, Robot):
    """A chain that moves in one plane, on the planar fast path (planar.py)."""


class FloatingMimicRobot(Mimic, Floating, Robot):
    """A floating base with mimic joints (a humanoid's or a hand's fingers): mimic.py's
    reduction around floating.py's algorithms, q = [base pose; independent joints]."""

    def inverse_dynamics_derivatives(self, q, qd, qdd, wrench=None, base_motion=None):
        """G^T (d tau_all/d x_all) G, x = q (tangent), v (Mimic's forward derivatives solve
        with these and the reduced M)."""
        _, _, (q, qd, qdd) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        dq, dv = Floating.inverse_dynamics_derivatives(self, q, qd, qdd, wrench, base_motion)
        return self._reduce2(dq), self._reduce2(dv)

    def integrate(self, q, qd, dt):
        """q moved by v dt (the map is linear: G (q + qd dt) + o = q_all + G qd dt)."""
        _, _, (qa, va) = self._all(("q", q), ("qd", qd))
        return np.ascontiguousarray(super().integrate(qa, va, dt)[..., self._q_independent])

    def random_state(self, rng=None, batch=None, speed=1.0):
        q, v = super().random_state(rng, batch, speed)     # rows C-contiguous, as the other
        return (np.ascontiguousarray(q[..., self._q_independent]),   # kinds': fast calls
                np.ascontiguousarray(v[..., self._ind]))

    _q_independent = property(lambda self: np.r_[np.arange(7), 7 + self.model.independent])

    def regressor(self, q, qd, qdd, friction=False, armature=None):
        """G_v^T Y_all: the floating regressor of every body (the base's ten columns first)
        at the whole state, its rows reduced (the base's six their own), then the friction
        columns of the independent joints (zero in the base's rows)."""
        friction = _regressor.check_friction(friction)
        arm = _regressor.armature_on(self, armature)
        _, (q, qd, qdd), (qa, va, aa) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        Y = np.swapaxes(self._reduce(np.swapaxes(
            Floating.regressor(self, qa, va, aa, armature=arm), -1, -2)), -1, -2)
        if not friction:
            return Y
        J = _regressor.friction_columns(qd[..., 6:])
        J = np.concatenate([np.zeros(J.shape[:-2] + (6, J.shape[-1])), J], axis=-2)
        return np.concatenate([Y, J], axis=-1)

    def base_reaction(self, q, qd_joints):
        raise NotImplementedError("base_reaction with mimic joints is not available; "
                                  "solve with the blocks of mass_matrix(q)")

    def generalized_jacobian(self, q, link=None):
        raise NotImplementedError("generalized_jacobian with mimic joints is not available; "
                                  "compose it from jacobian(q, link) and mass_matrix(q)")


def kind_of(model):
    """The facade class ``model`` needs: the first that fits, read top to bottom."""
    if model.floating:                   # the base's six degrees of freedom join the joints'
        return (FloatingMimicRobot       # (q: n + 7, v: n + 6); no planar path there
                if model.has_mimic_joints else FloatingRobot)
    if model.has_mimic_joints:           # coordinates are the independent joints; the
        return MimicRobot                # reduction runs the full chain's general algorithms
    if planar_pack(model) is not None:   # every revolute axis parallel, prismatic ones in
        return PlanarRobot               # the plane: planar 3-vectors
    return Robot
