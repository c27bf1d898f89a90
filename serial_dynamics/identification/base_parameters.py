"""Base parameters: the combinations of the standard parameters that the torques determine.

The regressor Y(q, qd, qdd) (``Robot.regressor``) has p columns, but some are zero (the
mass of a body whose origin never moves) and some are combinations of others (the mass of
a body acts as a point mass on the body before it; a pair of inertias only as a
difference). The b **base parameters** beta = K phi are a minimal set of combinations
with Y phi = Y_b beta for every state, Y_b = Y[..., independent] (Mayeda, Yoshida &
Osuka, "Base parameters of manipulator dynamic models", IEEE Trans. Robot. Autom. 6(3),
1990).

Gautier's numerical method (Gautier, "Numerical calculation of the base inertial
parameters of robots", J. Robotic Systems 8(4), 1991; ICRA 1990): stack the regressor at
random states into W (r x p, r >> p). Then

1. the rank: QR with column pivoting, W P = Q R, b = the number of |R_kk| above
   ``tol`` |R_00| (the numerical rank of W);
2. the base columns: W's QR without pivoting, in the standard order (bodies base to
   tip, each [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]; then Ia, fv, fc, fo):
   column k is a base column when |R_kk| > ``tol`` |W_k| (it is not a combination of the
   columns before it). So every dependent parameter is grouped into base parameters
   before it: a body's mass into the first moments and inertias of the body before it
   ("mx2 + 0.425 m3"), Iyy into Ixx ("Ixx3 - Iyy3"), as in Khalil & Dombre's symbolic
   grouping rules (*Modeling, Identification and Control of Robots*, 2002).
   Should this choice not give b columns (a badly scaled problem), the pivoted QR's are
   used instead;
3. with W = [W1 W2] (base columns first), W2 = W1 R1^-1 R2 (QR of [W1 W2]), so
   beta = phi_1 + R1^-1 R2 phi_2: K has the identity on the base columns and R1^-1 R2 on
   the others (coefficients whose contribution |K_rk| |W_k| is below 1e-10 |W1_r| set to
   0: round-off).

Deterministic: the states come from ``seed`` (numpy's default_rng), the regressor is
bitwise reproducible, and LAPACK's QR is deterministic for the same input; the choice in
step 2 has no ties to break (a column is in the span of those before it or not).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import qr, solve_triangular

from ..robot.regressor import parameter_names

TOL = 1e-8          # rank tolerance relative to |R_00|, and a column's own threshold
FLOOR = 1e-10       # a column this small against the largest is round-off (zero)
CLEAN = 1e-10       # a coefficient contributing less than this (relative) is round-off


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """The b base parameters of a robot: beta = K phi, Y phi == Y[..., independent] beta."""

    independent: np.ndarray      # (b,) indices of the base columns, sorted
    K: np.ndarray                # (b, p)
    standard_names: tuple        # the p standard parameters' names (regressor.parameter_names)
    names: tuple                 # the b readable combinations, e.g. "Izz2 + 0.425 mx3"

    @property
    def count(self) -> int:
        """b, the number of base parameters."""
        return int(self.independent.size)

    def beta(self, phi):
        """The base parameters K phi of the standard parameters phi (p,) (or (..., p))."""
        return np.asarray(phi, dtype=float) @ self.K.T

    def project(self, Y):
        """The base regressor Y[..., independent] of a regressor Y (..., p)."""
        return np.asarray(Y)[..., self.independent]

    def __repr__(self):
        return f"BaseParameters({self.count} of {len(self.standard_names)}: {list(self.names)})"


def base_parameters(robot, friction=False, armature=None, samples=None, seed=0,
                    tol=None) -> BaseParameters:
    """The base parameters of ``robot``'s regressor (same ``friction`` and ``armature``
    arguments as ``Robot.regressor``), from ``samples`` random states (default: enough for
    4 p rows, at least 64) drawn with ``seed``; ``tol``: the rank tolerance (default 1e-8,
    relative)."""
    tol = TOL if tol is None else float(tol)
    if not 0.0 < tol < 1.0:
        raise ValueError(f"tol = {tol}; give a relative tolerance between 0 and 1, e.g. 1e-8")
    names = parameter_names(robot, friction, armature)
    p, n = len(names), robot.dof
    samples = max(64, -(-4 * p // n)) if samples is None else int(samples)
    if samples * n < p:
        raise ValueError(f"samples = {samples} states give {samples * n} rows for {p} "
                         f"parameters; give at least {-(-p // n)}")
    W = stacked_regressor(robot, samples, seed, friction, armature)
    independent = _base_columns(W, tol)
    K = _grouping(W, independent)
    independent.setflags(write=False)
    K.setflags(write=False)
    return BaseParameters(independent, K, tuple(names), tuple(_expressions(K, independent, names, W)))


def stacked_regressor(robot, samples, seed=0, friction=False, armature=None):
    """W (samples n, p): the regressor at ``samples`` random states, stacked: q uniform in
    the joint limits (+-pi where unlimited), qd uniform in +-1, qdd normal."""
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, batch=samples)
    qdd = rng.normal(size=q.shape)
    Y = robot.regressor(q, qd, qdd, friction=friction, armature=armature)
    return Y.reshape(-1, Y.shape[-1])


def _base_columns(W, tol):
    """Sorted indices of the base columns (module docstring, steps 1 and 2)."""
    R, piv = qr(W, mode="r", pivoting=True)
    d = np.abs(np.diag(R))
    b = int(np.sum(d > tol * d[0])) if d.size and d[0] > 0 else 0
    R0 = qr(W, mode="r")[0]
    norms = np.linalg.norm(W, axis=0)
    floor = FLOOR * (np.max(norms) if norms.size else 0.0)      # a column of round-off is zero
    greedy = np.flatnonzero((np.abs(np.diag(R0)) > tol * norms) & (norms > floor))
    chosen = greedy if greedy.size == b else np.sort(piv[:b])
    return chosen.astype(np.int64)


def _grouping(W, independent):
    """K (b, p): beta = K phi (module docstring, step 3)."""
    p, b = W.shape[1], independent.size
    dependent = np.setdiff1d(np.arange(p), independent)
    R = qr(W[:, np.concatenate([independent, dependent])], mode="r")[0]
    K = np.zeros((b, p))
    K[:, independent] = np.eye(b)
    if dependent.size:
        C = solve_triangular(R[:b, :b], R[:b, b:b + dependent.size])
        norms = np.linalg.norm(W, axis=0)
        small = np.abs(C) * norms[dependent] <= CLEAN * norms[independent][:, None]
        K[:, dependent] = np.where(small, 0.0, C)
    return K


def _expressions(K, independent, names, W):
    """"Izz2 + 0.425 mx3 - Iyy3": each base parameter as a combination of named standard
    parameters, coefficients to 4 significant digits, zero terms dropped."""
    out = []
    for r, k in enumerate(independent):
        terms = [names[k]]
        for j in np.flatnonzero(K[r]):
            if j == k:
                continue
            c = K[r, j]
            mag = "" if abs(abs(c) - 1.0) < 1e-9 else f"{abs(c):.4g} "
            terms.append(f"{'-' if c < 0 else '+'} {mag}{names[j]}")
        out.append(" ".join(terms))
    return out
