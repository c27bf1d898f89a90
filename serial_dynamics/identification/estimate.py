"""Estimators of the inertial (and friction) parameters from tau = W beta.

- Ordinary least squares on the base regressor W (rows: every joint at every sample),
  sigma^2 = |tau - W beta|^2 / (rows - b), cov(beta) = sigma^2 (W^T W)^-1 (the standard
  deviations of the base parameters; Gautier & Khalil, "Exciting trajectories for the
  identification of base inertial parameters of robots", IJRR 11(4), 1992).
- Weighted least squares: each joint's rows weighted by 1 / sigma_j, sigma_j^2 its OLS
  residual variance, cov(beta) = (W^T S^-1 W)^-1 (Gautier, "Dynamic identification of
  robots with power model", ICRA 1997).
- Physically consistent: the standard parameters of every body as a log-Cholesky factor of
  its pseudo-inertia J = [[Sigma, h], [h^T, m]], Sigma = tr(I_O)/2 1 - I_O (Rucker & Wensing,
  "Smooth parameterization of rigid-body inertia", IEEE RA-L 7(2), 2022): J = U U^T with

      U = e^alpha [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]]

  is positive definite for every real (alpha, d, s, t), which is exactly a body with
  positive mass whose inertia obeys the triangle inequality (Wensing, Kim, Slotine, IEEE
  RA-L 3(1), 2018). Friction coefficients fv, fc and armature are squares (>= 0). Fitted by
  scipy.optimize.least_squares (Levenberg-Marquardt, weighted as WLS, on the R factor of
  the regressor's QR) from the URDF's inertias and the WLS friction, with a small pull
  (1e-5 of the regressor's scale) towards the URDF's inertias that fixes the directions
  the data cannot see (the standard parameters beyond the base ones).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .urdf_out import body_inertia, is_physical

PULL = 1e-5      # the pull towards the URDF, relative to the regressor's scale


def least_squares_fit(W, tau, weights=None):
    """(beta, cov, residual (N, n)) of tau (N, n) = W (N, n, b) beta, rows weighted by
    ``weights`` (n,) (1 / sigma_j) when given."""
    N, n, b = W.shape
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    A = (W * w[None, :, None]).reshape(-1, b)
    y = (tau * w).reshape(-1)
    beta, *_ = np.linalg.lstsq(A, y, rcond=None)
    residual = tau - W @ beta
    inv = np.linalg.pinv(A.T @ A)
    if weights is None:
        sigma2 = float(np.sum(residual**2)) / max(N * n - b, 1)
        cov = sigma2 * inv            # sigma^2 (W^T W)^-1 (Gautier & Khalil 1992)
    else:
        cov = inv                     # (W^T S^-1 W)^-1, rows scaled by 1/sigma_j (Gautier 1997)
    return beta, cov, residual


def joint_weights(residual, b):
    """1 / sigma_j from the OLS residuals (N, n), sigma_j^2 = |r_j|^2 / (N - b / n)."""
    N, n = residual.shape
    var = np.sum(residual**2, axis=0) / max(N - b / n, 1)
    return 1.0 / np.sqrt(np.maximum(var, 1e-30 * max(var.max(), 1e-300)))


def closest_standard(phi0, K, beta):
    """The standard parameters closest to ``phi0`` that give the base parameters ``beta``
    (K phi = beta): phi = phi0 + K^+ (beta - K phi0), minimum |phi - phi0|."""
    return phi0 + np.linalg.pinv(K) @ (beta - K @ phi0)


def physical_bodies(phi, bodies):
    """(bodies,) bool: each body's 10 standard parameters are physically consistent."""
    return np.array([is_physical(*body_inertia(phi[10 * i:10 * i + 10]))
                     for i in range(bodies)])


# --------------------------------------------------------------- log-Cholesky (Rucker & Wensing)
def pseudo_inertia(phi):
    """J (4, 4) of one body's standard parameters (m, h, I_O)."""
    m, h, I_O = body_inertia(phi)
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_O) * np.eye(3) - I_O
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


def from_log_cholesky(theta):
    """One body's 10 standard parameters from theta = (alpha, d1, d2, d3, s12, s23, s13,
    t1, t2, t3): J = U U^T, m = J_44, h = J_1:3,4, I_O = tr(Sigma) 1 - Sigma."""
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = theta
    U = np.exp(a) * np.array([[np.exp(d1), s12, s13, t1], [0.0, np.exp(d2), s23, t2],
                              [0.0, 0.0, np.exp(d3), t3], [0.0, 0.0, 0.0, 1.0]])
    J = U @ U.T                                # pseudo-inertia (Rucker & Wensing 2022)
    S = J[:3, :3]
    I = np.trace(S) * np.eye(3) - S
    return np.array([J[3, 3], *J[:3, 3], I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2],
                     I[2, 2]])


