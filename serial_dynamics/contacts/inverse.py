"""Contact inverse dynamics, what a whole-body controller computes: the joint torques tau
and contact forces f that realise given accelerations a with given contacts,
M a + b = tau + J^T f (f exerted by the environment on the robot; world axes).

On a floating base the base's six rows are unactuated (tau's first six are zero), so the
forces must carry the base: J_b^T f = (M a + b)_b, six equations. By default f is the
minimum-norm solution (least squares, refused where it leaves a residual: the contacts
cannot exert that wrench); with ``friction=mu`` the minimum-norm one with every force in its
Coulomb cone (friction.py). On a fixed base every joint is actuated: the minimum-norm forces
are zero and tau = M a + b. The accelerations are taken as given (a controller's a meets
the contacts; this does not check J a + J-dot v = 0).
"""
from __future__ import annotations

import numpy as np

from .constrained import forces_table
from .contact import check_contacts
from .friction import friction_forces, normals
from .jacobians import contact_rows
from .states import positive, rows


def _one(robot, q, v, a, contacts, mu, normal, tolerance):
    h = robot.inverse_dynamics(q, v, a)                        # M a + b
    m = sum(c.size for c in contacts)
    if not robot.is_floating:
        return h, np.zeros(m)
    J = contact_rows(robot, q, v, contacts).J
    B, hb = J[:, :6].T, h[:6]                                  # the base rows: B f = h_b
    if mu is None:
        f = np.linalg.lstsq(B, hb, rcond=None)[0]              # the minimum-norm solution
        left = B @ f - hb
        if np.max(np.abs(left)) > tolerance * max(1.0, float(np.max(np.abs(hb)))):
            left = (np.round(left, 6) + 0.0).tolist()
            raise ValueError(
                f"the contacts {[str(c) for c in contacts]} cannot exert the base wrench these "
                f"accelerations need: the closest forces leave {left} "
                f"(N, N m; base frame) unbalanced (they span {np.linalg.matrix_rank(B)} of its "
                "6 directions); add contacts (a frame contact carries a moment) or change a")
    else:
        f = friction_forces(B, hb, contacts, mu, normal, tolerance)
    tau = h - J.T @ f
    tau[:6] = 0.0                                              # unactuated, carried by f
    return tau, f


def contact_inverse_dynamics(robot, q, v, a, contacts, friction=None, normal=(0.0, 0.0, 1.0),
                             tolerance=1e-9):
    """(tau, f): joint torques (nv,) (a floating base's six rows zero) and contact forces
    (k, 3) or (k, 6) with M a + b = tau + J^T f (module docstring). ``friction``: Coulomb's
    coefficient mu > 0 for every contact with the environment, about ``normal`` (world axes,
    (3,) or one per contact). A batch (N, .) gives (N, nv) and (N, k, .)."""
    contacts = check_contacts(robot, contacts)
    mu = None if friction is None else positive("friction", friction)
    normals(normal, contacts)                                  # checked before any work
    tolerance = positive("tolerance", tolerance)
    nv = robot.nv
    single, N, (Q, V, A) = rows((("q", q, (robot.nq,)), ("v", v, (nv,)), ("a", a, (nv,))))
    T, F = [], []
    for i in range(N):
        tau, f = _one(robot, Q[i], V[i], A[i], contacts, mu, normal, tolerance)
        T.append(tau)
        F.append(forces_table(contacts, f))
    return (T[0], F[0]) if single else (np.array(T), np.array(F))
