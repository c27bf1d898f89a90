"""Cholesky factor and solves, compiled: M x = b for a symmetric positive-definite M
(Featherstone 2008, Sec. 6.3: the factor of the mass matrix, then two triangular solves).

    cholesky_factor(L)             M = L L^T in place (lower triangle)
    cholesky_solve_factored(L, x)  x <- M^-1 x, one right-hand side
    cholesky_solve_matrix(L, X)    X <- M^-1 X, many (rows of X contiguous: SIMD lanes)
    cholesky_solve(L, b, x)        factor, then x = M^-1 b

and, for a kinematic tree, the factorization that keeps the zeros its branches put in M
(Featherstone 2005, "Efficient factorization of the joint-space inertia matrix for branched
kinematic trees"; RBDA 2008, Sec. 6.5, Tables 6.3 and 6.4):

    ltdl_factor(P, L)              M = L^T D L in place, L unit lower with M's sparsity
    ltdl_solve_factored(P, L, x)   x <- M^-1 x
    ltdl_solve_matrix(P, L, X)     X <- M^-1 X, many (each column's operations as one x's)
"""
import math

from numba import types

from .layout import PARENT
from .signatures import D1, D2, Out1, Pm, internal


@internal(types.void(D2))
def cholesky_factor(L):
    """M = L L^T in place: L (n, n) holds M on entry, its lower factor after."""
    n = L.shape[0]
    for j in range(n):                   # column by column
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


@internal(types.void(D2, Out1))
def cholesky_solve_factored(L, x):
    """x <- (L L^T)^-1 x: L y = x, then L^T x = y."""
    n = x.shape[0]
    for i in range(n):                   # L y = x
        s = x[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):       # L^T x = y
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@internal(types.void(D2, D2))
def cholesky_solve_matrix(L, X):
    """X <- (L L^T)^-1 X: L Y = X, then L^T X = Y, row by row, so that the innermost loop
    runs along the columns of X (contiguous: SIMD lanes)."""
    n = X.shape[0]
    m = X.shape[1]
    for i in range(n):                   # L Y = X
        for k in range(i):
            lik = L[i, k]
            for c in range(m):
                X[i, c] -= lik * X[k, c]
        d = 1.0 / L[i, i]
        for c in range(m):
            X[i, c] *= d
    for i in range(n - 1, -1, -1):       # L^T X = Y
        for k in range(i + 1, n):
            lki = L[k, i]
            for c in range(m):
                X[i, c] -= lki * X[k, c]
        d = 1.0 / L[i, i]
        for c in range(m):
            X[i, c] *= d


@internal(types.void(D2, D1, Out1), calls=("cholesky_factor", "cholesky_solve_factored"))
def cholesky_solve(L, b, x):
    """Solve M x = b: L (n, n) holds M on entry and its factor M = L L^T after."""
    cholesky_factor(L)
    for i in range(b.shape[0]):
        x[i] = b[i]
    cholesky_solve_factored(L, x)


# ------------------------------------------------------------------ trees: L^T D L
# M_ki != 0 only where i is k's ancestor (or k itself): with the bodies numbered parents
# first, eliminating from the leaves up creates no fill-in, and each column k touches only
# the pairs (i, j) of its ancestors: O(n d^2) for depth d, against O(n^3) dense.
@internal(types.void(Pm, D2))
def ltdl_factor(P, L):
    """M = L^T D L in place (RBDA Table 6.3): L (n, n) holds M's lower triangle on entry;
    after, D on the diagonal and L's ancestor entries below it (L_kk = 1, not stored).
    Entries off k's ancestors are neither read nor written."""
    n = L.shape[0]
    for k in range(n - 1, -1, -1):
        i = int(P[k, PARENT])
        while i >= 0:
            a = L[k, i] / L[k, k]                 # L_ki = M_ki / D_k
            j = i
            while j >= 0:                         # M_ij -= M_kj L_ki, j = i and its ancestors
                L[i, j] -= L[k, j] * a
                j = int(P[j, PARENT])
            L[k, i] = a
            i = int(P[i, PARENT])


@internal(types.void(Pm, D2, Out1))
def ltdl_solve_factored(P, L, x):
    """x <- (L^T D L)^-1 x (RBDA Table 6.4): L^T z = x from the leaves up, z <- D^-1 z,
    then L x = z from the root down."""
    n = x.shape[0]
    for i in range(n - 1, -1, -1):                # L^T z = x: z_i is final once its subtree is
        j = int(P[i, PARENT])
        while j >= 0:
            x[j] -= L[i, j] * x[i]
            j = int(P[j, PARENT])
    for i in range(n):
        x[i] /= L[i, i]
    for i in range(n):                            # L x = z: x_i after its ancestors
        j = int(P[i, PARENT])
        while j >= 0:
            x[i] -= L[i, j] * x[j]
            j = int(P[j, PARENT])


@internal(types.void(Pm, D2, D2))
def ltdl_solve_matrix(P, L, X):
    """X <- (L^T D L)^-1 X: ``ltdl_solve_factored`` on every column of X at once, row by
    row, so that the innermost loop runs along the columns of X (contiguous: SIMD lanes);
    each column gets the operations, in the order, of a solve of its own."""
    n, m = X.shape[0], X.shape[1]
    for i in range(n - 1, -1, -1):               # L^T Z = X
        j = int(P[i, PARENT])
        while j >= 0:
            lij = L[i, j]
            for c in range(m):
                X[j, c] -= lij * X[i, c]
            j = int(P[j, PARENT])
    for i in range(n):
        d = L[i, i]
        for c in range(m):
            X[i, c] /= d
    for i in range(n):                            # L X = Z
        j = int(P[i, PARENT])
        while j >= 0:
            lij = L[i, j]
            for c in range(m):
                X[i, c] -= lij * X[j, c]
            j = int(P[j, PARENT])
