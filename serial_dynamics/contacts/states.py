"""The checks of the contact methods' arguments: states as one vector or a batch of rows,
each named in the error with its expected length, and the solver's settings."""
from __future__ import annotations

import numpy as np


def rows(named):
    """(single, N, [(N, k) arrays]) of ``named`` = ((name, x, lengths), ...): each x one state
    (k,) or a batch (N, k) with k in ``lengths`` (the first is the one named in the error),
    finite; batches of one size or broadcast from one state (ValueError naming the culprit)."""
    single, N, out = True, 1, []
    for name, x, lengths in named:
        a = np.asarray(x, dtype=float) if not isinstance(x, str) else np.zeros((0, 0, 0))
        if a.ndim not in (1, 2) or a.shape[-1] not in lengths:
            raise ValueError(f"{name} has shape {a.shape}; expected ({lengths[0]},) or "
                             f"(N, {lengths[0]})" + (f" (or {lengths[1]} columns)" if
                                                     len(lengths) > 1 else ""))
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} has a NaN or Inf entry; states must be finite numbers")
        if a.ndim == 2:
            if not single and a.shape[0] != N:
                raise ValueError(f"{name} has {a.shape[0]} rows; the other states have {N}")
            single, N = False, a.shape[0]
        out.append(a)
    return single, N, [np.broadcast_to(a, (N, a.shape[-1])) for a in out]


def positive(name, value, allow_zero=False):
    """``value`` as a float > 0 (>= 0 with ``allow_zero``), or a ValueError naming it."""
    x = float(value) if np.isscalar(value) and not isinstance(value, (str, bool)) else np.nan
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise ValueError(f"{name} must be a finite number {'>=' if allow_zero else '>'} 0; "
                         f"got {value!r}")
    return x
