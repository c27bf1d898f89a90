"""The check that test_derivatives_lanes.py (a floating chain) and
test_tree_derivatives_lanes.py (a floating tree) share: a floating base's derivative
batches against the single-state kernels, row by row, bit for bit."""
import numpy as np

from serial_dynamics.core import flags as F


def check_floating_rows(k, P, q, v, a, tau, rng):
    """``floating_rnea_derivatives_batch`` and ``floating_fd_derivatives_batch`` of the N
    states (q, v, a) and (q, v, tau) from the kernel table ``k``, without and with a world
    wrench per row (the world's gravity tilted), against one single-state call a row,
    bitwise. Returns the last rows of gw (wrench; gravity) used."""
    N, nv = q.shape[0], P.shape[0] - 1
    for flags in (0, F.WRENCH):
        gw = rng.normal(size=(N, 9))
        gw[:, 6:] = (0.3, -0.2, -9.8)
        dq, dv = np.full((N, nv, nv), np.nan), np.full((N, nv, nv), np.nan)
        assert k.floating_rnea_derivatives_batch(P, q, v, a, gw, flags, dq, dv) == 0
        fq, fv, fm = (np.full((N, nv, nv), np.nan) for _ in range(3))
        assert k.floating_fd_derivatives_batch(P, q, v, tau, gw, flags, fq, fv, fm) == 0
        o2, o3 = np.empty((2, nv, nv)), np.empty((3, nv, nv))
        for i in range(N):
            assert k.floating_rnea_derivatives(P, q[i], v[i], a[i], gw[i], flags, o2) == 0
            assert dq[i].tobytes() == o2[0].tobytes() and dv[i].tobytes() == o2[1].tobytes()
            assert k.floating_fd_derivatives(P, q[i], v[i], tau[i], gw[i], flags, o3) == 0
            assert all(x.tobytes() == y.tobytes() for x, y in zip((fq[i], fv[i], fm[i]), o3))
    return gw
