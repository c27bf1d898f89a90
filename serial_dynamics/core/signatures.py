"""numba types of the compiled functions' arguments, named once.

Every core function has one explicit signature, so that it compiles once whatever
calls it (a C-contiguous or a strided, writable or read-only array converts to the 'A'
layout): one machine-code version of each algorithm, and a short cold start.
"""
from numba import types

f8, i8 = types.float64, types.int64
Pm = types.Array(f8, 2, "C")                     # the packed model P (never written)
In1 = types.Array(f8, 1, "A", readonly=True)     # a state vector (q, qd, qdd, tau, w)
In2 = types.Array(f8, 2, "A", readonly=True)     # a batch of them
Out1 = types.Array(f8, 1, "A")                   # a result / scratch vector
Out2 = types.Array(f8, 2, "A")                   # a result / scratch matrix
Out3 = types.Array(f8, 3, "A")
