"""``Robot``: the friendly facade over a ``Model`` and the algorithms.

It holds the immutable model and the dissipation model, checks inputs, and calls the
algorithm functions. Every state argument accepts ``(n,)`` or a batch ``(N, n)``.

Backends: ``"numba"`` (default) runs inverse dynamics, the mass matrix, bias and gravity
torques and forward dynamics (Cholesky and articulated-body routes) through the compiled
kernels of ``kernels.py``; ``"numpy"`` runs the readable reference implementations of
``algorithms/`` (the tests compare the two). Choose per robot with
``Robot(model, backend="numpy")`` or for the process with the environment variable
``SERIAL_DYNAMICS_BACKEND=numpy``. Everything else (Coriolis matrix, kinematics,
energies, forward dynamics by QR) always runs the reference code.

The single-state path is kept lean: a float64 C-contiguous (n,) state goes straight to
the compiled kernel, which checks lengths and NaN/Inf itself; anything else (lists,
batches, other dtypes, errors) takes the general path, which validates like the
reference (same ValueError messages) and calls the batch kernels.
"""
from __future__ import annotations

import os
import threading

import numpy as np

from .algorithms import aba, energy, forward, kinematics, mass_matrix, noc, rnea
from .algorithms._batch import as_batch
from .dissipation import Dissipation
from .model import Model

_empty = np.empty                          # one global lookup on the fast paths
_NOT_FAST = (TypeError, AttributeError)    # inputs the single-state fast path does not take
BACKENDS = ("numba", "numpy")
FD_METHODS = ("auto", "cholesky", "aba", "qr")
_QD, _QDD, _W, _ABA = 1, 2, 4, 8          # kernel flags (kernels.F_QD, F_QDD, F_W, F_ABA)
_FD_FLAGS = {"cholesky": _QD, "aba": _QD | _ABA}


