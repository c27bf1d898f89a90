"""Forward dynamics of a batch by the Cholesky route, compiled: B samples at a time in SIMD
lanes (``forward.cholesky_core``'s steps, lane by lane).

b = Newton-Euler at zero acceleration (``rnea_lanes.newton_euler_lanes``), x = tau - b,
M by composite rigid bodies on the same transforms (``crba_lanes.composite_lanes``), then
M = L L^T and the two triangular solves with the loop over the lanes innermost. Each lane
does ``cholesky_core``'s operations in its order (``cholesky.cholesky_factor`` and
``cholesky_solve_factored``; sqrt and division are IEEE-exact in a vector as in a scalar),
so a sample's qdd is bitwise the same alone or in any batch.
"""
import math

from numba import njit

from . import flags as F
from .crba_lanes import composite_lanes, floating_composite_lanes
from .data import stack_empty
from .layout import LANES
from .rnea_lanes import (fixed_base, free_flyer_root, gather, lanes_scratch, newton_euler_lanes,
                         scatter, tau_minus_bias)
from .signatures import In2, Out2, Pm, i8, internal
from .status import NOT_FINITE, OK


@njit(cache=True, inline="always")
def cholesky_lanes(n, MB, XB, SB, nl):
    """x <- M^-1 x in every lane: MB (n * n, B) holds M's upper triangle (row i * n + j,
    j >= i), which is M's lower one read transposed; its slots receive L (L_ij, i >= j, in
    row j * n + i). XB (n, B) the right-hand sides, SB (1, B) scratch."""
    for j in range(n):                   # M = L L^T, column by column
        jj = j * n + j
        for b in range(nl):
            SB[0, b] = MB[jj, b]
        for k in range(j):
            jk = k * n + j
            for b in range(nl):
                SB[0, b] -= MB[jk, b] * MB[jk, b]
        for b in range(nl):
            MB[jj, b] = math.sqrt(SB[0, b])
        for i in range(j + 1, n):
            ij = j * n + i
            for b in range(nl):
                SB[0, b] = MB[ij, b]
            for k in range(j):
                ik, jk = k * n + i, k * n + j
                for b in range(nl):
                    SB[0, b] -= MB[ik, b] * MB[jk, b]
            for b in range(nl):
                MB[ij, b] = SB[0, b] / MB[jj, b]
    for i in range(n):                   # L y = x
        for k in range(i):
            ik = k * n + i
            for b in range(nl):
                XB[i, b] -= MB[ik, b] * XB[k, b]
        for b in range(nl):
            XB[i, b] = XB[i, b] / MB[i * n + i, b]
    for i in range(n - 1, -1, -1):       # L^T x = y
        for k in range(i + 1, n):
            ki = i * n + k
            for b in range(nl):
                XB[i, b] -= MB[ki, b] * XB[k, b]
        for b in range(nl):
            XB[i, b] = XB[i, b] / MB[i * n + i, b]


@njit(cache=True, inline="always")
def fd_scratch(n, L):
    """The scratch of ``fd_lanes_core`` for B = L lanes but M's slots (MB, n * n rows, which
    the caller makes): ``rnea_lanes.lanes_scratch``'s, then CB, SB."""
    return lanes_scratch(n, L) + (stack_empty((10, L)), stack_empty((1, L)))


@njit(cache=True, inline="always")
def fd_lanes_core(P, q, qd, tau, w, flags, k0, nl, QV, WB, TB, ST, RB, PB, FB, CB, MB, SB,
                  first, root, composite):
    """qdd of the samples k0 .. k0 + nl - 1 into TB (n, B), M's Cholesky factors left in MB
    (``cholesky_lanes``' layout). Returns whether every input was finite. ``first``, ``root``,
    ``composite``: a fixed base's (0, ``rnea_lanes.fixed_base``, ``composite_lanes``) or a
    floating base's virtual chain's (6, ``free_flyer_root``, ``floating_composite_lanes``)."""
    n = P.shape[0] - 1
    # b - J^T w: Newton-Euler at qdd = 0
    small, fin = gather(P, q, qd, q, w, flags & (F.QD | F.WRENCH | F.BASE), QV, WB, k0, nl)
    newton_euler_lanes(P, flags & (F.QD | F.WRENCH | F.BASE), QV, WB, RB, PB, FB, ST, TB, nl, small, first, root)
    fin = tau_minus_bias(tau, TB, k0, nl, fin)
    composite(P, RB, PB, CB, ST, MB, nl)         # M, on the transforms of q
    cholesky_lanes(n, MB, TB, SB, nl)            # x <- M^-1 (tau - b)
    return fin


@njit(cache=True, inline="always")
def cholesky_block(P, q, qd, tau, w, flags, out, k0, first, root, composite):
    """qdd of the samples k0 .. k0 + B - 1 (fewer at the batch's end) into the same rows of
    ``out`` (flags as ``forward.fd``'s, without ABA). Returns 1 if one of them has a NaN/Inf
    input, else 0."""
    n = P.shape[0] - 1
    L = int(P[n, LANES])                 # lanes (= B), read at run time on purpose
    nl = min(L, out.shape[0] - k0)
    QV, WB, TB, ST, RB, PB, FB, CB, SB = fd_scratch(n, L)
    MB = stack_empty((n * n, L))         # fd_batch calls this only where it fits
    fin = fd_lanes_core(P, q, qd, tau, w, flags, k0, nl, QV, WB, TB, ST, RB, PB, FB, CB, MB, SB,
                        first, root, composite)
    scatter(TB, out, k0, nl)
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def fd_block(P, q, qd, tau, w, flags, out, k0):
    """``cholesky_block`` on a fixed base (``forward.cholesky_core`` in every lane)."""
    return cholesky_block(P, q, qd, tau, w, flags, out, k0, 0, fixed_base, composite_lanes)


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def floating_fd_block(P, q, qd, tau, w, flags, out, k0):
    """``cholesky_block`` with a free-flyer root (``forward.floating_cholesky_core``)."""
    return cholesky_block(P, q, qd, tau, w, flags, out, k0, 6, free_flyer_root,
                          floating_composite_lanes)
