"""numba types of the compiled functions' arguments, named once, and ``internal``.

Every core algorithm has one signature, so that it compiles once whatever calls it (a
C-contiguous or a strided, writable or read-only input converts to the 'A' layout): one
machine-code version of each algorithm, and a short cold start. The Data arrays are the
package's own, C-contiguous; inputs and results are the caller's, any layout.

The signatures are compiled when the first entry point is (``compile_internal``, called
by ``core.K``), not at import: importing the package compiles nothing.
"""
import threading

from numba import njit, types

_OPTIONS = dict(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
_TYPED = {}          # name: (dispatcher, signature, typed callees) of those with one
_DONE = set()        # the names compiled and fixed
_LOCK = threading.Lock()


def internal(sig_or_func, calls=()):
    """A core function, called only from compiled code (no CPython or C wrapper to
    build). ``@internal``: specialized on use, for small helpers; ``@internal(sig,
    calls=names)``: one signature, compiled by ``compile_internal`` after the typed
    functions it calls, and then fixed (calls convert to it)."""
    if callable(sig_or_func) and not hasattr(sig_or_func, "args"):
        return njit(**_OPTIONS)(sig_or_func)

    def decorate(func):
        disp = njit(**_OPTIONS)(func)
        _TYPED[func.__name__] = (disp, sig_or_func, tuple(calls))
        return disp
    return decorate


def compile_internal(names):
    """Compile (or load from the cache) the one signature of each internal function in
    ``names`` -- after the ones it calls, so that it is typed against theirs -- then
    forbid it other specializations. Idempotent; threads wait for each other."""
    with _LOCK:
        for name in names:
            _compile(name)


def _compile(name):
    if name in _DONE:
        return
    disp, sig, calls = _TYPED[name]
    for callee in calls:
        _compile(callee)
    disp.compile(sig)
    disp.disable_compile()
    _DONE.add(name)

f8, i8 = types.float64, types.int64
Pm = types.Array(f8, 2, "C")                     # the packed model P (never written)
Vec = types.Array(f8, 1, "C")                    # single-state entry points: exactly the
Mat = types.Array(f8, 2, "C")                    # arrays a caller usually has (core.K)
In1 = types.Array(f8, 1, "A", readonly=True)     # a state vector (q, qd, qdd, tau, w)
In2 = types.Array(f8, 2, "A", readonly=True)     # a batch of them
Out1 = types.Array(f8, 1, "A")                   # a result vector
Out2 = types.Array(f8, 2, "A")                   # a result matrix
Out3 = types.Array(f8, 3, "A")
D1 = types.Array(f8, 1, "C")                     # Data (core/data.py): always C-contiguous,
D2 = types.Array(f8, 2, "C")                     # which keeps the many scratch accesses
D3 = types.Array(f8, 3, "C")                     # cheap (no run-time strides)


# A batch argument (In2) has N rows, or one row that stands for every state of the batch.
@njit(cache=True, inline="always")
def row(x, k):
    """Row k of a batch argument: its own row, or its one row broadcast over the batch."""
    return x[min(k, x.shape[0] - 1)]


@njit(cache=True, inline="always")
def rows_fit(N, width, arrays):
    """Whether each batch argument in the tuple ``arrays`` has ``width`` columns and N rows
    or one."""
    for x in arrays:
        if x.shape[1] != width or (x.shape[0] != N and x.shape[0] != 1):
            return False
    return True
