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
from .cholesky import cholesky_solve
from .crba import composite_bodies
from .data import new_art, new_chol, new_kin, square_lanes_fit
from .forward_lanes import fd_block, floating_fd_block
from .layout import LANES, ROOT, W_ALL, W_WRENCH
from .signatures import D1, D2, D3, In1, Out1, Pm, f8, i8, internal
from .rnea import newton_euler
from .status import BAD_LENGTH, NOT_FINITE, OK, status
from .spatial import finite


@njit(cache=True, inline="always")
def cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out, nb):
    """qdd into ``out`` by the Cholesky route. Returns 0.0, or NaN on a NaN/Inf input.
    ``nb``, a constant of the caller: 0, or 6 for a floating base's virtual chain, whose
    recursions take its first six bodies as one free-flyer root (rnea.newton_euler,
    crba.composite_bodies)."""
    n = out.shape[0]
    fl = flags & (F.QD | F.WRENCH | F.BASE)
    chk = (newton_euler(P, sc, R, p, f, q, qd, q, w, fl, b, 0) if nb == 0 else
           newton_euler(P, sc, R, p, f, q, qd, q, w, fl, b, 6))        # b - J^T w
    for i in range(n):
        chk += finite(tau[i])
        b[i] = tau[i] - b[i]
    if nb == 0:                          # R, p: the joint transforms of q, from newton_euler
        composite_bodies(P, R, p, M, 0)
    else:
        composite_bodies(P, R, p, M, 6)
    if (flags & F.DAMPING) != 0:
        for i in range(n):
            M[i, i] += damping[i]
    cholesky_solve(M, b, out)
    return chk


def cholesky_core(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out):
    """``cholesky_route`` on a fixed base (a moving one with flag BASE)."""
    return cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out, 0)


def floating_cholesky_core(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out):
    """``cholesky_route`` on a floating base's virtual chain (a free-flyer root)."""
    return cholesky_route(P, sc, R, p, f, M, b, q, qd, tau, w, damping, flags, out, 6)


cholesky_inline = njit(cache=True, inline="always")(cholesky_core)   # into the entry fd
cholesky_core = internal(f8(Pm, D2, D3, D2, D2, D2, D1, In1, In1, In1, In1, In1, i8, Out1),
                         calls=("cholesky_solve",))(cholesky_core)
floating_cholesky_core = internal(
    f8(Pm, D2, D3, D2, D2, D2, D1, In1, In1, In1, In1, In1, i8, Out1),
    calls=("cholesky_solve",))(floating_cholesky_core)


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


def fd_batch(P, q, qd, tau, w, flags, out):
    """Forward dynamics of N states (rows broadcast as in ``rnea_batch``): the Cholesky route
    B at a time in SIMD lanes (``forward_lanes.py``; a chain too long for the lanes' stack,
    ``data.square_lanes_fit``, one state at a time by ``cholesky_core``, the same bits),
    ABA one state after the other. Returns OK, or NOT_FINITE if some input had a NaN/Inf."""
    N, n = out.shape[0], P.shape[0] - 1
    L = int(P[n, LANES])
    flags &= ~F.DAMPING                  # tau stands in for the unread damping argument
    aba = (flags & F.ABA) != 0
    if not aba and square_lanes_fit(n, L):
        bad = OK
        for k0 in range(0, N, L):
            if P[n, ROOT] != 0.0:        # a floating base's virtual chain: a free-flyer root
                bad |= floating_fd_block(P, q, qd, tau, w, flags, out, k0)
            else:
                bad |= fd_block(P, q, qd, tau, w, flags, out, k0)
        return bad
    d, a, c = new_kin(n), new_art(n), new_chol(n)
    nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
    bad = OK
    for k in range(N):
        qk, qdk, tk, wk = q[k if nq else 0], qd[k if nv else 0], tau[k if nt else 0], w[k if nw else 0]
        if aba and P[n, ROOT] != 0.0:    # FDfb on a floating base's virtual chain
            chk = floating_aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y,
                                    qk, qdk, tk, wk, tk, flags, out[k])
        elif aba:
            chk = aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y,
                           qk, qdk, tk, wk, tk, flags, out[k])
        elif P[n, ROOT] != 0.0:
            chk = floating_cholesky_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, qk, qdk, tk, wk, tk,
                                         flags, out[k])
        else:
            chk = cholesky_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, qk, qdk, tk, wk, tk, flags, out[k])
        if chk != 0.0:
            bad = NOT_FINITE
    return bad