class Robot:
    """Dynamics of one serial chain. Build it with ``serial_dynamics.load_urdf``."""

    def __init__(self, model: Model, dissipation: Dissipation | None = None, backend=None):
        self.model = model
        self._dissipation = Dissipation.from_model(model) if dissipation is None else dissipation
        backend = backend or os.environ.get("SERIAL_DYNAMICS_BACKEND", "numba")
        if backend not in BACKENDS:
            raise ValueError(f"backend {backend!r} unknown; use one of {BACKENDS}")
        self._backend = backend
        self._n, self._nn = model.dof, (model.dof, model.dof)
        # forward_dynamics(method="auto"): articulated bodies from aba.CROSSOVER joints on
        self._fd_auto = _FD_FLAGS["aba" if model.dof >= aba.CROSSOVER else "cholesky"]
        # Single-state fast paths: compiled kernels (set up on first call), or, with the
        # reference backend, stand-ins that send every call to the general path.
        self._k = None
        self._rnea = self._crba = self._fd = _no_fast_path
        self._PW, self._wrow = None, np.zeros(6)
        self._wrench_lock = threading.Lock()
        if backend == "numba":
            from . import kernels
            self._k = kernels.K                  # all entry points, compiled on first use
            self._PW = kernels.pack(model)       # packed model + scratch of single calls
            self._wrow = kernels.wrench_row(self._PW)
            self._w1 = np.zeros((1, 6))          # placeholder when there is no wrench
            for attr, name in (("_rnea", "rnea"), ("_crba", "crba"), ("_fd", "fd")):
                setattr(self, attr, _FirstCall(self, attr, name))

    backend = property(lambda self: self._backend, doc='"numba" (compiled) or "numpy" (reference)')

    # ------------------------------------------------------------- description
    dof = property(lambda self: self.model.dof)
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

    @property
    def dissipation(self) -> Dissipation:
        """Joint friction model (defaults from URDF <dynamics>); replace it with
        ``robot.dissipation = robot.dissipation.override(coulomb={...})``."""
        return self._dissipation

    @dissipation.setter
    def dissipation(self, value: Dissipation):
        if not isinstance(value, Dissipation) or value.joint_names != self.model.joint_names:
            raise ValueError("dissipation must be a serial_dynamics.Dissipation for the joints "
                             f"{self.joint_names}")
        self._dissipation = value

    def __repr__(self):
        return (f"Robot({self.model.name!r}, dof={self.dof}, {self.base_link!r} -> "
                f"{self.tip_link!r}, joints={self.joint_names})")

    # ------------------------------------------------------------- dynamics
    # Each method first tries the single-state fast path: a float64 C-contiguous (n,) state
    # goes straight to the kernel, which checks lengths and NaN/Inf and returns 0 on
    # success. Anything else -- a batch (caught by the ndim test: letting numba reject it
    # costs ~65 us), other types (TypeError from the kernel's signature, AttributeError for
    # lists), a bad value, the reference backend -- takes the general path, which validates
    # like the reference and raises its ValueError.
    # ``out``: an array of the result's shape (float64, writable) to write the result into
    # instead of a new one, as NumPy's out= (a 1 kHz loop then allocates nothing); returned.
    # After an error its contents are undefined.
    def inverse_dynamics(self, q, qd, qdd, wrench=None, out=None):
        """tau = M(q) qdd + b(q, qd) - J^T w  (rigid body; no friction). N m / N."""
        o = _empty(self._n) if out is None else out
        try:
            if q.ndim == 1 and (self._rnea(self._PW, q, qd, qdd, 3, o) if wrench is None else
                                self._with_wrench(self._rnea, wrench, q, qd, qdd, 3, o)) == 0:
                return o
        except _NOT_FAST:
            pass
        return _into(out, self._rnea_general((("q", q), ("qd", qd), ("qdd", qdd)), wrench))

    def mass_matrix(self, q, out=None):
        """M(q), the generalized inertia matrix."""
        o = _empty(self._nn) if out is None else out
        try:
            if q.ndim == 1 and self._crba(self._PW, q, o) == 0:
                return o
        except _NOT_FAST:
            pass
        if self._k is None:
            return _into(out, mass_matrix.mass_matrix(self.model, q))
        single, (q,) = as_batch(self.model, ("q", q))
        q = _rows(q)
        M = np.empty((q.shape[0], self._n, self._n))
        self._k.crba_batch(self._PW, q, M)
        return _into(out, M[0] if single else M)

    def bias_torques(self, q, qd, wrench=None, out=None):
        """b(q, qd) - J^T w = C(q, qd) qd + g(q) - J^T w."""
        o = _empty(self._n) if out is None else out
        try:
            if q.ndim == 1 and (self._rnea(self._PW, q, qd, q, 1, o) if wrench is None else
                                self._with_wrench(self._rnea, wrench, q, qd, q, 1, o)) == 0:
                return o
        except _NOT_FAST:
            pass
        return _into(out, self._rnea_general((("q", q), ("qd", qd), ("qdd", None)), wrench))

    def gravity_torques(self, q, out=None):
        """g(q): the torques that hold the chain still (the textbook's gamma is -g)."""
        o = _empty(self._n) if out is None else out
        try:
            if q.ndim == 1 and self._rnea(self._PW, q, q, q, 0, o) == 0:
                return o
        except _NOT_FAST:
            pass
        return _into(out, self._rnea_general((("q", q), ("qd", None), ("qdd", None)), None))

    def coriolis_matrix(self, q, qd):
        """C(q, qd) from the natural orthogonal complement: C qd + g = b, Mdot - 2C skew."""
        return noc.coriolis_matrix(self.model, q, qd)

    def forward_dynamics(self, q, qd, tau, wrench=None, method="auto", out=None):
        """qdd for applied torques tau (rigid body). ``method``: "auto" (Cholesky for short
        chains, articulated bodies from ``algorithms.aba.CROSSOVER`` joints on),
        "cholesky", "aba" (O(n)) or "qr" (for ill-conditioned chains)."""
        flags = self._fd_auto if method == "auto" else _FD_FLAGS.get(method)
        if flags is not None:
            o = _empty(self._n) if out is None else out
            try:
                if q.ndim == 1 and (self._fd(self._PW, q, qd, tau, flags, o) if wrench is None
                                    else self._with_wrench(self._fd, wrench, q, qd, tau, flags,
                                                           o)) == 0:
                    return o
            except _NOT_FAST:
                pass
        if self._k is None or flags is None:
            if method == "auto":
                method = "aba" if flags & _ABA else "cholesky"
            if method == "aba":
                return _into(out, aba.forward_dynamics(self.model, q, qd, tau, wrench))
            if method not in FD_METHODS:
                raise ValueError(f"forward-dynamics method {method!r} unknown; use one of "
                                 f"{FD_METHODS}")
            return _into(out, forward.forward_dynamics(self.model, q, qd, tau, wrench, method))
        single, (q, qd, tau) = as_batch(self.model, ("q", q), ("qd", qd), ("tau", tau))
        w, flags = self._wrench_rows(wrench, q.shape[0], flags)
        q, qd, tau = _rows(q), _rows(qd), _rows(tau)
        qdd = np.empty((max(q.shape[0], qd.shape[0], tau.shape[0]), self._n))
        if self._k.fd_batch(self._PW, q, qd, tau, w, flags, qdd) != 0:
            raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
        return _into(out, qdd[0] if single else qdd)

    # general path: validate like the reference, then one batch kernel call
    def _rnea_general(self, named, wrench):
        if self._k is None:
            return rnea.inverse_dynamics(self.model, *(x for _, x in named), wrench)
        single, (q, qd, qdd) = as_batch(self.model, *named)   # raises the reference's ValueError
        N = q.shape[0]
        flags = (_QD if named[1][1] is not None else 0) | (_QDD if named[2][1] is not None else 0)
        q = _rows(q)
        qd = _rows(qd) if flags & _QD else q             # unused by the kernel when absent
        qdd = _rows(qdd) if flags & _QDD else q
        w, flags = self._wrench_rows(wrench, N, flags)
        out = np.empty((N, self._n))
        if self._k.rnea_batch(self._PW, q, qd, qdd, w, flags, out) != 0:
            raise ValueError("wrench has a NaN or Inf entry; give finite numbers")
        return out[0] if single else out

    def _with_wrench(self, kernel, wrench, a, b, c, flags, out):
        """Single-state kernel call with a tip wrench, which the kernel reads from the robot's
        scratch memory: written and used under a lock, so that two threads cannot swap
        wrenches in between (the kernels hold the GIL while they run, so calls without a
        wrench need no lock). Anything but a flat 6-vector raises TypeError (-> the
        general path)."""
        w = np.asarray(wrench, dtype=float)
        if w.shape != (6,) or self._PW is None:
            raise TypeError
        with self._wrench_lock:
            self._wrow[:] = w
            return kernel(self._PW, a, b, c, flags | _W, out)

    def _wrench_rows(self, wrench, N, flags):
        if wrench is None:
            return self._w1, flags
        return _rows(rnea._wrench_batch(wrench, N)), flags | _W

    def dissipation_torques(self, qd):
        """delta(qd) of the current dissipation model (oppose the motion)."""
        return self._dissipation.torque(qd)

    # ------------------------------------------------------------- kinematics, energy
    def forward_kinematics(self, q, link=None):
        """4x4 pose of ``link`` (default: the tip) in the base frame."""
        return kinematics.forward_kinematics(self.model, q, link)

    def jacobian(self, q, link=None):
        """6 x n geometric Jacobian of ``link``'s origin, [linear; angular], base frame."""
        return kinematics.jacobian(self.model, q, link)

    def kinetic_energy(self, q, qd):
        """T = 1/2 qd^T M(q) qd (J), with this robot's (compiled) mass matrix."""
        if self._k is None:
            return energy.kinetic_energy(self.model, q, qd)
        single, (q, qd) = as_batch(self.model, ("q", q), ("qd", qd))
        T = 0.5 * np.einsum("ni,nij,nj->n", qd, self.mass_matrix(_rows(q)), qd)
        return T[0] if single else T

    def potential_energy(self, q):
        return energy.potential_energy(self.model, q)

    def total_energy(self, q, qd):
        return self.kinetic_energy(q, qd) + self.potential_energy(q)

    def warmup(self):
        """Compile or load every fast path once (numba backend: every kernel of the Robot
        methods, single and batch, from the numba cache when it is warm), so that the first
        real call is fast.
        Nodes call this before they report ready. Returns self."""
        if self._k is not None:
            from .kernels import ROBOT_KERNELS
            self._k.load_all(ROBOT_KERNELS)
            self._rnea, self._crba, self._fd = self._k.rnea, self._k.crba, self._k.fd
        q = np.zeros(self.dof)
        qb = np.zeros((2, self.dof))
        w = np.zeros(6)
        for x in (q, qb):
            self.inverse_dynamics(x, x, x)
            self.inverse_dynamics(x, x, x, wrench=w)
            self.bias_torques(x, x)
            self.gravity_torques(x)
            self.mass_matrix(x)
            for method in ("cholesky", "aba"):
                self.forward_dynamics(x, x, x, method=method)
        return self

    def random_state(self, rng=None, batch=None, speed=1.0):
        """(q, qd) drawn uniformly within the joint limits (+-pi where unlimited) and
        velocities in +-speed; handy for tests and benchmarks."""
        rng = np.random.default_rng(rng)
        shape = (self.dof,) if batch is None else (batch, self.dof)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        return rng.uniform(lo, hi, shape), rng.uniform(-speed, speed, shape)


