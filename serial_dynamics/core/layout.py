"""The model in the compiled core's layout: one array ``P``, built once per model.

Row ``i < n`` describes body ``i`` in joint frames (``Model`` fields of the same names;
conventions in docs/conventions.md); row ``n`` holds the chain's constants. The number
of bodies is ``n = P.shape[0] - 1``.

    P[i, XR:XR+9]   Xtree_R, row-major          P[n, G:G+3]       gravity (base frame)
    P[i, XP:XP+3]   Xtree_p                     P[n, TIPP:TIPP+3] Xtip_p
    P[i, KIND]      1.0 prismatic, 0.0 revolute P[n, TIPR:TIPR+9] Xtip_R, row-major
    P[i, MASS]      m                           P[n, LANES]       lanes of the batch kernels
    P[i, H:H+3]     h = m c                     P[n, TREE]        1.0 a tree, 0.0 a chain
    P[i, IO:IO+6]   I_O: xx yy zz xy xz yz      P[n, ROOT]        6.0: bodies 0-5 are a
                                                 floating base's coordinates (``pack(root=6)``:
                                                 the tree kernels treat them as one joint)
    P[i, ARM]       armature (reflected rotor inertia, kg m^2 or kg)   P[n, ARMATURE]  1.0: some
                                                 joint has armature (else the kernels add none)
                                                P[n, GROOT:GROOT+3] the world's gravity of a
                                                 floating base (``pack(root=6, gravity=g)``:
                                                 its inverse dynamics without a gw argument)
    P[i, PARENT]    the body joint i hangs from (-1.0: the base); i - 1 in a chain
    P[i, TIPPATH]   1.0 if body i is on the path from the base to body n-1 (the tip's)

The entry points' external inputs ``w`` (flags.WRENCH, flags.BASE) are one vector:

    w[W_F:W_F+3], w[W_M:W_M+3]       the tip wrench [f; m] (base frame, on the tip)
    w[W_OMEGA:+3], w[W_ALPHA:+3]     the base's angular velocity and acceleration (base frame)
    w[W_ACC:W_ACC+3]                 the classical acceleration of the base origin (no gravity)
"""
import numpy as np

from ..joints import PRISMATIC

XR, XP, KIND, MASS, H, IO, ARM, PARENT, TIPPATH = 0, 9, 12, 13, 14, 17, 23, 24, 25
G, TIPP, TIPR, LANES, TREE, ROOT, ARMATURE, GROOT = 0, 3, 6, 15, 16, 17, 18, 19
WIDTH = 26
B = 32          # samples per block of the lane-parallel batch kernel (rnea_lanes.py)
W_F, W_M, W_OMEGA, W_ALPHA, W_ACC = 0, 3, 6, 9, 12
W_WRENCH, W_ALL = 6, 15      # lengths of w: a tip wrench only; wrench and base motion


def pack(model, root=0, gravity=(0.0, 0.0, 0.0)) -> np.ndarray:
    """``P`` for ``model``. No kernel writes it (signatures.Pm). ``root``: 6 for the virtual
    chain of a floating base (robot/floating.virtual_chain), whose first six bodies the tree
    kernels then take as the free-flyer root joint; the chain kernels do not read it.
    ``gravity``: there, the world's gravity (the virtual chain's own is zero), which
    ``floating_rnea`` reads from P instead of an argument."""
    n = model.dof
    P = np.zeros((n + 1, WIDTH))
    for i in range(n):
        set_inertia(P, i, model.mass[i], model.h[i], model.I_O[i])
        P[i, XR:XR + 9] = model.Xtree_R[i].ravel()
        P[i, XP:XP + 3] = model.Xtree_p[i]
        P[i, KIND] = 1.0 if model.kind[i] == PRISMATIC else 0.0
        P[i, ARM] = model.armature[i]
        P[i, PARENT] = model.parent[i]
    P[model.ancestors(n - 1), TIPPATH] = 1.0
    P[n, G:G + 3] = model.gravity
    P[n, TIPP:TIPP + 3] = model.Xtip_p
    P[n, TIPR:TIPR + 9] = model.Xtip_R.ravel()
    P[n, LANES] = B
    P[n, TREE] = 0.0 if model.is_chain else 1.0
    P[n, ROOT] = root
    P[n, ARMATURE] = 1.0 if np.any(model.armature != 0.0) else 0.0
    P[n, GROOT:GROOT + 3] = gravity
    return P        # writable on purpose: numba's dispatcher types a read-only array ~100 ns slower


def set_inertia(P, i, m, h, I):
    """Body ``i``'s inertial parameters (m, h = m c, I_O; joint frame) into row ``i``."""
    P[i, MASS] = m
    P[i, H:H + 3] = h
    P[i, IO:IO + 6] = I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]