def to_log_cholesky(phi, floor=1e-6):
    """theta of one body's standard parameters (their pseudo-inertia, lifted to positive
    definite by ``floor`` times its largest entry where it is only semi-definite): U is
    the upper-triangular factor J = U U^T, the Cholesky factor of J with its rows and
    columns reversed."""
    J = pseudo_inertia(phi)
    w, V = np.linalg.eigh(J)
    J = (V * np.maximum(w, floor * max(w.max(), 1e-12))) @ V.T
    P = np.eye(4)[::-1]
    U = P @ np.linalg.cholesky(P @ J @ P) @ P
    a = np.log(U[3, 3])
    U = U / U[3, 3]
    return np.array([a, np.log(U[0, 0]), np.log(U[1, 1]), np.log(U[2, 2]), U[0, 1], U[1, 2],
                     U[0, 2], U[0, 3], U[1, 3], U[2, 3]])


def physical_fit(Y, tau, weights, phi_start, names, bodies, max_nfev=2000):
    """Standard parameters phi (p,) of tau (N, n) = Y (N, n, p) phi with every one of the
    ``bodies`` physical and the friction/armature columns >= 0 (module docstring);
    ``phi_start``: the starting point and the target of the small pull. Returns
    (phi, scipy result)."""
    N, n, p = Y.shape
    A = (Y * weights[None, :, None]).reshape(-1, p)
    y = (tau * weights).reshape(-1)
    # |A phi - y|^2 = |R phi - Q^T y|^2 + const (A = Q R): fit p rows instead of N n
    Q, R = np.linalg.qr(A)
    y = Q.T @ y
    nb = 10 * bodies
    other = np.arange(nb, p)
    # friction and armature >= 0 as squares, phi_k = x_k^2 (the offsets fo are free)
    sq = np.zeros(p, bool)
    sq[other] = [not names[k].startswith("fo") for k in other]
    start = phi_start.copy()
    start[sq] = np.maximum(start[sq], 1e-6 * max(np.abs(start[sq]).max(initial=0.0), 1.0))
    x0 = np.concatenate([np.concatenate([to_log_cholesky(phi_start[10 * i:10 * i + 10])
                                         for i in range(bodies)]),
                         np.where(sq[other], np.sqrt(np.abs(start[other])), start[other])])
    unit = np.maximum(np.abs(phi_start), 1e-3 * max(np.abs(phi_start).max(), 1e-12))
    pull = PULL * np.sqrt(np.trace(R.T @ R)) * unit.mean() / unit     # per parameter
    pull[nb:] = 0.0                    # friction is always seen: no pull

    def phi_of(x):
        body = [from_log_cholesky(x[10 * i:10 * i + 10]) for i in range(bodies)]
        rest = np.where(sq[other], x[nb:] ** 2, x[nb:])
        return np.concatenate(body + [rest])

    def residual(x):
        phi = phi_of(x)
        return np.concatenate([R @ phi - y, pull * (phi - phi_start)])

    def jacobian(x):
        D = np.zeros((p, p))           # d phi / d x: 10 x 10 blocks, then diagonal
        for i in range(bodies):
            D[10 * i:10 * i + 10, 10 * i:10 * i + 10] = log_cholesky_jacobian(x[10 * i:10 * i + 10])
        D[other, other] = np.where(sq[other], 2 * x[nb:], 1.0)
        return np.vstack([R @ D, pull[:, None] * D])

    # Levenberg-Marquardt (MINPACK): phi is quadratic in the factors, so it converges in
    # a few dozen iterations. A trial step far out may overflow exp (an unphysical body);
    # the fit goes on past it (test/identification), so it is not reported as a warning
    with np.errstate(over="ignore", invalid="ignore"):
        res = least_squares(residual, x0, jac=jacobian, method="lm", x_scale="jac",
                            max_nfev=max_nfev)
    return phi_of(res.x), res


def log_cholesky_jacobian(theta, h=1e-6):
    """d phi / d theta (10, 10) of ``from_log_cholesky`` by central differences (phi is a
    quadratic polynomial in exp(theta) and theta: step h gives ~1e-12 relative error)."""
    J = np.empty((10, 10))
    for k in range(10):
        e = np.zeros(10)
        e[k] = h
        J[:, k] = (from_log_cholesky(theta + e) - from_log_cholesky(theta - e)) / (2 * h)
    return J
