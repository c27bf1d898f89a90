"""The model in the compiled core's layout: one array ``P``, built once per model.

Row ``i < n`` describes body ``i`` in joint frames (``Model`` fields of the same names;
conventions in docs/conventions.md); row ``n`` holds the chain's constants:

    P[i, XR:XR+9]   Xtree_R, row-major          P[n, G:G+3]      gravity (base frame)
    P[i, XP:XP+3]   Xtree_p                     P[n, TIPP:TIPP+3] Xtip_p
    P[i, KIND]      1.0 prismatic, 0.0 revolute P[n, TIPR:TIPR+9] Xtip_R, row-major
    P[i, MASS]      m                           P[0, NJ]          n (as a float)
    P[i, H:H+3]     h = m c                     P[0, LANES]       lanes of the batch kernels
    P[i, IO:IO+6]   I_O: xx yy zz xy xz yz
"""
import numpy as np

from ..joints import PRISMATIC

XR, XP, KIND, MASS, H, IO = 0, 9, 12, 13, 14, 17
G, TIPP, TIPR = 0, 3, 6
NJ, LANES = 23, 22
WIDTH = 24
B = 32          # samples per block of the lane-parallel batch kernel (rnea_lanes.py)


def pack(model) -> np.ndarray:
    """``P`` for ``model``. No kernel writes it (signatures.Pm)."""
    n = model.dof
    P = np.zeros((n + 1, WIDTH))
    for i in range(n):
        I = model.I_O[i]
        P[i, XR:XR + 9] = model.Xtree_R[i].ravel()
        P[i, XP:XP + 3] = model.Xtree_p[i]
        P[i, KIND] = 1.0 if model.kind[i] == PRISMATIC else 0.0
        P[i, MASS] = model.mass[i]
        P[i, H:H + 3] = model.h[i]
        P[i, IO:IO + 6] = I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]
    P[n, G:G + 3] = model.gravity
    P[n, TIPP:TIPP + 3] = model.Xtip_p
    P[n, TIPR:TIPR + 9] = model.Xtip_R.ravel()
    P[0, NJ] = n
    P[0, LANES] = B
    return P        # writable on purpose: numba's dispatcher types a read-only array ~100 ns slower
