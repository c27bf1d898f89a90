"""External joint torques from the model and the measured motion: the generalized-momentum
observer, and the tip wrench that explains them.

``MomentumObserver(robot, gain)``: from joint positions, velocities and the applied
(actuator) torques, sample after sample, the residual r that tracks the external torque
tau_ext = J^T w (De Luca & Mattone, ICRA 2003; De Luca, Albu-Schaeffer, Haddadin &
Hirzinger, IROS 2006):

    p = M(q) qd                                                  # generalized momentum
    pdot = tau + tau_ext + C^T(q, qd) qd - g(q) [+ delta(qd)]    # Mdot = C + C^T (De Luca 2006)
    r(t) = K (p(t) - p(t0) - int_t0^t (tau + C^T qd - g [+ delta] + r) ds)

so that rdot = K (tau_ext - r): each r_i is tau_ext_i through a first-order lag of time
constant 1/K_i, with no acceleration measured and no matrix inverted. ``C^T qd`` is
dT/dq at fixed qd (T = 1/2 qd^T M qd; true of any C with Mdot = C + C^T), computed by the
compiled ``Robot.kinetic_energy_gradient``. ``delta`` = ``robot.dissipation``'s
torques, only with ``dissipation=True`` (else the friction shows up in r as an external
torque).

Discretization (over the sample times given, which may be irregular): the trapezoid rule
for the known part, I_k = I_{k-1} + dt/2 (f_{k-1} + f_k) with f = tau + C^T qd - g [+ delta],
so that e_k = p_k - p_{k-1} - (I_k - I_{k-1}) is the integral of tau_ext over the interval;
then the lag solved exactly over the interval with tau_ext at its mean e_k / dt:

    r_k = exp(-K dt) r_{k-1} + (1 - exp(-K dt)) e_k / dt

(the zero-order-hold equivalent of rdot = K (tau_ext - r)): stable and without overshoot
for any K dt (a dropped sample is a longer dt, nothing else); a step of a constant
tau_ext is followed as exactly 1 - exp(-K (t - t_step)) at the samples, a ramp with the
continuous lag 1/K times (K dt / 2) coth(K dt / 2).
What it guarantees: with exact samples and tau_ext = 0, r is the trapezoid error of the
integral of f (second order in dt); what it does not: the sampled torque is taken as
piecewise linear between samples, and Coulomb friction near qd = 0 is only as good as
the model.

``wrench(q, tau_ext)``: the tip wrench w ([force; torque] exerted by the environment on
the tip link at its origin, base frame: the library's ``wrench`` convention) solving
J(q)^T w = tau_ext in least squares (minimum norm when the chain has fewer than 6
joints), with the condition number of J (inf when J is rank-deficient); J from six
inverse-dynamics calls (``tip_jacobian``).
"""
from __future__ import annotations

import numpy as np


RCOND = 1e-10        # singular values of J below RCOND * the largest are taken as zero


