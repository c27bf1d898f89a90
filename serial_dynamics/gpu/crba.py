"""Mass matrices of a batch on the card: the composite-rigid-body algorithm, one CUDA thread
per state (Featherstone 2008, Table 6.2).

As ``core/crba.py``: the composite inertia of each subtree kept as ten numbers (m, h = m c,
I_O), F = IC_i S_i carried towards the base by ``force_to_parent`` (the core's, compiled for
CUDA), M_ji = S_j^T F, and the armature on the diagonal. Here on the parent array: each
composite is added to its parent's (``steps.composite_to_parent``) and F climbs the parents;
the core's chain loop instead carries one composite in registers and stops at body 0 early.
"""
from functools import lru_cache

from numba import float64

from ..core.layout import ARM, H, IO, KIND, MASS, W_ALL
from .device_model import device_model
from .rnea import passes
from .runtime import Batch, cuda, launch
from ..core.floating import GW
from .steps import (composite_to_parent, coordinates, floating_chain_inputs, force_to_parent,
                    get9, get10, has_armature, joint_momentum, project, put10, row)


@lru_cache(maxsize=None)
def crba_pass(n, chain):
    """The device function ``crba(P, parent, R, p, c, M)``: M (n, n) from the joint
    transforms R, p; c (n, 10) holds the composites."""

    @cuda.jit(device=True)
    def crba(P, parent, R, p, c, M):
        if not chain:                   # bodies on different branches do not couple: M_ij = 0
            for i in range(n):
                for j in range(n):
                    M[i, j] = 0.0
        for i in range(n):
            put10(c, i, (P[i, MASS], P[i, H], P[i, H + 1], P[i, H + 2], P[i, IO], P[i, IO + 1],
                         P[i, IO + 2], P[i, IO + 3], P[i, IO + 4], P[i, IO + 5]))
        for i in range(n - 1, -1, -1):
            m, hx, hy = c[i, 0], c[i, 1], c[i, 2]
            # F = IC_i S_i: the momentum of the subtree moving with a unit joint rate
            nx, ny, nz, fx, fy, fz, M[i, i] = joint_momentum(P[i, KIND], m, hx, hy, c[i, 8],
                                                             c[i, 9], c[i, 6])
            j = i
            pj = i - 1 if chain else parent[i]
            while pj >= 0:              # F = Xup_j^T F, then M_ji = S_j^T F
                nx, ny, nz, fx, fy, fz = force_to_parent(get9(R, j), p[j, 0], p[j, 1], p[j, 2],
                                                         nx, ny, nz, fx, fy, fz)
                j = pj
                M[j, i] = project(P[j, KIND], nz, fz)
                M[i, j] = M[j, i]
                pj = j - 1 if chain else parent[j]
            pa = i - 1 if chain else parent[i]
            if pa >= 0:
                put10(c, pa, composite_to_parent(get9(R, i), p[i, 0], p[i, 1], p[i, 2],
                                                 get10(c, i), get10(c, pa)))
        if has_armature(P):             # M_ii += I_a,i, after the pass
            for i in range(n):
                M[i, i] += P[i, ARM]
    return crba


@lru_cache(maxsize=None)
def kernel(n, k, chain, mimic, floating):
    """The mass-matrix kernel for n bodies and k coordinates (``floating``: a floating base's
    instantaneous chain, whose mass matrix is the floating base's M)."""
    transforms, _ = passes(n, chain)
    crba = crba_pass(n, chain)
    load, _, reduce_matrix = coordinates(n, k, mimic)
    nq = n + 1

    @cuda.jit
    def crba_kernel(P, parent, src, mult, off, gw, Q, OUT):
        s = cuda.grid(1)
        if s >= Q.shape[0]:
            return
        q, w = cuda.local.array(n, float64), cuda.local.array(W_ALL, float64)
        R, p = cuda.local.array((n, 9), float64), cuda.local.array((n, 3), float64)
        c, M = cuda.local.array((n, 10), float64), cuda.local.array((n, n), float64)
        if floating:        # q of the chain: six zeros, then the joints
            qf, g9 = cuda.local.array(nq, float64), cuda.local.array(GW, float64)
            row(Q, s, qf)
            row(gw, 0, g9)
            floating_chain_inputs(qf, g9, 0, q, w)
        else:
            load(Q, s, src, mult, off, True, q)
        transforms(P, q, R, p)
        crba(P, parent, R, p, c, M)
        if mimic:
            red = cuda.local.array((k, k), float64)
            reduce_matrix(M, src, mult, red)
            for a in range(k):
                for b in range(k):
                    OUT[s, a, b] = red[a, b]
        else:
            for a in range(n):
                for b in range(n):
                    OUT[s, a, b] = M[a, b]

    return crba_kernel


def mass_matrix(robot, Q):
    """M(q) of N configurations (N, nv, nv), as ``robot.mass_matrix``: Q (N, robot's nq)
    float64, a NumPy array (the result is NumPy) or a device array (it stays on the card)."""
    op = "gpu.mass_matrix"
    dm = device_model(robot, "mass_matrix")
    batch = Batch(op, [("Q", Q, dm.nq)])
    (q,) = batch.to_card(dm.k * dm.k, op)
    out = cuda.device_array((batch.N, dm.k, dm.k))
    launch(kernel(*dm.key), batch.N, *dm.arrays, q, out)
    return batch.result(out)
