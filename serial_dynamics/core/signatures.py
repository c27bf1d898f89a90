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
_TYPED = []          # (dispatcher, signature) of the internal functions with one
_LOCK = threading.Lock()


def internal(sig_or_func):
    """A core function, called only from compiled code (no CPython or C wrapper to
    build). ``@internal``: specialized on use, for small helpers; ``@internal(sig)``: one
    signature, compiled by ``compile_internal`` and then fixed (calls convert to it)."""
    if callable(sig_or_func) and not hasattr(sig_or_func, "args"):
        return njit(**_OPTIONS)(sig_or_func)

    def decorate(func):
        disp = njit(**_OPTIONS)(func)
        _TYPED.append((disp, sig_or_func))
        return disp
    return decorate


def compile_internal():
    """Compile (or load from the cache) every internal function's one signature, then
    forbid other specializations, in the order they were defined (callees before their
    callers, so that a caller is typed against its callees' one signature). Idempotent;
    threads that come together wait for the first."""
    with _LOCK:
        for disp, sig in _TYPED:
            disp.compile(sig)
            disp.disable_compile()
        _TYPED.clear()

f8, i8 = types.float64, types.int64
Pm = types.Array(f8, 2, "C")                     # the packed model P (never written)
In1 = types.Array(f8, 1, "A", readonly=True)     # a state vector (q, qd, qdd, tau, w)
In2 = types.Array(f8, 2, "A", readonly=True)     # a batch of them
Out1 = types.Array(f8, 1, "A")                   # a result vector
Out2 = types.Array(f8, 2, "A")                   # a result matrix
Out3 = types.Array(f8, 3, "A")
D1 = types.Array(f8, 1, "C")                     # Data (core/data.py): always C-contiguous,
D2 = types.Array(f8, 2, "C")                     # which keeps the many scratch accesses
D3 = types.Array(f8, 3, "C")                     # cheap (no run-time strides)