def _rows(a):
    """An (N, n) state or wrench as a C-contiguous array for the kernels; a row broadcast
    over the batch (stride 0) is passed as one row, which the kernels broadcast."""
    if a.strides[0] == 0:
        a = a[:1]
    return np.ascontiguousarray(a, dtype=float)


def _into(out, result):
    """``result``, or ``result`` written into the caller's ``out`` (checked) and ``out``."""
    if out is None:
        return result
    if not (isinstance(out, np.ndarray) and out.shape == result.shape
            and out.dtype == np.float64 and out.flags.writeable):
        got = (f"{out.dtype} array of shape {out.shape}" if isinstance(out, np.ndarray)
               else type(out).__name__)
        raise ValueError(f"out must be a writable float64 array of shape {result.shape} "
                         f"(the result's); got a {got}"
                         + ("" if not isinstance(out, np.ndarray) or out.flags.writeable
                            else " that is read-only"))
    out[...] = result
    return out


def _no_fast_path(*args):
    """Fast-path stand-in of the reference backend: every call takes the general path."""
    raise TypeError


class _FirstCall:
    """Stands in for a kernel until the first call, which compiles it (or loads it from
    the numba cache) and puts the compiled kernel itself on the robot."""

    def __init__(self, robot, attr, name):
        self.robot, self.attr, self.name = robot, attr, name

    def __call__(self, *args):
        kernel = getattr(self.robot._k, self.name)
        setattr(self.robot, self.attr, kernel)
        return kernel(*args)
