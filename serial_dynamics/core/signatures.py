"""numba types of the compiled functions' arguments, named once.

Every core function has one explicit signature, so that it compiles once whatever
calls it (a C-contiguous or a strided, writable or read-only input converts to the 'A'
layout): one machine-code version of each algorithm, and a short cold start. The Data
arrays are the package's own, C-contiguous; inputs and results are the caller's, any
layout.
"""
from functools import partial

from numba import njit, types

# a core function, called only from compiled code: no CPython or C wrapper to build
# (they would be compiled for every one of them, at import, for nothing)
internal = partial(njit, cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)

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
