"""The semi-implicit Euler step, written once, compiled.

Owns ``semi_implicit_euler_step``: the step-by-step integrator (``fixed_step``) and the
compiled whole-run loop both call it, so that the two give the same numbers. A plain
loop with no fast-math flag: each update rounds exactly as NumPy's ``qd + dt * qdd``
(a product, then a sum), bitwise. It imports only ``core.cache`` (where numba caches it).
"""
from ..core.cache import njit_in


@njit_in("sim")
def semi_implicit_euler_step(q, qd, qdd, dt):
    """Advance (q, qd) in place by one step dt with the acceleration qdd (n,): velocity
    first, then position with the new velocity (Hairer, Lubich & Wanner, GNI, Sec. I.1.2;
    symplectic Euler only when the mass matrix is constant: in (q, qd) with M(q) it is
    not symplectic, see ``symplectic.py`` for the momentum form)."""
    for i in range(q.shape[0]):
        qd[i] += dt * qdd[i]        # qd1 = qd0 + dt qdd0
        q[i] += dt * qd[i]          # q1 = q0 + dt qd1
