"""Forward dynamics of a batch on the card, one CUDA thread per state: qdd = M^-1 (tau - b)
by Cholesky (Featherstone 2008, Sec. 6.3), as the core's Cholesky route (``core/forward.py``).

b by Newton-Euler at zero acceleration (``rnea.passes``), M by composite rigid bodies
(``crba.crba_pass``) on the same joint transforms, then the core's own Cholesky factor and
solves (``core/cholesky.py``, compiled for CUDA) in per-thread arrays. A robot with mimic
joints solves (G^T M G) qdd = tau - G^T b, as ``robot/mimic.py``. A free-floating base
solves its instantaneous chain (``core/floating.fd_inputs``, compiled for CUDA: tau of n+6
numbers, or the joints' n with the base free) and takes the velocity products off after, as
``core/floating.py``. The articulated-body route (``core/aba.py``, for long chains) is not
on the card yet.
"""
from functools import lru_cache

import math

from numba import float64

from ..core.layout import W_ACC, W_ALL
from .crba import crba_pass
from .device_model import device_model
from .rnea import base_acc, passes
from .runtime import Batch, cuda, launch
from ..core.floating import GW
from .steps import (cholesky_factor, cholesky_solve_factored, coordinates, floating_fd_inputs,
                    row, velocity_products)


@lru_cache(maxsize=None)
def kernel(n, k, chain, mimic, floating):
    """The forward-dynamics kernel for n bodies and k coordinates (``floating``: a floating
    base's instantaneous chain)."""
    transforms, newton_euler = passes(n, chain)
    crba = crba_pass(n, chain)
    load, _, reduce_matrix = coordinates(n, k, mimic)
    ns, nq = (1 if chain else n), n + 1

    @cuda.jit
    def fd_kernel(P, parent, src, mult, off, gw, Q, QD, TAU, QDD):
        s = cuda.grid(1)
        if s >= Q.shape[0]:
            return
        q, qd = cuda.local.array(n, float64), cuda.local.array(n, float64)
        zero, b = cuda.local.array(n, float64), cuda.local.array(n, float64)
        R, p = cuda.local.array((n, 9), float64), cuda.local.array((n, 3), float64)
        f, st = cuda.local.array((n, 6), float64), cuda.local.array((ns, 9), float64)
        c, M = cuda.local.array((n, 10), float64), cuda.local.array((n, n), float64)
        x, w = cuda.local.array(k, float64), cuda.local.array(W_ALL, float64)
        load(QD, s, src, mult, off, False, qd)
        if floating:        # q, x = tau (six zeros first: the base free), w[W_ACC:] = -R^T g
            qf, tf, g9 = (cuda.local.array(nq, float64), cuda.local.array(n, float64),
                          cuda.local.array(GW, float64))
            row(Q, s, qf)
            row(TAU, s, tf)
            row(gw, 0, g9)
            chk = floating_fd_inputs(qf, tf[:TAU.shape[1]], g9, 0, q, w, x)
            gx, gy, gz = w[W_ACC], w[W_ACC + 1], w[W_ACC + 2]
        else:
            load(Q, s, src, mult, off, True, q)
            chk = 0.0
            gx, gy, gz = base_acc(P, n)
        for i in range(n):
            zero[i] = 0.0
        transforms(P, q, R, p)
        newton_euler(P, parent, R, p, f, st, qd, zero, b, gx, gy, gz)   # b(q, qd)
        crba(P, parent, R, p, c, M)
        if mimic:                       # x = tau - G^T b, L = chol(G^T M G)
            L = cuda.local.array((k, k), float64)
            reduce_matrix(M, src, mult, L)
            for a in range(k):
                x[a] = 0.0
            for i in range(n):
                x[src[i]] += mult[i] * b[i]
            for a in range(k):
                x[a] = TAU[s, a] - x[a]
        else:
            L = M
            for a in range(k):
                x[a] = (x[a] if floating else TAU[s, a]) - b[a]
        cholesky_factor(L)
        cholesky_solve_factored(L, x)
        if floating:        # a = qdd of the chain - the velocity products
            velocity_products(qd, -1.0, x)
        for a in range(k):
            QDD[s, a] = math.nan if chk != 0.0 else x[a]

    return fd_kernel


def forward_dynamics(robot, Q, QD, TAU):
    """qdd of N states, as ``robot.forward_dynamics`` (Cholesky route; no wrench): Q (N,
    robot's nq), QD (N, nv), TAU (N, nv) (a floating base: or (N, dof), the joints' torques
    with the base free) float64, NumPy arrays (the result is NumPy) or device arrays (it
    stays on the card)."""
    op = "gpu.forward_dynamics"
    dm = device_model(robot, "forward_dynamics")
    widths = (dm.k, dm.k - 6) if dm.floating else dm.k
    batch = Batch(op, [("Q", Q, dm.nq), ("QD", QD, dm.k), ("TAU", TAU, widths)])
    q, qd, tau = batch.to_card(dm.k, op)
    out = cuda.device_array((batch.N, dm.k))
    launch(kernel(*dm.key), batch.N, *dm.arrays, q, qd, tau, out)
    return batch.result(out)
