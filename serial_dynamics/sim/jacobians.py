"""The Jacobians of the state equations for the implicit methods: analytical (from
``Robot.forward_dynamics_derivatives`` and ``Dissipation.torque_derivative``) or by
forward differences in one batched dynamics call (the route before the analytical
derivatives; kept selectable: ``simulate(..., jacobian="finite_differences")``).

Owns ``JACOBIANS`` (the routes' names), ``input_derivatives`` and ``accel_jacobian``:
with qdd = FD(q, qd, tau(t, q, qd) + delta(qd), w(t, q, qd)),

    dqdd/dq  = A_q + M^-1 (dtau/dq + J^T dw/dq)
    dqdd/dqd = A_v + M^-1 (dtau/dqd + diag(ddelta/dqd) + J^T dw/dqd)

with (A_q, A_v, M^-1) the derivatives of forward dynamics at fixed torques (Carpentier &
Mansard 2018, analytical derivatives of rigid-body dynamics). A torque or wrench given
as a callable of the state has no analytical derivative: it is differenced (the input
function only, at the 2n perturbed states; no dynamics evaluation is made for it).
"""
from __future__ import annotations

import numpy as np

JACOBIANS = ("analytical", "finite_differences")
H_REL = 1e-7                 # forward-difference step, relative to max(1, |x|)


def check_jacobian(jacobian):
    if jacobian not in JACOBIANS:
        raise ValueError(f"jacobian {jacobian!r} unknown; use one of {list(JACOBIANS)}")
    return jacobian


def analytical(jacobian):
    """True when the analytical route is asked for (every Robot has the derivatives)."""
    return check_jacobian(jacobian) == "analytical"


def perturbed(x):
    """``x`` (m,) and its m forward-difference perturbations, as rows: (X (m + 1, m), h)
    with X[0] = x, X[1 + j] = x + h_j e_j, h = H_REL max(1, |x|)."""
    h = H_REL * np.maximum(1.0, np.abs(x))
    X = np.repeat(x[None], x.size + 1, axis=0)
    X[1 + np.arange(x.size), np.arange(x.size)] += h
    return X, h


def input_derivatives(inputs, t, q, qd):
    """(dtau/dq, dtau/dqd, dw/dq, dw/dqd) by forward differences of the input functions
    (each (n, n) or (6, n); None for the inputs that do not depend on the state)."""
    if not inputs.state:
        return None, None, None, None
    n = q.size
    hq, hv = H_REL * np.maximum(1.0, np.abs(q)), H_REL * np.maximum(1.0, np.abs(qd))
    tau0 = inputs.torque(t, q, qd)
    w0 = None if inputs.wrench is None else inputs.wrench(t, q, qd)
    Tq, Tv = np.empty((n, n)), np.empty((n, n))
    Wq, Wv = (None, None) if w0 is None else (np.empty((6, n)), np.empty((6, n)))
    for j in range(n):
        for X, V, h, T, W in ((q.copy(), qd, hq[j], Tq, Wq), (q, qd.copy(), hv[j], Tv, Wv)):
            (X if T is Tq else V)[j] += h
            T[:, j] = (inputs.torque(t, X, V) - tau0) / h
            if W is not None:
                W[:, j] = (inputs.wrench(t, X, V) - w0) / h
    return Tq, Tv, Wq, Wv


def accel_jacobian(eq, inputs, t, q, qd, tau, w, ddelta):
    """(dqdd/dq, dqdd/dqd, dtau/dq, dtau/dqd) at one state (the last two None when the
    inputs do not depend on the state) with the applied torques
    ``tau`` + delta already evaluated there (``tau`` here: the total tau + delta) and
    ``ddelta`` the diagonal of d delta/d qd (module doc). One call of the analytical
    derivatives of forward dynamics."""
    Aq, Av, Minv = eq.fd_derivatives(q, qd, tau, w)
    Tq, Tv, Wq, Wv = input_derivatives(inputs, t, q, qd)
    Av = Av + Minv * ddelta[None, :]
    if Tq is not None:
        Fq, Fv = Tq, Tv                    # the generalized forces of the inputs
        if Wq is not None:
            JT = eq.robot.jacobian(q).T
            Fq, Fv = Fq + JT @ Wq, Fv + JT @ Wv
        Aq, Av = Aq + Minv @ Fq, Av + Minv @ Fv
    return Aq, Av, Tq, Tv
