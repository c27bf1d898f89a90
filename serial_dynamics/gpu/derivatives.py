"""Derivatives of inverse dynamics of a batch on the card: d tau/d q and d tau/d qd, one CUDA
thread per state.

Each thread runs the compiled core's own forward-mode recursion, ``core/derivatives.py``'s
``derivatives_core`` (all 2n directions of a chain at once, O(n^2)), compiled for the CUDA
target from the same source, on per-thread arrays; the joint transforms come from
``steps.joint_transform`` (flag HAVE_TRANSFORMS). A robot with mimic joints gets
G^T (d tau_all/d x_all) G, as ``robot/mimic.py``. That recursion is written for a chain
(the directions alive at body k are [0, 2k)): a tree is refused until the core's is.
In numba's simulator the core's inner functions run compiled for the CPU, which cannot
read a simulated device array: there each thread copies ``P`` into a per-thread array first.
"""
from functools import lru_cache

from numba import float64

from ..core import flags as F
from ..core.derivatives import HAVE_TRANSFORMS, derivatives_core
from ..core.layout import WIDTH
from .device_model import device_model
from .runtime import SIMULATOR, Batch, cuda, launch
from .steps import coordinates, device, joint_transform

_core = device(derivatives_core)
_FLAGS = F.QD | F.QDD | HAVE_TRANSFORMS


@lru_cache(maxsize=None)
def kernel(n, k, mimic):
    """The kernel for a chain of n bodies and k coordinates."""
    load, _, reduce_matrix = coordinates(n, k, mimic)
    n2, rows, sim = 2 * n, n + 1, SIMULATOR

    @cuda.jit
    def derivatives_kernel(P, parent, src, mult, off, Q, QD, QDD, DQ, DQD):
        s = cuda.grid(1)
        if s >= Q.shape[0]:
            return
        q, qd, qdd = (cuda.local.array(n, float64), cuda.local.array(n, float64),
                      cuda.local.array(n, float64))
        sc, R = cuda.local.array((2, n), float64), cuda.local.array((n, 3, 3), float64)
        p, f = cuda.local.array((n, 3), float64), cuda.local.array((n, 6), float64)
        T, Tf = cuda.local.array((15, n2), float64), cuda.local.array((6, n2), float64)
        dB, w = cuda.local.array((n, 6, n2), float64), cuda.local.array(6, float64)
        dq, dqd = cuda.local.array((n, n), float64), cuda.local.array((n, n), float64)
        Pt = P
        if sim:
            Pt = cuda.local.array((rows, WIDTH), float64)
            for i in range(rows):
                for j in range(WIDTH):
                    Pt[i, j] = P[i, j]
        load(Q, s, src, mult, off, True, q)
        load(QD, s, src, mult, off, False, qd)
        load(QDD, s, src, mult, off, False, qdd)
        for i in range(n):
            r, px, py, pz = joint_transform(P, i, q[i])
            R[i, 0, 0], R[i, 0, 1], R[i, 0, 2] = r[0], r[1], r[2]
            R[i, 1, 0], R[i, 1, 1], R[i, 1, 2] = r[3], r[4], r[5]
            R[i, 2, 0], R[i, 2, 1], R[i, 2, 2] = r[6], r[7], r[8]
            p[i, 0], p[i, 1], p[i, 2] = px, py, pz
        _core(Pt, sc, R, p, f, T, Tf, dB, q, qd, qdd, w, _FLAGS, dq, dqd)
        if mimic:
            red = cuda.local.array((k, k), float64)
            reduce_matrix(dq, src, mult, red)
            for a in range(k):
                for b in range(k):
                    DQ[s, a, b] = red[a, b]
            reduce_matrix(dqd, src, mult, red)
            for a in range(k):
                for b in range(k):
                    DQD[s, a, b] = red[a, b]
        else:
            for a in range(n):
                for b in range(n):
                    DQ[s, a, b] = dq[a, b]
                    DQD[s, a, b] = dqd[a, b]

    return derivatives_kernel


def inverse_dynamics_derivatives(robot, Q, QD, QDD):
    """(d tau/d q, d tau/d qd), each (N, dof, dof), as ``robot.inverse_dynamics_derivatives``
    (no wrench, no base motion): Q, QD, QDD (N, robot.dof) float64, NumPy arrays (NumPy
    results) or device arrays (results on the card)."""
    op = "gpu.inverse_dynamics_derivatives"
    dm = device_model(robot, "inverse_dynamics_derivatives")
    if dm.floating:
        raise NotImplementedError(
            f"{op}: a free-floating base is not supported yet (its derivatives add the "
            "base's rotation of gravity to the chain's, robot/floating.py); call "
            "robot.inverse_dynamics_derivatives(...) on the CPU")
    if not dm.chain:
        raise NotImplementedError(
            f"{op}: a kinematic tree is not supported on the card yet (the card runs the "
            "chain's derivative recursion, core/derivatives.py; the tree's, "
            "core/tree_derivatives.py, is compiled for the CPU only); call "
            "robot.inverse_dynamics_derivatives(...) on the CPU")
    batch = Batch(op, [("Q", Q, dm.k), ("QD", QD, dm.k), ("QDD", QDD, dm.k)])
    q, qd, qdd = batch.to_card(2 * dm.k * dm.k, op)
    dq, dqd = cuda.device_array((batch.N, dm.k, dm.k)), cuda.device_array((batch.N, dm.k, dm.k))
    launch(kernel(dm.n, dm.k, dm.mimic), batch.N, *dm.structure, q, qd, qdd, dq, dqd)
    return batch.result(dq), batch.result(dqd)
