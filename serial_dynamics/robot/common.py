"""What the facade and its kinds share: the flag sets of the kernel calls, the
forward-dynamics methods, and the ``out=`` convention."""
from __future__ import annotations

import numpy as np

from ..core import flags as F

QD_QDD, QD = F.QD | F.QDD, F.QD          # flags, as module constants (no attribute lookup)
QD_QDD_W, QD_W = QD_QDD | F.WRENCH, QD | F.WRENCH
FD_METHODS = ("auto", "cholesky", "aba", "qr")
# states; splitting a batch over 2 cores paid from about 2048 states for inverse dynamics,
# 1500 for the mass matrix and 800 for forward dynamics (UR5e, measured 2026-11-23)
PARALLEL_MIN = 2048


def into(out, result):
    """``result``, or ``result`` written into the caller's ``out`` (checked) and ``out``."""
    if out is None:
        return result
    if not (isinstance(out, np.ndarray) and out.shape == result.shape
            and out.dtype == np.float64 and out.flags.writeable):
        got = (f"{out.dtype} array of shape {out.shape}" if isinstance(out, np.ndarray)
               else type(out).__name__)
        raise ValueError(f"out must be a writable float64 array of shape {result.shape} "
                         f"(the result's); got a {got}"
                         + ("" if not isinstance(out, np.ndarray) or out.flags.writeable
                            else " that is read-only"))
    out[...] = result
    return out
