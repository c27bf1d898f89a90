"""Wrenches on any links (``wrenches={link: [fx, fy, fz, mx, my, mz]}``): the generalized
forces sum_k J_k^T w_k that the environment's wrenches w_k, exerted on the links k at their
frame origins (base axes on a fixed base, world axes on a floating one, as the tip
wrench), put on the coordinates (virtual work: J_k v is link k's twist, so w_k . J_k v =
(J_k^T w_k) . v). Inverse dynamics subtracts them, forward dynamics adds them to tau:
tau = M a + b - sum_k J_k^T w_k (what whole-body controllers compute for a foot's contact
force or a hand's load)."""
from __future__ import annotations

import numpy as np

from ..model.links import resolve_link


def generalized_forces(robot, q, wrenches):
    """sum_k J_k(q)^T w_k, (nv,) or (N, nv) as q is one state or a batch."""
    if not isinstance(wrenches, dict):
        raise ValueError(f"wrenches must be a dict {{link: [fx, fy, fz, mx, my, mz]}}; got "
                         f"{type(wrenches).__name__}")
    total = 0.0
    for link, w in wrenches.items():
        resolve_link(robot.model, link, prefix="wrenches: ")
        w = np.asarray(w, dtype=float)
        if w.shape[-1:] != (6,) or w.ndim > 2 or not np.all(np.isfinite(w)):
            raise ValueError(f"wrenches[{link!r}] must be 6 finite numbers [fx, fy, fz, mx, "
                             f"my, mz] (or (N, 6) rows); got shape {w.shape}")
        J = robot.jacobian(q, link)                          # (6, nv) or (N, 6, nv)
        total = total + np.einsum("...ij,...i->...j", J, w)  # J^T w
    return total
