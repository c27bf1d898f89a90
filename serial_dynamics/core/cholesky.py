"""Cholesky factor and solve, compiled: M x = b for a symmetric positive-definite M
(Featherstone 2008, Sec. 6.3: the factor of the mass matrix, then two triangular solves)."""
import math

from numba import types

from .signatures import D1, D2, Out1, internal


@internal(types.void(D2, D1, Out1))
def cholesky_solve(L, b, x):
    """Solve M x = b: L (n, n) holds M on entry and its factor M = L L^T after."""
    n = b.shape[0]
    for j in range(n):                   # M = L L^T, column by column
        s = L[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = L[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    for i in range(n):                   # L y = b
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):       # L^T x = y
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]
