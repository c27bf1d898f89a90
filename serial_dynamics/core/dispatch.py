"""Dispatch: the compiled entry points (``ENTRY_POINTS``), ``K`` that builds them on first
use, and the status codes they return.

``K.rnea`` etc. (one attribute of ``_Kernels`` per entry point, listed below) compiles its
entry point on first use with its explicit signature and ``cache=True``, after the typed
algorithms it calls (seconds once per machine; loading from the numba cache takes
milliseconds; ``core/cache.py`` says where it lies); importing compiles nothing;
``python -m serial_dynamics.precompile`` fills the cache. Entry points take the packed model
``P`` and float64 arrays, write into ``out`` and return a status (``status.py``: OK,
NOT_FINITE, BAD_LENGTH, OTHER_TYPES, NOT_CONVERGED). Batch kernels take (N, n) inputs, or
(1, n) to broadcast one row, and release the GIL so that ``Robot`` can split a large batch
over the cores.

A single-state entry point (``SINGLE_STATE``) has one exact signature -- C-contiguous,
writable float64 arrays and int64s, what a caller usually has -- and is built by
``cabi.entry``: a ``numba.cfunc`` wrapper of the njit kernel with one plain C ABI, called
by ``_fastcall.Entry`` after it checks the arguments' types in C (a fraction of numba's
dispatcher's price per array: docs/speed.md, bench/bench_call_cost.py). Any other
arguments (a list, a batch, another dtype or layout, a read-only array) get OTHER_TYPES
back without numba being called, and ``Robot`` takes its general path (no exception is
raised or caught to choose the path). Only numba's documented interfaces are used:
``njit``, ``cfunc`` and its ``.address``, ``carray``, ``NUMBA_CACHE_DIR``;
``NUMBA_SUPPORTED`` is the range of numba releases the tests have run on (setup.py pins
it). Without the extension (a build without a C compiler) or with
``SERIAL_DYNAMICS_FASTCALL=0`` in the environment, ``cabi.Entry`` makes the same check in
Python and calls the njit kernel (the same bits, slower by the check).
"""
from numba import njit

from . import crba, crba_lanes, derivatives, derivatives_lanes, energy, floating, forward, kinematics
from . import floating_derivatives
from . import mimic, planar, planar_lanes
from . import regressor
from . import rnea, rnea_lanes, tree, tree_derivatives, tree_derivatives_lanes
from .cabi import FASTCALL, entry  # noqa: F401 (FASTCALL re-exported)
from .cache import in_folder
from .signatures import In2, Mat, Out2, Out3, Pm, Vec, compile_internal, i8
from .status import BAD_LENGTH, NOT_CONVERGED, NOT_FINITE, OK, OTHER_TYPES   # noqa: F401 (re-exported)

NUMBA_SUPPORTED = ">=0.59,<0.69"   # the numba releases the tests have run on (setup.py pins it)

FD_CALLS = ("aba_core", "cholesky_solve", "cholesky_core", "fd_block")
FLOATING_FD_CALLS = ("floating_aba_core", "cholesky_solve", "floating_cholesky_core",
                     "floating_fd_block")

ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "rnea": (rnea.rnea, i8(Pm, Vec, Vec, Vec, i8, Vec), False, ()),
    "rnea_wrench": (rnea.rnea_wrench, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, ("rnea_core",)),
    "crba": (crba.crba, i8(Pm, Vec, Mat), False, ()),
    "fd": (forward.fd, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, FD_CALLS),
    "rnea_batch": (rnea_lanes.rnea_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True, ("rnea_block",)),
    "crba_batch": (crba_lanes.crba_batch, i8(Pm, In2, Out3), True, ("crba_block", "crba_core")),
    "fd_batch": (forward.fd_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True,
                 FD_CALLS + ("aba_block",)),
    # a floating base's virtual chain (its free-flyer root; their own kernels, so that a fixed
    # base's cold start compiles none of them)
    "floating_rnea_batch": (rnea_lanes.floating_rnea_batch, i8(Pm, In2, In2, In2, In2, i8, Out2),
                            True, ("floating_rnea_block",)),
    "floating_crba_batch": (crba_lanes.floating_crba_batch, i8(Pm, In2, Out3), True,
                            ("floating_crba_block", "floating_crba_core")),
    "floating_fd_batch": (forward.floating_fd_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True,
                          FLOATING_FD_CALLS + ("floating_aba_block",)),
    **planar.ENTRY_POINTS,   # the planar fast path (planar 3-vectors; Robot.is_planar),
    **planar_lanes.ENTRY_POINTS,   # and its batches
    **derivatives.ENTRY_POINTS,    # derivatives of inverse and forward dynamics
    **derivatives_lanes.ENTRY_POINTS,   # and of inverse dynamics over a batch, in SIMD lanes
    **regressor.ENTRY_POINTS,      # the torque regressor
    **energy.ENTRY_POINTS,         # dT/dq and the symplectic Euler step
    **floating.ENTRY_POINTS,       # a free-floating base on the instantaneous chain
    **floating_derivatives.ENTRY_POINTS,   # and its derivatives (chains and trees)
    **tree.ENTRY_POINTS,           # kinematic trees on the parent array
    **tree_derivatives.ENTRY_POINTS,   # and their derivatives,
    **tree_derivatives_lanes.ENTRY_POINTS,   # over a batch in SIMD lanes
    **mimic.ENTRY_POINTS,          # the reduced system of mimic joints, on any of the above
    **kinematics.ENTRY_POINTS,     # frames, Jacobians, center of mass, momentum (any robot)
}
SINGLE_STATE = ("rnea", "rnea_wrench", "crba", "fd", "planar_rnea", "planar_rnea_wrench",
                "planar_crba", "regressor", "floating_regressor", "rnea_derivatives",
                "fd_derivatives",
                *floating.SINGLE_STATE, *floating_derivatives.SINGLE_STATE, *tree.SINGLE_STATE,
                *tree_derivatives.SINGLE_STATE, *mimic.SINGLE_STATE, *kinematics.SINGLE_STATE)


