"""Dispatch: the compiled entry points (``ENTRY_POINTS``), ``K`` that builds them on first
use, the numba hook of the single-state ones, and the status codes they return.

``K.rnea`` etc. (one attribute of ``_Kernels`` per entry point, listed below) compiles its
entry point on first use with its explicit signature and ``cache=True``, after the typed
algorithms it calls (seconds once per machine; loading from the numba cache in
``__pycache__`` takes milliseconds); importing compiles nothing;
``python -m serial_dynamics.precompile`` fills the cache. Entry points take the packed model
``P`` and float64 arrays, write into ``out`` and return a status (``status.py``: OK,
NOT_FINITE, BAD_LENGTH, OTHER_TYPES, NOT_CONVERGED). Batch kernels take (N, n) inputs, or
(1, n) to broadcast one row, and release the GIL so that ``Robot`` can split a large batch
over the cores.

The hook: a single-state entry point has one exact signature -- C-contiguous, writable
float64 arrays, what a caller usually has -- which numba's dispatcher matches in C
(~70 ns). For argument types it has no version for, numba calls the dispatcher's
``_compile_for_args``; that internal method is replaced here by a function returning a
function returning OTHER_TYPES, so that any other arguments (a list, a batch, another dtype
or layout, a read-only array) get that status instead of a new compilation or an
exception, and ``Robot`` takes its general path. (No exception is raised or caught to
choose the path.) The hook depends on numba's internals: importing this module checks that
the method exists and raises an ImportError naming the numba version and the supported
range (``NUMBA_SUPPORTED``, the range setup.py pins) when it does not.

Past the dispatcher: a single-state entry point is an ``Entry`` of ``_fastcall.c``, which
checks in C that the arguments are of its one signature and then calls numba's compiled
function directly (20-40 ns for one to seven arrays, against the dispatcher's ~95 and
~33 for each further array, bench_call_cost.py); any other arguments, and a call whose function raised, go to the
dispatcher itself. The same machine code runs either way (the same bits). ``fast_entry``
makes one only where numba lays the function out as ``_fastcall.c`` assumes; without the
extension (a build without a C compiler) or with ``SERIAL_DYNAMICS_FASTCALL=0`` in the
environment every call goes through the dispatcher.
"""
import os

import numba
from numba import njit, types
from numba.core.dispatcher import Dispatcher

from . import crba, crba_lanes, derivatives, derivatives_lanes, energy, floating, forward, kinematics
from . import floating_derivatives
from . import mimic, planar, planar_lanes
from . import regressor
from . import rnea, rnea_lanes, tree, tree_derivatives, tree_derivatives_lanes
from .signatures import In2, Mat, Out2, Out3, Pm, Vec, compile_internal, f8, i8
from .status import BAD_LENGTH, NOT_CONVERGED, NOT_FINITE, OK, OTHER_TYPES   # noqa: F401 (re-exported)

try:
    from . import _fastcall
except ImportError:          # built without a C compiler: every call through the dispatcher
    _fastcall = None
FASTCALL = _fastcall is not None and os.environ.get("SERIAL_DYNAMICS_FASTCALL", "1") != "0"

NUMBA_SUPPORTED = ">=0.59,<0.69"   # the numba releases the tests have run on (setup.py pins it)
HOOK = "_compile_for_args"          # the dispatcher method the hook replaces

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


def check_hook(dispatcher_class=Dispatcher, version=numba.__version__):
    """Raise an ImportError unless numba's dispatcher has the method the hook replaces."""
    if not callable(getattr(dispatcher_class, HOOK, None)):
        raise ImportError(
            f"serial_dynamics cannot run on numba {version}: its dispatcher has no {HOOK}, "
            f"the internal method serial_dynamics.core.dispatch replaces so that a compiled "
            f"call with arguments of other types returns a status instead of compiling. The "
            f"supported numba releases are {NUMBA_SUPPORTED}: pip install 'numba{NUMBA_SUPPORTED}'.")


check_hook()


def _other_types(*args, **kwargs):
    return lambda *a, **k: OTHER_TYPES


def native_spec(kernel, sig):
    """``_fastcall.Entry``'s spec of ``kernel``'s one signature (per argument 1, 2 or 3: a
    C-contiguous writable float64 array of that ndim; i: an int64), or None where the
    extension is off or numba's compiled function is not laid out as ``_fastcall.c``
    assumes: int32 f(int64 *result, excinfo **, each array as meminfo, parent, nitems,
    itemsize, data, shape, strides; each int64 as itself)."""
    if not FASTCALL or sig.return_type != i8:
        return None
    spec, words = "", []
    for t in sig.args:
        if t == i8:
            spec, words = spec + "i", words + ["i64"]
        elif (isinstance(t, types.Array) and t.dtype == f8 and t.layout == "C" and t.mutable
              and t.aligned and 1 <= t.ndim <= 3):
            spec += str(t.ndim)
            words += ["i8*", "i8*", "i64", "i64", "double*"] + ["i64"] * (2 * t.ndim)
        else:
            return None
    try:
        cres = kernel.overloads[sig.args]
        conv = cres.target_context.call_conv
        fnty = conv.get_function_type(cres.fndesc.restype, cres.fndesc.argtypes)
    except (AttributeError, KeyError, TypeError):      # another numba: the dispatcher
        return None
    laid_out = ([str(fnty.return_type), str(fnty.args[0])] + [str(a) for a in fnty.args[2:]]
                == ["i32", "i64*"] + words)
    return spec if type(conv).__name__ == "CPUCallConv" and laid_out else None


def fast_entry(kernel, sig):
    """``kernel`` as a ``_fastcall.Entry`` (called past the dispatcher when the arguments
    are of ``sig``'s types), or ``kernel`` itself where ``native_spec`` is None."""
    spec = native_spec(kernel, sig)
    if spec is None:
        return kernel
    cres = kernel.overloads[sig.args]
    address = cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)
    return _fastcall.Entry(kernel, address, spec) if address else kernel


def build(name):
    """Compile (or load from the cache) entry point ``name``, after the typed algorithms it
    calls; a single-state one gets its one signature and the hook, and is called through
    ``fast_entry``."""
    func, sig, nogil, calls = ENTRY_POINTS[name]
    compile_internal(calls)
    if name in SINGLE_STATE:
        kernel = njit(cache=True, nogil=nogil)(func)
        kernel.compile(sig)
        setattr(kernel, HOOK, _other_types)
        kernel = fast_entry(kernel, sig)
    else:
        kernel = njit([sig], cache=True, nogil=nogil)(func)
    return kernel


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
