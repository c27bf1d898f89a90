"""The compiled core (numba): one module per algorithm, in joint frames.

    layout.py     the model as one array P (``pack``), its named columns
    data.py       Data: the named scratch arrays of one evaluation (on the call's stack)
    signatures.py the argument types, named; ``internal`` (one signature per algorithm)
    spatial.py    small helpers: sincos, joint transforms, frame changes of vectors/forces
    rnea.py       inverse dynamics (Newton-Euler)     rnea_lanes.py  the same, B samples in SIMD lanes
    crba.py       mass matrix (composite rigid bodies)
    cholesky.py   M x = b                             aba.py         articulated bodies
    forward.py    forward dynamics (Cholesky or ABA)  flags.py       the entry points' flags
    planar.py     Newton-Euler and composite bodies of a planar chain in planar 3-vectors
    planar_lanes.py  the same, B samples in SIMD lanes

Each algorithm is the same as its NumPy reference in ``algorithms/`` (same frames and
symbols; docs/conventions.md). Entry points take the packed model ``P`` and float64
arrays, write into ``out`` and return a status: 0 ok, 1 a NaN/Inf in an input (the
caller then raises the reference's ValueError naming it), 2 a wrong length, 3 arguments
of other types (single-state entry points; see ``_Kernels``). Batch
kernels take (N, n) inputs, or (1, n) to broadcast one row, and release the GIL so that
``Robot`` can split a large batch over the cores.

``K`` compiles each entry point on first use with its explicit signature and
``cache=True``, after the typed algorithms it calls (seconds once per machine; loading
from the numba cache in ``__pycache__`` takes milliseconds); importing compiles nothing;
``python -m serial_dynamics.precompile`` fills the cache. No fast-math
flag anywhere: IEEE arithmetic, so results do not depend on what was compiled or
inlined where (bitwise the same in every process, whatever the cache holds).
"""
from numba import njit

from . import crba, derivatives, forward, planar, planar_lanes, regressor, rnea, rnea_lanes
from . import energy, floating
from .signatures import In2, Mat, Out2, Out3, Pm, Vec, compile_internal, i8

FD_CALLS = ("aba_core", "rnea_core", "crba_core", "cholesky_solve")   # the Cholesky route inlined

ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "rnea": (rnea.rnea, i8(Pm, Vec, Vec, Vec, i8, Vec), False, ()),
    "rnea_wrench": (rnea.rnea_wrench, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, ("rnea_core",)),
    "crba": (crba.crba, i8(Pm, Vec, Mat), False, ()),
    "fd": (forward.fd, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, FD_CALLS),
    "rnea_batch": (rnea_lanes.rnea_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True, ("rnea_block",)),
    "crba_batch": (crba.crba_batch, i8(Pm, In2, Out3), True, ("crba_core",)),
    "fd_batch": (forward.fd_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True, FD_CALLS),
    **planar.ENTRY_POINTS,   # the planar fast path (planar 3-vectors; Robot.is_planar),
    **planar_lanes.ENTRY_POINTS,   # and its batches
    **derivatives.ENTRY_POINTS,    # derivatives of inverse and forward dynamics
    **regressor.ENTRY_POINTS,      # the torque regressor
    **energy.ENTRY_POINTS,         # dT/dq and the symplectic Euler step
    **floating.ENTRY_POINTS,       # a free-floating base on the instantaneous chain
}
SINGLE_STATE = ("rnea", "rnea_wrench", "crba", "fd", "planar_rnea", "planar_rnea_wrench",
                "planar_crba", "regressor", "rnea_derivatives", "fd_derivatives")
SINGLE_STATE += floating.SINGLE_STATE
OTHER_TYPES = 3      # what a single-state entry point returns for arguments of other types


def _other_types(*args, **kwargs):
    return lambda *a, **k: OTHER_TYPES


class _Kernels:
    """Compiled entry points, built (compiled or loaded from the cache) on first use.

    Batch entry points accept their signature only. A single-state entry point has one
    exact signature -- C-contiguous, writable float64 arrays, what a caller usually has --
    which numba's dispatcher matches in C (~70 ns); for any other argument types (a list,
    a batch, another dtype or layout, a read-only array) it returns ``OTHER_TYPES``
    instead of compiling a new version or raising: numba calls the dispatcher's
    ``_compile_for_args`` for argument types it has no version for, and that is replaced
    here by a function returning a function returning the status. ``Robot`` then takes
    its general path. (No exception is raised or caught to choose the path.)"""

    def __getattr__(self, name):
        if name not in ENTRY_POINTS:
            raise AttributeError(name)
        func, sig, nogil, calls = ENTRY_POINTS[name]
        compile_internal(calls)          # the typed algorithms it calls, first
        if name in SINGLE_STATE:
            kernel = njit(cache=True, nogil=nogil)(func)
            kernel.compile(sig)
            kernel._compile_for_args = _other_types
        else:
            kernel = njit([sig], cache=True, nogil=nogil)(func)
        setattr(self, name, kernel)
        return kernel

    def load_all(self, names=None):
        """Compile or load ``names`` (default: every entry point)."""
        for name in ENTRY_POINTS if names is None else names:
            getattr(self, name)
        return self


K = _Kernels()