def build(name):
    """Compile (or load from the cache) entry point ``name``, after the typed algorithms it
    calls; a single-state one is ``cabi.entry``'s (its cfunc wrapper called from C)."""
    func, sig, nogil, calls = ENTRY_POINTS[name]
    compile_internal(calls)
    with in_folder("core"):
        if name in SINGLE_STATE:
            return entry(name, func, sig, nogil)
        return njit([sig], cache=True, nogil=nogil)(func)


class _EntryPoint:
    """An attribute of ``K``: builds its entry point on first access and stores it in the
    instance, whose plain attribute lookup finds it from then on (a non-data descriptor)."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        kernel = build(self.name)
        obj.__dict__[self.name] = kernel
        return kernel


class _Kernels:
    """The compiled entry points, built (compiled or loaded from the cache) on first use."""
    # single state: inverse dynamics, mass matrix, forward dynamics (module dispatch doc)
    rnea = _EntryPoint()
    rnea_wrench = _EntryPoint()
    crba = _EntryPoint()
    fd = _EntryPoint()
    # batches of N states
    rnea_batch = _EntryPoint()
    crba_batch = _EntryPoint()
    fd_batch = _EntryPoint()
    # the planar fast path (planar.py, planar_lanes.py)
    planar_rnea = _EntryPoint()
    planar_rnea_wrench = _EntryPoint()
    planar_crba = _EntryPoint()
    planar_rnea_batch = _EntryPoint()
    planar_crba_batch = _EntryPoint()
    # derivatives (derivatives.py), the regressor (regressor.py), energy (energy.py)
    rnea_derivatives = _EntryPoint()
    fd_derivatives = _EntryPoint()
    rnea_derivatives_batch = _EntryPoint()
    fd_derivatives_batch = _EntryPoint()
    regressor = _EntryPoint()
    regressor_batch = _EntryPoint()
    floating_regressor = _EntryPoint()
    floating_regressor_batch = _EntryPoint()
    kinetic_energy_gradient = _EntryPoint()
    symplectic_euler = _EntryPoint()
    # a free-floating base on the instantaneous chain (floating.py)
    floating_rnea = _EntryPoint()
    floating_rnea_wrench = _EntryPoint()
    floating_fd = _EntryPoint()
    floating_crba = _EntryPoint()
    floating_rows = _EntryPoint()
    floating_rnea_batch = _EntryPoint()
    floating_crba_batch = _EntryPoint()
    floating_fd_batch = _EntryPoint()
    floating_accelerations = _EntryPoint()
    floating_rnea_derivatives = _EntryPoint()      # floating_derivatives.py
    floating_fd_derivatives = _EntryPoint()
    floating_rnea_derivatives_batch = _EntryPoint()
    floating_fd_derivatives_batch = _EntryPoint()
    floating_tree_rnea_derivatives = _EntryPoint()
    floating_tree_fd_derivatives = _EntryPoint()
    floating_tree_rnea_derivatives_batch = _EntryPoint()
    floating_tree_fd_derivatives_batch = _EntryPoint()
    # kinematic trees (tree.py)
    tree_rnea = _EntryPoint()
    tree_rnea_wrench = _EntryPoint()
    tree_crba = _EntryPoint()
    tree_fd = _EntryPoint()
    tree_rnea_batch = _EntryPoint()
    tree_crba_batch = _EntryPoint()
    tree_fd_batch = _EntryPoint()
    floating_tree_rnea = _EntryPoint()
    floating_tree_rnea_wrench = _EntryPoint()
    floating_tree_fd = _EntryPoint()
    floating_tree_crba = _EntryPoint()
    tree_kinetic_energy_gradient = _EntryPoint()
    tree_rnea_derivatives = _EntryPoint()
    tree_fd_derivatives = _EntryPoint()
    tree_rnea_derivatives_batch = _EntryPoint()
    tree_fd_derivatives_batch = _EntryPoint()
    # mimic joints (mimic.py): the reduced system, on a chain's or a tree's kernels
    mimic_rnea = _EntryPoint()
    mimic_crba = _EntryPoint()
    mimic_fd = _EntryPoint()
    mimic_rnea_batch = _EntryPoint()
    mimic_crba_batch = _EntryPoint()
    mimic_fd_batch = _EntryPoint()
    # kinematics (kinematics.py): one kernel each for chains and trees, batches of states
    frame_pose = _EntryPoint()
    frame_jacobian = _EntryPoint()
    frame_pose_one = _EntryPoint()        # one state, without the batch's views
    frame_jacobian_one = _EntryPoint()
    mass_moment = _EntryPoint()
    centroidal = _EntryPoint()
    coriolis = _EntryPoint()
    frame_acceleration = _EntryPoint()

    def load_all(self, names=None):
        """Compile or load ``names`` (default: every entry point)."""
        for name in ENTRY_POINTS if names is None else names:
            getattr(self, name)
        return self


_ATTRIBUTES = {k for k, v in vars(_Kernels).items() if isinstance(v, _EntryPoint)}
if _ATTRIBUTES != set(ENTRY_POINTS):      # a new entry point needs its attribute, and back
    raise RuntimeError(f"core.dispatch: K's attributes and ENTRY_POINTS differ: "
                       f"{sorted(_ATTRIBUTES ^ set(ENTRY_POINTS))}")

K = _Kernels()


class TreeTable:
    """The kernels ``Robot`` calls, for a tree: the same names and signatures as K's chain
    kernels (rnea, rnea_wrench, crba, fd and their batches; a floating base's floating_rnea,
    floating_fd, floating_crba), bound to ``tree.py``'s; the floating base's conversions
    (floating_rows, floating_accelerations) are K's own."""
    NAMES = {"rnea": "tree_rnea", "rnea_wrench": "tree_rnea_wrench", "crba": "tree_crba",
             "fd": "tree_fd", "rnea_batch": "tree_rnea_batch", "crba_batch": "tree_crba_batch",
             "fd_batch": "tree_fd_batch", "floating_rnea": "floating_tree_rnea",
             "floating_rnea_wrench": "floating_tree_rnea_wrench",
             "floating_fd": "floating_tree_fd", "floating_crba": "floating_tree_crba",
             "floating_rows": "floating_rows", "floating_accelerations": "floating_accelerations",
             "floating_rnea_batch": "tree_rnea_batch", "floating_crba_batch": "tree_crba_batch",
             "floating_fd_batch": "tree_fd_batch",
             "kinetic_energy_gradient": "tree_kinetic_energy_gradient",
             "rnea_derivatives": "tree_rnea_derivatives", "fd_derivatives": "tree_fd_derivatives",
             "rnea_derivatives_batch": "tree_rnea_derivatives_batch",
             "fd_derivatives_batch": "tree_fd_derivatives_batch",
             "floating_rnea_derivatives": "floating_tree_rnea_derivatives",
             "floating_fd_derivatives": "floating_tree_fd_derivatives",
             "floating_rnea_derivatives_batch": "floating_tree_rnea_derivatives_batch",
             "floating_fd_derivatives_batch": "floating_tree_fd_derivatives_batch",
             "mimic_rnea": "mimic_rnea", "mimic_crba": "mimic_crba", "mimic_fd": "mimic_fd",
             "mimic_rnea_batch": "mimic_rnea_batch", "mimic_crba_batch": "mimic_crba_batch",
             "mimic_fd_batch": "mimic_fd_batch"}

    def __getattr__(self, name):
        if name not in self.NAMES:
            raise AttributeError(name)
        kernel = getattr(K, self.NAMES[name])
        setattr(self, name, kernel)              # found by plain lookup from then on
        return kernel


TREE = TreeTable()
