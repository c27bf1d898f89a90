"""Forward dynamics, compiled: qdd = M(q)^-1 (tau - b(q, qd) + J^T w), by one of two routes
(the same as ``algorithms/forward.py`` and ``algorithms/aba.py``):

- Cholesky: b by Newton-Euler at zero acceleration, M by the composite-rigid-body
  algorithm, then M = L L^T and two triangular solves (Featherstone 2008, Sec. 6.3);
- ABA: the articulated-body algorithm, O(n) (``aba.py``), for long chains.

``Robot.forward_dynamics(method="auto")`` picks the route by chain length
(``algorithms.aba.CROSSOVER``). With the DAMPING flag both solve
(M + diag(damping)) qdd = tau - b (the simulator's implicit joint damping).
"""
from numba import njit

from . import flags as F
from .aba import aba_core, floating_aba_core
from .aba_lanes import aba_block, aba_lanes_fit, floating_aba_block
from .cholesky import cholesky_solve
from .crba import crba_core, floating_crba_core
from .data import new_art, new_chol, new_kin, square_lanes_fit
from .forward_lanes import fd_block, floating_fd_block
from .layout import LANES, W_ALL, W_WRENCH
from .signatures import D1, D2, D3, In1, Out1, Pm, f8, i8, internal
from .rnea import floating_rnea_core, rnea_core
from .status import BAD_LENGTH, NOT_FINITE, OK, status
from .spatial import finite


@njit(cache=True, inline="always")
def cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out, rnea, crba):
    """qdd into ``out`` by the Cholesky route. Returns 0.0, or NaN on a NaN/Inf input.
    ``rnea``, ``crba``: the caller's recursions (a fixed base's, or a floating base's whose
    first six bodies are one free-flyer root: rnea.floating_rnea_core, crba.floating_crba_core)."""
    n = out.shape[0]
    chk = rnea(P, sc, R, p, f, q, qd, q, w, flags & (F.QD | F.WRENCH | F.BASE), b)   # b - J^T w
    for i in range(n):
        chk += finite(tau[i])
        b[i] = tau[i] - b[i]
    crba(P, R, p, M)                     # R, p: the joint transforms of q, from rnea
    if (flags & F.DAMPING) != 0:
        for i in range(n):
            M[i, i] += damping[i]
    cholesky_solve(M, b, out)
    return chk


def cholesky_core(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out):
    """``cholesky_route`` on a fixed base (a moving one with flag BASE)."""
    return cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out, rnea_core,
                          crba_core)


def floating_cholesky_core(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out):
    """``cholesky_route`` on a floating base's virtual chain (a free-flyer root)."""
    return cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out,
                          floating_rnea_core, floating_crba_core)


cholesky_inline = njit(cache=True, inline="always")(cholesky_core)   # into the entry fd
cholesky_core = internal(f8(Pm, D2, D3, D2, D2, D2, D1, In1, In1, In1, In1, In1, i8, Out1),
                         calls=("rnea_core", "crba_core", "cholesky_solve"))(cholesky_core)
floating_cholesky_core = internal(
    f8(Pm, D2, D3, D2, D2, D2, D1, In1, In1, In1, In1, In1, i8, Out1),
    calls=("floating_rnea_core", "floating_crba_core", "cholesky_solve"))(floating_cholesky_core)


# ------------------------------------------------------------------ entry points
@njit(cache=True, inline="always")
def _checked_length(P, q, qd, tau, out):
    n = P.shape[0] - 1
    return q.shape[0] == n and qd.shape[0] == n and tau.shape[0] == n and out.shape[0] == n


def fd(P, q, qd, tau, w, flags, out):
    """Forward dynamics of one state into ``out`` (n,): Cholesky, or ABA with flag ABA;
    with flag WRENCH the tip wrench ``w[:6]``, [f; m] in base coordinates, on the tip
    (else not read); with flag BASE the base motion (then ``w`` has W_ALL entries,
    layout.W_*). Returns OK, NOT_FINITE or BAD_LENGTH. (One entry
    point with and without a wrench: a second one would compile the recursions again,
    ~0.7 s of a cold start, to save ~40 ns a call.)"""
    if (not _checked_length(P, q, qd, tau, out)
            or w.shape[0] != (W_ALL if (flags & F.BASE) != 0 else W_WRENCH)):
        return BAD_LENGTH
    n = out.shape[0]
    d = new_kin(n)
    flags &= ~F.DAMPING                  # tau stands in for the unread damping argument
    if (flags & F.ABA) != 0:
        a = new_art(n)
        return status(aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y,
                               q, qd, tau, w, tau, flags, out))
    c = new_chol(n)
    return status(cholesky_inline(P, d.sc, d.R, d.p, d.f, c.M, c.b, q, qd, tau, w, tau, flags, out))


@njit(cache=True, inline="always")
def batch(P, q, qd, tau, w, flags, out, block, aba, cholesky, aba_block):
    """Forward dynamics of N states (rows broadcast as in ``rnea_batch``), B at a time in
    SIMD lanes: the Cholesky route by ``block``, ABA by ``aba_block`` (aba_lanes.py); a chain
    too long for the lanes' stack (``data.square_lanes_fit``, ``aba_lanes.aba_lanes_fit``)
    one state at a time by ``cholesky`` or ``aba`` (the same bits). Returns OK, or
    NOT_FINITE if some input had a NaN/Inf. The kernels are the caller's: a fixed base's or
    a floating one's."""
    N, n = out.shape[0], P.shape[0] - 1
    L = int(P[n, LANES])
    flags &= ~F.DAMPING                  # tau stands in for the unread damping argument
    use_aba = (flags & F.ABA) != 0
    if aba_lanes_fit(n, L) if use_aba else square_lanes_fit(n, L):
        bad = OK
        for k0 in range(0, N, L):
            if use_aba:
                bad |= aba_block(P, q, qd, tau, w, flags, out, k0)
            else:
                bad |= block(P, q, qd, tau, w, flags, out, k0)
        return bad
    d, a, c = new_kin(n), new_art(n), new_chol(n)
    nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
    bad = OK
    for k in range(N):
        qk, qdk, tk, wk = q[k if nq else 0], qd[k if nv else 0], tau[k if nt else 0], w[k if nw else 0]
        if use_aba:
            chk = aba(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y, qk, qdk, tk, wk, tk,
                      flags, out[k])
        else:
            chk = cholesky(P, d.sc, d.R, d.p, d.f, c.M, c.b, qk, qdk, tk, wk, tk, flags, out[k])
        if chk != 0.0:
            bad = NOT_FINITE
    return bad


def fd_batch(P, q, qd, tau, w, flags, out):
    """``batch`` on a fixed base (or one with a known motion, flag BASE)."""
    return batch(P, q, qd, tau, w, flags, out, fd_block, aba_core, cholesky_core, aba_block)


def floating_fd_batch(P, q, qd, tau, w, flags, out):
    """``batch`` on a floating base's virtual chain: the free-flyer root's kernels."""
    return batch(P, q, qd, tau, w, flags, out, floating_fd_block, floating_aba_core,
                 floating_cholesky_core, floating_aba_block)
