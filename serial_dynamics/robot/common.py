"""What the facade and its kinds share: the flag sets of the kernel calls, the
forward-dynamics methods, and the ``out=`` convention."""
from __future__ import annotations

import numpy as np

from ..algorithms.aba import CROSSOVER
from ..core import flags as F

QD_QDD, QD = F.QD | F.QDD, F.QD          # flags, as module constants (no attribute lookup)
QD_QDD_W, QD_W = QD_QDD | F.WRENCH, QD | F.WRENCH
FD_METHODS = ("auto", "cholesky", "aba", "qr")
# states; splitting a batch over 2 cores paid from about 2048 states for inverse dynamics,
# 1500 for the mass matrix and 800 for forward dynamics (UR5e, measured 2026-11-23)
PARALLEL_MIN = 2048
# forward_dynamics(method="auto"): articulated bodies (O(n)) or Cholesky of M. A chain: from
# aba.CROSSOVER joints on, on a floating base from FLOATING_CHAIN_CROSSOVER (bench_floating.py,
# 2026-11-24: ABA / Cholesky 1.25 at 6 joints, 1.03 at 18, 0.89 at 24, 0.61 at 40). A tree:
# the sparse factor M = L^T D L costs sum_i d_i^2 for joint i at depth d_i (six more on a
# floating base), so from a mean d_i^2 of TREE_CROSSOVER on (bench_trees.py's "method"
# table, BENCHMARKS.md, 2026-11-28, over four runs: ABA / sparse factor 1.01-1.17 at a
# mean of 116 (the floating Talos), 0.60-0.75 at 144).
FLOATING_CHAIN_CROSSOVER = 24
TREE_CROSSOVER = 125.0


def aba_by_default(model, floating: bool) -> bool:
    """Whether forward_dynamics(method="auto") takes articulated bodies (see above)."""
    if model.is_chain:
        return model.dof >= (FLOATING_CHAIN_CROSSOVER if floating else CROSSOVER)
    d = model.depths + (6 if floating else 0)
    return float(np.mean(d.astype(float) ** 2)) >= TREE_CROSSOVER


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
