"""Inverse dynamics of a batch on the card: the recursive Newton-Euler algorithm, one CUDA
thread per state.

Each thread runs the compiled core's own steps (``core/rnea.py``'s ``into_body``,
``body_wrench``; ``core/joint.py``'s ``joint_rate``, ``project``; ``core/spatial.py``'s ``force_to_parent``, compiled for
the CUDA target by ``steps.device``) over the bodies in the order of the parent array:
outward, each body's (omega, alpha, acc) from its parent's (a chain keeps them in
registers; a tree in a per-thread array); inward, each body's joint wrench added to its
parent's (Featherstone 2008, Sec. 5.3). The model is the packed joint-frame array ``P``
(``core/layout.py``), read by every thread; the per-body transforms and wrenches live in
per-thread arrays. No tip wrench and no base motion here (the CPU's ``rnea_wrench`` has them).

A free-floating base runs the CPU's instantaneous chain (``device_model``): the core's own
``core/floating.rnea_inputs`` (compiled for CUDA) makes its q, its accelerations (a plus the
virtual joints' velocity products) and the base's acceleration -R^T g from each state.
"""
from functools import lru_cache

from numba import float64

import math

from ..core import flags as F
from ..core.layout import ARM, G, KIND, W_ACC, W_ALL
from .device_model import device_model
from .runtime import Batch, cuda, launch
from ..core.floating import GW
from .steps import (body_wrench, coordinates, floating_rnea_inputs, force_to_parent, get9,
                    has_armature, into_body, joint_rate, joint_transform, project, put9, row)

QD_QDD = F.QD | F.QDD


@lru_cache(maxsize=None)
def passes(n, chain):
    """(transforms, newton_euler): device functions for n bodies (``chain``: parent = i - 1)."""

    @cuda.jit(device=True)
    def transforms(P, q, R, p):
        """R[i] (row-major) and p[i]: body i in its parent at q[i]."""
        for i in range(n):
            r, px, py, pz = joint_transform(P, i, q[i])
            put9(R, i, r)
            p[i, 0], p[i, 1], p[i, 2] = px, py, pz

    @cuda.jit(device=True)
    def newton_euler(P, parent, R, p, f, st, qd, qdd, tau, gx, gy, gz):
        """tau = M(q) qdd + b(q, qd) of every joint; f: the body wrenches, then the joint
        wrenches; st: each body's (omega, alpha, acc) (a tree only); (gx, gy, gz): the
        base's linear acceleration, -g for a fixed base (``base_acc``)."""
        wx = wy = wz = ax = ay = az = 0.0
        lx, ly, lz = gx, gy, gz
        for i in range(n):
            if not chain:
                pa = parent[i]
                if pa < 0:
                    wx = wy = wz = ax = ay = az = 0.0
                    lx, ly, lz = gx, gy, gz
                else:
                    wx, wy, wz, ax, ay, az, lx, ly, lz = get9(st, pa)
            wx, wy, wz, ax, ay, az, lx, ly, lz = into_body(
                get9(R, i), p[i, 0], p[i, 1], p[i, 2], wx, wy, wz, ax, ay, az, lx, ly, lz)
            wx, wy, wz, ax, ay, az, lx, ly, lz = joint_rate(
                P[i, KIND], wx, wy, wz, ax, ay, az, lx, ly, lz, qd[i], qdd[i])
            if not chain:
                put9(st, i, (wx, wy, wz, ax, ay, az, lx, ly, lz))
            f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5] = body_wrench(
                P, i, wx, wy, wz, ax, ay, az, lx, ly, lz)
        # inward: tau_i = S_i^T (n; f), then f_parent += Xup_i^T f_i
        for i in range(n - 1, -1, -1):
            tau[i] = project(P[i, KIND], f[i, 2], f[i, 5])
            pa = i - 1 if chain else parent[i]
            if pa >= 0:
                nx, ny, nz, fx, fy, fz = force_to_parent(get9(R, i), p[i, 0], p[i, 1], p[i, 2],
                                                         f[i, 0], f[i, 1], f[i, 2], f[i, 3],
                                                         f[i, 4], f[i, 5])
                f[pa, 0] += nx
                f[pa, 1] += ny
                f[pa, 2] += nz
                f[pa, 3] += fx
                f[pa, 4] += fy
                f[pa, 5] += fz

        if has_armature(P):         # tau_i += I_a,i qdd_i, after the passes
            for i in range(n):
                tau[i] += P[i, ARM] * qdd[i]
    return transforms, newton_euler


