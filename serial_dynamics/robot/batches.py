"""What every compiled batch call needs: its inputs as kernel rows, the single-state
external vector ``w``, and the split of a large batch over the cores.

Used by ``Robot`` (inverse dynamics, mass matrix, forward dynamics), ``regressor.py`` and
``derivatives.py``. The batch kernels release the GIL; each state is computed by the same
code whatever its chunk, so a split batch gives the bits of one serial call.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .base_motion import BaseMotion
from ..core import flags as F


def cores() -> int:
    """The cores this process may run on: its affinity mask (``taskset``, a container's
    cpuset), or ``os.cpu_count()`` on a platform without one."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


WORKERS = cores()                          # threads of a split batch: one per core
PAGE = 512                                 # float64 per 4 KiB page
W_BAD = np.zeros(0)                        # a w that no entry point accepts (BAD_LENGTH)
_pool = None


def run_split(kernel, P, N, arrays, extra, outs, min_states, block=1):
    """``kernel(P, *arrays, *extra, *outs)`` over ``N`` states: in one call below
    ``min_states``, else in one chunk per core. ``arrays``: the (N, ...) or broadcast
    (1, ...) inputs; ``outs``: the (N, ...) results; chunks are whole multiples of
    ``block`` states (the SIMD blocks of the lane kernels). Returns the largest status."""
    global _pool
    if N < min_states or WORKERS < 2:
        return kernel(P, *arrays, *extra, *outs)
    if _pool is None:
        _pool = ThreadPoolExecutor(WORKERS, thread_name_prefix="serial_dynamics")
    for o in outs:       # the first touch of fresh pages, here: threads faulting in pages
        o.reshape(-1)[::PAGE] = 0.0      # of one array at once slowed a 39 MB regressor 4x
    step = -(-N // WORKERS // block) * block
    rows = lambda a, k: a if a.shape[0] == 1 else a[k:k + step]   # noqa: E731
    futures = [_pool.submit(kernel, P, *[rows(a, k) for a in arrays], *extra,
                            *[o[k:k + step] for o in outs]) for k in range(0, N, step)]
    return max(f.result() for f in futures)


def kernel_rows(a):
    """An (N, n) state or wrench as a C-contiguous array for the kernels; a row broadcast
    over the batch (stride 0) is passed as one row, which the kernels broadcast."""
    if a.strides[0] == 0:
        a = a[:1]
    return np.ascontiguousarray(a, dtype=float)


def single_external(base_motion, wrench, flags):
    """(w, flags) for a single-state entry point with a base motion (core/layout.py W_*).
    A wrench that is not 6 numbers, or a base motion that is not a BaseMotion, is left to
    the general path (which names the culprit): w is then empty, and the entry point
    answers 2."""
    if not isinstance(base_motion, BaseMotion) or (wrench is not None and np.shape(wrench) != (6,)):
        return W_BAD, flags
    if wrench is None:                     # the motion's own vector (no kernel writes w)
        return base_motion._ext, flags | F.BASE
    return base_motion.external(wrench), flags | F.BASE | F.WRENCH
