"""The contacts' small dense linear algebra: M's Cholesky factor inverted, M = C C^T with
C^-1 lower triangular (LAPACK's dpotrf, then dtrtri), so that every solve with M and the
Delassus matrix G = J M^-1 J^T = Y^T Y (Y = C^-1 J^T) is a matrix product.

Why not triangular solves with many right-hand sides (``cho_solve(M, J.T)``,
``solve_triangular``)? OpenBLAS runs those (trsm) on every core even at 18 x 12, and on a
shared, loaded machine the threads' hand-offs cost milliseconds where the work is a few
microseconds (measured 2026-12-07 on this project's 2-core machine: docs/contacts.md);
dpotrf and dtrtri at these sizes, and the products, stay on the calling thread.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf, dtrtri


def inverse_factor(M, what="the mass matrix"):
    """C^-1 (lower triangular) with ``M`` = C C^T, or a ValueError naming ``what`` where M
    is not positive definite (a NaN in it, or a singular M)."""
    C, info = dpotrf(M, lower=1, clean=1)
    if info == 0:
        Ci, info = dtrtri(C, lower=1)
        if info == 0:
            return Ci
    raise ValueError(f"{what} is not positive definite here (LAPACK info {info}); check the "
                     "model's inertias and the state")


def firm_factor(G, share):
    """G's lower Cholesky factor L (G = L L^T, LAPACK's dpotrf) where G is far from singular:
    every pivot^2 at least ``share`` of G's largest diagonal entry; else None (G singular,
    nearly so, or not positive definite)."""
    L, info = dpotrf(G, lower=1)
    if info != 0 or float(L.diagonal().min()) ** 2 < share * max(float(G.diagonal().max()),
                                                                  np.finfo(float).tiny):
        return None
    return L