@cuda.jit(device=True)
def base_acc(P, n):
    """A fixed base's linear acceleration in the recursion: -g (Featherstone 2008, Sec. 5.3)."""
    return -P[n, G], -P[n, G + 1], -P[n, G + 2]


@lru_cache(maxsize=None)
def kernel(n, k, chain, mimic, floating):
    """The inverse-dynamics kernel for n bodies and k coordinates (``floating``: the
    instantaneous chain of a free-floating base, q of n + 1 numbers)."""
    transforms, newton_euler = passes(n, chain)
    load, store, _ = coordinates(n, k, mimic)
    ns, nq = (1 if chain else n), n + 1

    @cuda.jit
    def rnea_kernel(P, parent, src, mult, off, gw, Q, QD, QDD, TAU):
        s = cuda.grid(1)
        if s >= Q.shape[0]:
            return
        q, qd = cuda.local.array(n, float64), cuda.local.array(n, float64)
        qdd, tau = cuda.local.array(n, float64), cuda.local.array(n, float64)
        R, p = cuda.local.array((n, 9), float64), cuda.local.array((n, 3), float64)
        f, st = cuda.local.array((n, 6), float64), cuda.local.array((ns, 9), float64)
        w = cuda.local.array(W_ALL, float64)
        load(QD, s, src, mult, off, False, qd)
        if floating:        # q, qdd = a + the velocity products, w[W_ACC:] = -R^T g
            qf, af, g9 = (cuda.local.array(nq, float64), cuda.local.array(n, float64),
                          cuda.local.array(GW, float64))
            row(Q, s, qf)
            row(QDD, s, af)
            row(gw, 0, g9)
            chk = floating_rnea_inputs(qf, qd, af, g9, QD_QDD, q, w, qdd)
            gx, gy, gz = w[W_ACC], w[W_ACC + 1], w[W_ACC + 2]
        else:
            load(Q, s, src, mult, off, True, q)
            load(QDD, s, src, mult, off, False, qdd)
            chk = 0.0
            gx, gy, gz = base_acc(P, n)
        transforms(P, q, R, p)
        newton_euler(P, parent, R, p, f, st, qd, qdd, tau, gx, gy, gz)
        if chk != 0.0:      # a quaternion of zero length
            for i in range(n):
                tau[i] = math.nan
        store(tau, src, mult, TAU, s)

    return rnea_kernel


def inverse_dynamics(robot, Q, QD, QDD):
    """tau = M(q) qdd + b(q, qd) of N states, as ``robot.inverse_dynamics`` (no wrench, no
    base motion): Q (N, robot's nq), QD, QDD (N, nv) float64 (a fixed base: nq = nv = dof),
    NumPy arrays (the result is NumPy) or device arrays (``__cuda_array_interface__``: the
    result stays on the card)."""
    op = "gpu.inverse_dynamics"
    dm = device_model(robot, "inverse_dynamics")
    batch = Batch(op, [("Q", Q, dm.nq), ("QD", QD, dm.k), ("QDD", QDD, dm.k)])
    q, qd, qdd = batch.to_card(dm.k, op)
    out = cuda.device_array((batch.N, dm.k))
    launch(kernel(*dm.key), batch.N, *dm.arrays, q, qd, qdd, out)
    return batch.result(out)