class MomentumObserver:
    """External joint torques from (t, q, qd, tau) samples; see the module docstring.

    ``gain``: K (1/s), one value or one per joint, > 0: the bandwidth of the estimate (a
    step of tau_ext is reached to 1 - e^{-K t}). ``dissipation``: subtract the friction of
    ``robot.dissipation`` (True) or not (False, the default)."""

    def __init__(self, robot, gain, dissipation=False):
        n = robot.dof
        K = np.asarray(gain, dtype=float).reshape(-1)
        if K.size == 1:
            K = np.full(n, K[0])
        if K.shape != (n,) or not np.all(np.isfinite(K)) or np.any(K <= 0):
            raise ValueError(f"gain must be one value or one per joint ({n}: "
                             f"{robot.joint_names}), finite and > 0 (1/s); got {gain!r}")
        self.robot, self.gain, self.dissipation = robot, K, bool(dissipation)
        self.reset()

    def reset(self):
        """Forget the past: the next ``update`` starts the observer again (r = 0)."""
        self.t = None              # time of the last sample
        self.r = np.zeros(self.robot.dof)
        self._p = self._f = None     # momentum and known part at the last sample

    def _known(self, q, qd, tau):
        """tau + C^T qd - g [+ delta] at one sample: pdot - tau_ext."""
        robot = self.robot
        f = tau + robot.kinetic_energy_gradient(q, qd) - robot.gravity_torques(q)
        return f + robot.dissipation_torques(qd) if self.dissipation else f

    def update(self, t, q, qd, tau):
        """The estimate r (n,) of the external joint torques (N m, N) at time ``t`` (s),
        from the positions, velocities and applied torques of that sample. The first call
        (and the first after ``reset``) returns zeros. Raises ValueError for a time that
        does not increase, wrong lengths or NaN/Inf (the observer is then unchanged)."""
        q, qd, tau = (_vector(x, name, self.robot) for x, name in
                      ((q, "q"), (qd, "qd"), (tau, "tau")))
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"t = {t}; give a finite time in seconds")
        if self.t is not None and not t > self.t:
            raise ValueError(f"t = {t!r} s does not come after the previous sample's "
                             f"{self.t!r} s; give strictly increasing times (or reset())")
        p = self.robot.mass_matrix(q) @ qd                  # generalized momentum p = M qd
        f = self._known(q, qd, tau)
        if self.t is None:
            self.t, self._p, self._f, self.r = t, p, f, np.zeros_like(p)
            return self.r.copy()
        dt = t - self.t
        e = p - self._p - 0.5 * dt * (self._f + f)          # int tau_ext dt (trapezoid of f)
        decay = np.exp(-self.gain * dt)
        r = decay * self.r + (1.0 - decay) * (e / dt)       # rdot = K (tau_ext - r), exact
        self.t, self._p, self._f, self.r = t, p, f, r
        return r.copy()

    def wrench(self, q, tau_ext):
        """(w (6,), cond(J)): see ``tip_wrench``."""
        return tip_wrench(self.robot, q, tau_ext)


def tip_wrench(robot, q, tau_ext):
    """The tip wrench w = [fx, fy, fz, mx, my, mz] (exerted on the tip link at its origin,
    base frame) with J(q)^T w = tau_ext in least squares, minimum-norm (pseudo-inverse of
    J^T by the SVD of J, singular values below RCOND * the largest dropped), and the
    condition number s_max / s_min of J (inf when rank-deficient: then w is the
    minimum-norm one, and the unobservable part of the wrench is missing). J mixes m and
    rad in its rows, so cond(J) depends on the units."""
    q = _vector(q, "q", robot)
    tau_ext = _vector(tau_ext, "tau_ext", robot)
    J = tip_jacobian(robot, q)                              # 6 x n, [linear; angular]
    U, s, Vt = np.linalg.svd(J, full_matrices=False)        # J = U diag(s) Vt
    keep = s > RCOND * s[0] if s.size and s[0] > 0 else np.zeros(s.shape, bool)
    # J^T w = V S U^T w = tau  ->  w = U S^-1 V^T tau  (minimum-norm least squares)
    w = U[:, keep] @ ((Vt[keep] @ tau_ext) / s[keep])
    rank_deficient = not np.all(keep) or s.size < min(J.shape)
    cond = np.inf if rank_deficient else float(s[0] / s[-1])
    return w, cond


def tip_jacobian(robot, q):
    """J(q) (6, n) of the tip origin, [linear; angular], base frame, from six compiled
    inverse-dynamics calls: tau = M qdd + b - J^T w gives row i of J as g(q) - tau(q, 0, 0,
    e_i) (e_i the i-th unit wrench). Equal to ``robot.jacobian(q)`` to round-off (the
    difference with g cancels: about 1e-15 |g|), some 20 times faster."""
    n = robot.dof
    z, E, J = np.zeros(n), np.eye(6), np.empty((6, n))
    for i in range(6):
        robot.inverse_dynamics(q, z, z, wrench=E[i], out=J[i])
    return robot.gravity_torques(q) - J


def _vector(x, name, robot):
    a = np.asarray(x, dtype=float)
    if a.shape != (robot.dof,):
        raise ValueError(f"{name} has shape {np.shape(x)}; give one value per joint "
                         f"({robot.dof}: {robot.joint_names})")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} has a NaN or Inf entry: {a.tolist()}")
    return a if a.flags.c_contiguous else np.ascontiguousarray(a)
