"""The compiled core (numba): one module per algorithm, in joint frames.

    layout.py     the model as one array P (``pack``), its named columns
    data.py       Data: the named scratch arrays of one evaluation (on the call's stack)
    signatures.py the argument types, named; ``internal`` (one signature per algorithm)
    joint.py      the joint types, said once: X_J(q), S, S^T f, the rate, I S, the armature
    spatial.py    small helpers: sincos, frame changes of vectors/forces
    rnea.py       inverse dynamics (Newton-Euler)     rnea_lanes.py  the same, B samples in SIMD lanes
    crba.py       mass matrix (composite rigid bodies)  crba_lanes.py, forward_lanes.py  in lanes
    cholesky.py   M x = b                             aba.py         articulated bodies
    forward.py    forward dynamics (Cholesky or ABA)  flags.py       the entry points' flags
    status.py     the status codes entry points return
    derivatives.py   derivatives of inverse and forward dynamics (forward mode)
    derivatives_lanes.py  the same over a batch, B states in SIMD lanes
    dispatch.py   ENTRY_POINTS, K (built on first use), NUMBA_SUPPORTED
    cabi.py       a single-state entry point's numba.cfunc wrapper (one C ABI) for _fastcall.c
    planar_layout.py  the planar fast path's packed model Q and planar_pack (is a chain planar)
    planar.py     Newton-Euler and composite bodies of a planar chain in planar 3-vectors
    planar_lanes.py  the same, B samples in SIMD lanes
    floating.py   a free-floating base on the instantaneous chain (six virtual joints, one free-flyer root)
    floating_derivatives.py  its derivatives: the fixed-base ones on that chain, the base's columns
    tree.py       kinematic trees on the parent array (Newton-Euler: rnea.py's)  tree_lanes.py  in lanes
    tree_derivatives.py  the derivatives on trees    tree_derivatives_lanes.py  their batches in lanes
    mimic.py      mimic joints: the reduced system of one state in one call
    regressor.py  the torque regressor                energy.py      dT/dq, the symplectic step
    kinematics.py frame poses, Jacobians, center of mass, momentum (chains and trees)
    cache.py      where numba caches the kernels: a folder per fingerprint of their sources

Each algorithm is the same as its NumPy reference in ``algorithms/`` (same frames and
symbols; docs/conventions.md). Entry points, ``K`` and the status codes: ``dispatch.py``.
No fast-math flag anywhere: IEEE arithmetic, so results do not depend on what was compiled
or inlined where (bitwise the same in every process, whatever the cache holds), and
no cached kernel built from other sources: the functions decorated while the modules
import are cached in the folder of the sources' fingerprint (``cache.in_folder``; nothing
is deleted).
"""
from .cache import in_folder

with in_folder("core"):      # numba picks each function's cache folder as it is decorated
    from .dispatch import (BAD_LENGTH, ENTRY_POINTS, FD_CALLS, K, NOT_CONVERGED,  # noqa: F401
                           NOT_FINITE, NUMBA_SUPPORTED, OK, OTHER_TYPES, SINGLE_STATE)
