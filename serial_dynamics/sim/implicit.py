"""The implicit midpoint rule, x1 = x0 + dt f((x0 + x1)/2) (Hairer, Lubich & Wanner, GNI):
symplectic and A-stable, for stiff chains at a real-time step.

Owns ``implicit_midpoint`` (a stepper with the signature of ``fixed_step.STEPPERS``, see
``explicit``), its simplified Newton iteration and the Jacobian it reuses over steps
(``integ.jac_cache``: (modes, age, dqdd/dq, LU) of the last Jacobian): analytical
(``jacobians.accel_jacobian``; ``integ.analytical``), or by forward differences in one
batched dynamics call over the state and its 2n perturbations (``jacobian=
"finite_differences"``, and whenever joints are held by friction or a stop).

The rule is symmetric and A-stable. In (q, qd) it is symplectic only when the mass
matrix is constant (it is the midpoint rule of the Hamiltonian system only in (q, p));
on an arm its energy error still stays bounded over long runs in practice (symmetric
methods on reversible systems: Hairer, Lubich & Wanner, GNI, ch. XI).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from .jacobians import accel_jacobian, perturbed
from ..model.errors import SimulationError
from .methods import advice

JACOBIAN_AGE = 20            # steps a Jacobian is reused at most
NEWTON_ACCEPT = 1e-7         # largest relative correction accepted at the last Newton
                             # iteration (the target is newton_tol = 1e-10)


def frozen_coulomb(eq, s, dt):
    """The Coulomb (+ Stribeck) torques held over the step at their value for the predicted
    midpoint speed (second order while sliding); Newton then sees only the smooth viscous
    and rigid-body terms, not the kink of |qd| at zero nor the negative slope of the
    Stribeck rise. None without Coulomb friction."""
    if not eq.coulomb_on:
        return None
    sign = s.sign
    v_mid = s.qd + dt / 2 * s.qdd
    return np.where(sign != 0, -eq.diss.sliding_friction(np.maximum(sign * v_mid, 0.0)) * sign,
                    0.0)


def implicit_midpoint(integ, s, inputs, energy):
    """One implicit midpoint step by simplified Newton on the increments (dq, dv)."""
    eq, dt, n = integ.eq, integ.dt, integ.eq.n
    t, q, qd, stuck, sign = s.t, s.q, s.qd, s.stuck, s.sign
    coulomb = frozen_coulomb(eq, s, dt)
    tm = t + dt / 2

    def accel(Q, V):
        tau, w = inputs(tm, Q, V) if Q.ndim == 1 else inputs.batch(tm, Q, V)
        a, d = eq.accel(Q, V, tau, w, stuck, sign, coulomb=coulomb)
        return a, d, tau, w

    def newton_lu(Aq, Av):
        """Newton on G(dq, dv) = [dq - dt (qd + dv/2); dv - dt a(q + dq/2, qd + dv/2)] = 0
        with the position rows eliminated: (1 - dt/2 A_v - dt^2/4 A_q) s_v = ..., its LU."""
        return lu_factor(np.eye(n) - dt / 2 * Av - dt * dt / 4 * Aq, check_finite=False)

    def jacobian_differences(x, v):
        """qdd at (x, v) and its derivatives by forward differences: one batched call
        over the state and its 2n perturbations."""
        X, h = perturbed(np.concatenate([x, v]))
        A, D, tau, w = accel(X[:, :n], X[:, n:])
        integ.jacobians += 1
        integ.stages += 1
        a0 = A[0]
        Aq = ((A[1:n + 1] - a0) / h[:n, None]).T
        Av = ((A[n + 1:] - a0) / h[n:, None]).T
        return a0, Aq, newton_lu(Aq, Av), (x, v, tau[0], D[0], None if w is None else w[0])

    def jacobian_analytical(x, v):
        """qdd at (x, v) and its analytical derivatives (``jacobians.accel_jacobian``):
        one forward-dynamics call and one call of its derivatives. Over the step the
        dissipation is -beta v + the frozen Coulomb torques: d delta/d v = -beta."""
        a, d, tau, w = accel(x, v)
        Aq, Av, _, _ = accel_jacobian(eq, inputs, tm, x, v, tau + d, w, -eq.beta)
        integ.jacobians += 1
        integ.stages += 1
        return a, Aq, newton_lu(Aq, Av), (x, v, tau, d, w)

    # analytical, unless joints are held (then the differences of the held system)
    jacobian = (jacobian_analytical if integ.analytical and (stuck is None or not stuck.any())
                else jacobian_differences)

    def evaluated(x, v):
        """qdd at (x, v) and the arguments of the power there."""
        a, d, tau, w = accel(x, v)
        integ.stages += 1
        return a, (x, v, tau, d, w)

    key = (None if stuck is None else stuck.tobytes(), None if sign is None else
           sign.tobytes())
    cache = integ.jac_cache
    # the first iterate: the explicit Euler step from the acceleration at the start (made
    # by the caller), so that the first evaluation is at the predicted midpoint
    dv = dt * s.qdd
    dq = dt * (qd + dv / 2)
    if cache is not None and cache[0] == key and cache[1] < JACOBIAN_AGE:
        # reuse the last Jacobian (simplified Newton); refreshed below when it converges
        # slowly, when the stick-slip modes change, or after JACOBIAN_AGE steps
        dA_dq, lu = cache[2], cache[3]
        integ.jac_cache = (key, cache[1] + 1, dA_dq, lu)
        a, p_args = evaluated(q + dq / 2, qd + dv / 2)
    else:
        a, dA_dq, lu, p_args = jacobian(q + dq / 2, qd + dv / 2)
        integ.jac_cache = (key, 1, dA_dq, lu)
    scale = 1.0 + np.concatenate([np.abs(q), np.abs(qd)])
    prev, refreshed = None, 0
    for _ in range(integ.max_newton):
        Gq, Gv = dq - dt * (qd + dv / 2), dv - dt * a
        sv = lu_solve(lu, -Gv - dt / 2 * (dA_dq @ Gq), check_finite=False)
        step = np.concatenate([-Gq + dt / 2 * sv, sv])
        dq, dv = dq + step[:n], dv + sv
        integ.newton_iterations += 1
        size = np.max(np.abs(step) / scale)
        # simplified Newton converges linearly at rate rho; the error left after this
        # correction is about rho / (1 - rho) of it (Hairer & Wanner, Sec. IV.8)
        rho = size / prev if prev else None
        if not np.isfinite(size) or size <= integ.newton_tol or \
                (rho is not None and rho < 0.5 and rho / (1.0 - rho) * size <= integ.newton_tol):
            break
        prev = size
        qm, vm = q + dq / 2, qd + dv / 2
        if not (np.all(np.isfinite(qm)) and np.all(np.isfinite(vm))):
            break
        if rho is not None and rho > 0.2 and refreshed < 2:
            # slow contraction: a new Jacobian at the current midpoint (it gives a too)
            a, dA_dq, lu, p_args = jacobian(qm, vm)
            integ.jac_cache = (key, 1, dA_dq, lu)
            refreshed += 1
            prev = None
        else:
            a, p_args = evaluated(qm, vm)
    else:
        # a correction just above newton_tol after max_newton iterations is accepted
        if not size <= NEWTON_ACCEPT:
            raise SimulationError(
                f"implicit midpoint: Newton did not converge within {integ.max_newton} "
                f"iterations at t = {t:.6g} s (last relative correction {size:.3g}). "
                f"{advice('implicit_midpoint', dt)}", t, None, "newton")
        integ.newton_stalls += 1
    dW = dt * eq.power(*p_args) if energy else np.zeros(3)
    return q + dq, qd + dv, dW
