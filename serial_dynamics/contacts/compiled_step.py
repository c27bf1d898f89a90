"""One step of a simulation with a ``Ground`` in one compiled call, and a whole run of them:
``stepping.py``'s step (the reference: its targets, warm start, sticking solve and PGS
sweep order) with the free velocity, the implicit joint servo and the chart's update of q
that ``stepper.GroundStepper`` adds around it, on the compiled core's kernels.

Per step from (q, v), one numba kernel (``ground_step``):

1. M and b by the robot's composite-rigid-body and Newton-Euler kernels (``compiled.py``'s
   per-kind table), M = L L^T, a = M^-1 (tau + delta - b), delta = -beta qd (viscous
   dissipation, or none); with the servo of ``sim/servo.py`` (``euler_servo``):
   (M + D) y = e, a += y, and L the factor of M + D (D = dt Kd + dt^2 Kp);
2. v_f = v + dt a; each contact point's pose and Jacobian (core/kinematics.py's
   ``pose_at``, ``jacobian_at`` at the point folded into a frame of its body, on the poses
   of every body computed once: the bits of ``frame_pose_one``, ``frame_jacobian_one``), its rows
   [n; t1; t2] J_P, gap phi and normal speed; the contacts within MARGIN (plus twice their
   approach in a step) are solved;
3. Y = L^-1 J^T, G = Y^T Y, u0 = J v_f, the targets; lambda by the sticking solve where it
   holds, else by projected Gauss-Seidel from the last step's lambda (``stepping.pgs``'s
   sweep: each contact's sticking impulse from its 3 x 3 block's pseudo-inverse, else the
   normal row, then the tangents projected on the disc);
4. v1 = v_f + L^-T Y lambda; q1 = q(dt v1) in the robot's chart (``charts.Euclidean``,
   ``charts.FreeFlyer``'s formulas at the chart's centre); the state checks of
   ``GroupRates.check`` (DIVERGED: the caller's check then raises naming the joint).

What the kernel does not cover runs the NumPy step (``CompiledGround.of`` answers None, or
``step`` does): Coulomb friction, wrenches on links or the tip, mimic joints, the NumPy
backend. Joint stops act after either step (``GroundStepper``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..core import K, OK
from ..core.cabi import entry
from ..core.cholesky import cholesky_factor, cholesky_solve_factored
from ..core.data import new_poses, scratch, stack_empty
from ..core.kinematics import jacobian_at, not_finite_one, pose_at, root_and_bodies
from ..core.signatures import Mat, Pm, Vec, compile_internal, f8, i8
from ..core.status import BAD_LENGTH, NOT_FINITE
from ..sim.equations import PRISMATIC_BOUND
from . import compiled
from .compiled import firm_factor, lower_solve, upper_solve
from .stepping import ERP, MARGIN, MAX_ITERATIONS, STICK_PIVOT, TOLERANCE

DIVERGED = 5                 # a status: the new state fails GroupRates.check's bounds
RCOND = 1e-15                # np.linalg.pinv's cutoff (its default rcond)

# the settings (``numbers``): B = [n; t1; t2] row-major at B
DT, HEIGHT, B, MU, RESTITUTION, SERVO = 0, 1, 2, 11, 12, 13
NEAR, ERP_, TOL, ITERATIONS, PIVOT, BOUND_Q = 14, 15, 16, 17, 18, 19
NUMBERS = 20
# the joints' table (7, n): rows
BETA, KP, KD, Q_TARGET, QD_TARGET, SPEED_BOUND, PRISMATIC = range(7)
JOINT_ROWS = 7
# the contacts' table (k, 14): the body, the point as a frame of it (R row-major, p), radius
BODY, FRAME, RADIUS = 0, 1, 13
SPEC = 14
# ``out``: per step; then ACTIVE (k: 1.0 where the contact pushes), then the servo torque (n)
WORK, POWER_TAU, POWER_DELTA, SWEEPS, SOLVED, UNCONVERGED, ACTIVE = range(7)


# ------------------------------------------------------------------ the contacts' solvers
@njit(inline="always")
def _pinv3(G, r, P):
    """P = pinv(G[r:r+3, r:r+3]) (symmetric): its eigenvectors by cyclic Jacobi rotations
    (Golub & Van Loan 2013, Sec. 8.5), then sum_k v_k v_k^T / lambda_k over the |lambda_k|
    above RCOND of the largest (np.linalg.pinv's cutoff on the singular values |lambda|)."""
    A, V = stack_empty((3, 3)), stack_empty((3, 3))
    for i in range(3):
        for j in range(3):
            A[i, j] = G[r + i, r + j]
            V[i, j] = 1.0 if i == j else 0.0
    for _ in range(30):
        off = A[0, 1] ** 2 + A[0, 2] ** 2 + A[1, 2] ** 2
        if off == 0.0 or off <= 1e-40 * (A[0, 0] ** 2 + A[1, 1] ** 2 + A[2, 2] ** 2):
            break
        for p, s in ((0, 1), (0, 2), (1, 2)):
            if A[p, s] == 0.0:
                continue
            # the rotation that zeroes A[p, s]: t = tan, the smaller root (Sec. 8.5.2)
            theta = (A[s, s] - A[p, p]) / (2.0 * A[p, s])
            t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
            c = 1.0 / math.sqrt(t * t + 1.0)
            sn = t * c
            for k in range(3):             # A <- A R (columns p, s), then R^T A (rows)
                akp, aks = A[k, p], A[k, s]
                A[k, p], A[k, s] = c * akp - sn * aks, sn * akp + c * aks
            for k in range(3):
                apk, ask = A[p, k], A[s, k]
                A[p, k], A[s, k] = c * apk - sn * ask, sn * apk + c * ask
            for k in range(3):
                vkp, vks = V[k, p], V[k, s]
                V[k, p], V[k, s] = c * vkp - sn * vks, sn * vkp + c * vks
    top = max(abs(A[0, 0]), abs(A[1, 1]), abs(A[2, 2]))
    for i in range(3):
        for j in range(3):
            P[i, j] = 0.0
    for k in range(3):
        if abs(A[k, k]) > RCOND * top:
            w = 1.0 / A[k, k]
            for i in range(3):
                for j in range(3):
                    P[i, j] += V[i, k] * w * V[j, k]


@njit(inline="always")
def _sticking(G, u0, target, mu, pivot, L, lam):
    """``stepping.sticking``: lam (m,) with G lam = goal - u0 (goal = (target, 0, 0) per
    contact) where G is firm (every pivot^2 >= ``pivot`` of its largest diagonal entry) and
    every lam in its cone. True where it holds (lam then the answer)."""
    m = u0.shape[0]
    if not firm_factor(G, L, pivot):
        return False
    for i in range(m):
        lam[i] = (target[i // 3] if i % 3 == 0 else 0.0) - u0[i]
    cholesky_solve_factored(L, lam)
    for c in range(m // 3):
        r = 3 * c
        if not (lam[r] >= 0.0 and math.hypot(lam[r + 1], lam[r + 2]) <= mu * lam[r]):
            return False
    return True


@njit(inline="always")
def _add_columns(G, u, r, d0, d1, d2):
    """u += G[:, r:r+3] (d0, d1, d2)."""
    for j in range(u.shape[0]):
        u[j] += G[j, r] * d0 + G[j, r + 1] * d1 + G[j, r + 2] * d2


@njit(inline="always")
def _pgs(G, u0, target, mu, tolerance, max_iterations, x, u, blocks):
    """``stepping.pgs`` (its sweep, projections and stopping rule) on x (m,), the warm start
    on entry and the impulses on return; the sweeps made."""
    m = u0.shape[0]
    k = m // 3
    for i in range(m):
        s = 0.0
        for j in range(m):
            s += G[i, j] * x[j]
        u[i] = u0[i] + s
    for c in range(k):
        _pinv3(G, 3 * c, blocks[c])
    it = 0
    for it in range(1, max_iterations + 1):
        change = 0.0
        for c in range(k):
            r = 3 * c
            o0, o1, o2 = x[r], x[r + 1], x[r + 2]
            e0, e1, e2 = u[r] - target[c], u[r + 1], u[r + 2]     # u - (target, 0, 0)
            P = blocks[c]
            s0 = o0 - (P[0, 0] * e0 + P[0, 1] * e1 + P[0, 2] * e2)
            s1 = o1 - (P[1, 0] * e0 + P[1, 1] * e1 + P[1, 2] * e2)
            s2 = o2 - (P[2, 0] * e0 + P[2, 1] * e1 + P[2, 2] * e2)
            if s0 >= 0 and math.hypot(s1, s2) <= mu * s0:          # it sticks, given the rest
                _add_columns(G, u, r, s0 - o0, s1 - o1, s2 - o2)
                x[r], x[r + 1], x[r + 2] = s0, s1, s2
                change = max(change, abs(s0 - o0), abs(s1 - o1), abs(s2 - o2))
                continue
            x[r] = max(0.0, x[r] - (u[r] - target[c]) / G[r, r])   # the normal row, clamped
            if x[r] != o0:
                d = x[r] - o0
                for j in range(m):
                    u[j] += G[j, r] * d
            if mu > 0:                      # the tangents: one step, projected on the disc
                h = max(G[r + 1, r + 1], G[r + 2, r + 2])
                t1, t2 = x[r + 1] - u[r + 1] / h, x[r + 2] - u[r + 2] / h
                norm, bound = math.hypot(t1, t2), mu * x[r]
                if norm > bound:
                    t1, t2 = t1 * (bound / norm), t2 * (bound / norm)
                _add_columns(G, u, r, 0.0, t1 - o1, t2 - o2)
                x[r + 1], x[r + 2] = t1, t2
            elif x[r + 1] != 0.0 or x[r + 2] != 0.0:
                _add_columns(G, u, r, 0.0, -o1, -o2)
                x[r + 1], x[r + 2] = 0.0, 0.0
            change = max(change, abs(x[r] - o0), abs(x[r + 1] - o1), abs(x[r + 2] - o2))
        size = 1e-300
        for i in range(m):
            size = max(size, abs(x[i]))
        if change <= tolerance * size:
            break
    return it


# ------------------------------------------------------------------ the step
@njit(inline="always")
def _check(q, v, joints, nb, nqb, bound_q):
    """``GroupRates.check``'s test: the base's q and v finite, each joint's finite, within
    its speed bound, a prismatic joint within ``bound_q``."""
    for i in range(nqb):
        if not math.isfinite(q[i]):
            return False
    for i in range(nb):
        if not math.isfinite(v[i]):
            return False
    for j in range(joints.shape[1]):
        qj, vj = q[nqb + j], v[nb + j]
        if not (math.isfinite(qj) and math.isfinite(vj) and abs(vj) <= joints[SPEED_BOUND, j]):
            return False
        if joints[PRISMATIC, j] != 0.0 and abs(qj) > bound_q:
            return False
    return True


@njit(inline="always")
def _chart_step(floating, q, v1, dt, q1):
    """q1 = q(dt v1) in the chart centred at q: q + dt v1 on R^n; on a floating base
    ``charts.FreeFlyer``'s point(q, dt rate(q, phi0, v1) + phi0) at phi0 = [0; 0; joints]
    (the rate there [R v_O; omega; qd]), each operation as there."""
    if not floating:
        for i in range(q.shape[0]):
            q1[i] = dt * v1[i] + q[i]
        return
    x, y, z, s = q[3], q[4], q[5], q[6]
    u1, u2, u3 = v1[0], v1[1], v1[2]
    r0 = (1 - 2 * (y * y + z * z)) * u1 + 2 * (x * y - z * s) * u2 + 2 * (x * z + y * s) * u3
    r1 = 2 * (x * y + z * s) * u1 + (1 - 2 * (x * x + z * z)) * u2 + 2 * (y * z - x * s) * u3
    r2 = 2 * (x * z - y * s) * u1 + 2 * (y * z + x * s) * u2 + (1 - 2 * (x * x + y * y)) * u3
    q1[0], q1[1], q1[2] = q[0] + (dt * r0 + 0.0), q[1] + (dt * r1 + 0.0), q[2] + (dt * r2 + 0.0)
    # Exp(dtheta) [x, y, z, w], dtheta = dt omega (+ 0: the centre); sin(t/2) / t near 0 by
    # its series 1/2 - t^2 / 48
    p1, p2, p3 = dt * (v1[3] + 0.0 + 0.0) + 0.0, dt * (v1[4] + 0.0 + 0.0) + 0.0, \
        dt * (v1[5] + 0.0 + 0.0) + 0.0
    t = math.sqrt(p1 * p1 + p2 * p2 + p3 * p3)
    k = 0.5 - t * t / 48.0 if t < 1e-4 else math.sin(0.5 * t) / t
    bx, by, bz, bw = k * p1, k * p2, k * p3, math.cos(0.5 * t)
    ax, ay, az, aw = x, y, z, s                    # q_ref's quaternion, then the product
    c0 = aw * bx + bw * ax + ay * bz - az * by
    c1 = aw * by + bw * ay + az * bx - ax * bz
    c2 = aw * bz + bw * az + ax * by - ay * bx
    c3 = aw * bw - ax * bx - ay * by - az * bz
    nrm = math.sqrt(0 + c0 * c0 + c1 * c1 + c2 * c2 + c3 * c3)
    q1[3], q1[4], q1[5], q1[6] = c0 / nrm, c1 / nrm, c2 / nrm, c3 / nrm
    for j in range(7, q.shape[0]):
        q1[j] = dt * v1[j - 1] + q[j]


@njit(inline="always")
def ground_step(crba, rnea, floating, Pd, Pk, q, v, tau, joints, spec, num, lam, flags, q1,
                v1, forces, out):
    """One step (module docstring) from (q, v) under the joint torques ``tau`` (n,): q1, v1,
    the contact forces (k, 3, world axes, N), ``lam`` (k, 3) the impulses (the next step's
    warm start), ``out`` (WORK .. ACTIVE + k + n). OK, DIVERGED (q1, v1 written), or
    NOT_FINITE / BAD_LENGTH (nothing written: the NumPy step then answers or raises)."""
    nv, k, n = v.shape[0], spec.shape[0], tau.shape[0]
    nb, nqb = nv - n, q.shape[0] - n
    if (nv != Pd.shape[0] - 1 or q.shape[0] != nv + (1 if floating else 0)
            or nb != (6 if floating else 0) or joints.shape[0] != JOINT_ROWS
            or joints.shape[1] != n or spec.shape[1] != SPEC or num.shape[0] != NUMBERS
            or lam.shape[0] != k or lam.shape[1] != 3 or q1.shape[0] != q.shape[0]
            or v1.shape[0] != nv or forces.shape[0] != k or forces.shape[1] != 3
            or out.shape[0] != ACTIVE + k + n):
        return BAD_LENGTH
    if not_finite_one(q) or not_finite_one(v) or not_finite_one(tau):
        return NOT_FINITE
    dt, servo = num[DT], num[SERVO] != 0.0
    # 1. M, b; a = M^-1 (tau + delta - b), delta = -beta qd (GroupRates.rates)
    M, L = scratch((nv, nv), nv * nv), scratch((nv, nv), nv * nv)
    a, h = stack_empty((nv,)), stack_empty((nv,))
    for i in range(nv):
        h[i] = 0.0
    if crba(Pd, q, M) != OK or rnea(Pd, q, v, h, flags, a) != OK:
        return NOT_FINITE
    for i in range(nv):
        for j in range(nv):
            L[i, j] = M[i, j]
    cholesky_factor(L)
    for i in range(nv):
        if not L[i, i] > 0.0:
            return NOT_FINITE
    for i in range(nv):
        f = 0.0 if i < nb else tau[i - nb] + -joints[BETA, i - nb] * v[i]
        a[i] = f - a[i]
    cholesky_solve_factored(L, a)
    if servo:      # sim/servo.euler_servo: (M + D) y = e at the end of the servo-free step
        for i in range(nv):
            for j in range(nv):
                L[i, j] = M[i, j]
            h[i] = 0.0
        for j in range(n):
            i = nb + j
            qd1f = v[i] + dt * a[i]
            q1f = q[nqb + j] + dt * qd1f
            h[i] = (joints[KP, j] * (joints[Q_TARGET, j] - q1f)
                    + joints[KD, j] * (joints[QD_TARGET, j] - qd1f))
            L[i, i] += dt * joints[KD, j] + dt * dt * joints[KP, j]
        cholesky_factor(L)
        for i in range(nv):
            if not L[i, i] > 0.0:
                return NOT_FINITE
        cholesky_solve_factored(L, h)
        for i in range(nv):
            a[i] = a[i] + h[i]
    vf = stack_empty((nv,))
    for i in range(nv):
        vf[i] = v[i] + dt * a[i]
    # 2. the contacts' rows [n; t1; t2] J_P, gaps and approach (GroundContacts.step)
    X, Jw, F = stack_empty((4, 4)), stack_empty((6, nv)), stack_empty((12,))
    ps = new_poses(n)                          # every body's pose, once for all contacts
    if not root_and_bodies(Pk, ps, q, nqb, n):
        return NOT_FINITE
    rows = scratch((k, 3, nv), 3 * k * nv)
    phi, near = stack_empty((k,)), stack_empty((k,))
    m = 0
    for c in range(k):
        body = int(spec[c, BODY])
        for j in range(12):
            F[j] = spec[c, FRAME + j]
        pose_at(ps, body, F, X)
        jacobian_at(Pk, ps, nqb, body, F, Jw)
        for i in range(3):
            for j in range(nv):
                rows[c, i, j] = (num[B + 3 * i] * Jw[0, j] + num[B + 3 * i + 1] * Jw[1, j]
                                 + num[B + 3 * i + 2] * Jw[2, j])
        phi[c] = (X[0, 3] * num[B] + X[1, 3] * num[B + 1] + X[2, 3] * num[B + 2]
                  - num[HEIGHT] - spec[c, RADIUS])
        ub = 0.0
        for j in range(nv):
            ub += rows[c, 0, j] * v[j]
        near[c] = ub                                   # the normal speed at the start
        if phi[c] < num[NEAR] + 2.0 * dt * max(-ub, 0.0):
            m += 3
        else:
            near[c] = math.nan                         # not solved: NaN marks it
    # 3. Y = L^-1 J^T, G = Y^T Y, u0 = J v_f, the targets; lambda
    J, Y = scratch((m, nv), m * nv), scratch((nv, m), nv * m)
    G, Ls = scratch((m, m), m * m), scratch((m, m), m * m)
    u0, x, u, target = stack_empty((m,)), stack_empty((m,)), stack_empty((m,)), \
        stack_empty((m // 3 + 1,))
    i = 0
    for c in range(k):
        if math.isnan(near[c]):
            continue
        p, ub, e = phi[c], near[c], num[RESTITUTION]
        # the normal target: close the gap, never cross it; out of a penetration at ERP
        tc = -p / dt if p >= 0.0 else -num[ERP_] * p / dt
        if e > 0 and ub < 0 and p + dt * ub < 0:       # an impact: Newton's restitution
            tc = max(tc, -e * ub)
        target[i // 3] = tc
        for r in range(3):
            for j in range(nv):
                J[i + r, j] = rows[c, r, j]
            x[i + r] = lam[c, r]                       # the warm start
        i += 3
    sweeps, unconverged = 0, 0
    if m > 0:
        lower_solve(L, J, Y)
        for r in range(m):
            for s in range(r + 1):
                g = 0.0
                for l in range(nv):
                    g += Y[l, r] * Y[l, s]
                G[r, s] = g
                G[s, r] = g
            g = 0.0
            for j in range(nv):
                g += J[r, j] * vf[j]
            u0[r] = g
        mu = num[MU]
        if not _sticking(G, u0, target, mu, num[PIVOT], Ls, u):
            blocks = scratch((m // 3, 3, 3), 3 * m)
            sweeps = _pgs(G, u0, target, mu, num[TOL], int(num[ITERATIONS]), x, u, blocks)
            unconverged = 1 if sweeps == int(num[ITERATIONS]) else 0
            for r in range(m):
                u[r] = x[r]
    # 4. v1 = v_f + M^-1 J^T lambda, the forces, their work; q1 in the chart
    for l in range(nv):
        s = 0.0
        for r in range(m):
            s += Y[l, r] * u[r]
        h[l] = s
    if m > 0:
        upper_solve(L, h)
    for i in range(nv):
        v1[i] = vf[i] + h[i] if m > 0 else vf[i]
    work, i = 0.0, 0
    for r in range(m):
        s = 0.0
        for j in range(nv):
            s += J[r, j] * v1[j]
        work += u[r] * s
    for c in range(k):
        solved = not math.isnan(near[c])
        for r in range(3):
            lam[c, r] = u[i + r] if solved else 0.0
        for j in range(3):
            forces[c, j] = ((lam[c, 0] * num[B + j] + lam[c, 1] * num[B + 3 + j]
                             + lam[c, 2] * num[B + 6 + j]) / dt) if solved else 0.0
        out[ACTIVE + c] = 1.0 if lam[c, 0] > 0.0 else 0.0
        i += 3 if solved else 0
    pt, pd = 0.0, 0.0
    for j in range(n):
        w = v1[nb + j]
        pt += tau[j] * w
        pd += -joints[BETA, j] * v[nb + j] * w
        # the servo's torque at the step's end: Kp (q* - q - dt v1) + Kd (qd* - v1)
        out[ACTIVE + k + j] = (joints[KP, j] * (joints[Q_TARGET, j] - q[nqb + j] - dt * w)
                               + joints[KD, j] * (joints[QD_TARGET, j] - w)) if servo else 0.0
    out[WORK], out[POWER_TAU], out[POWER_DELTA] = work, pt, pd
    out[SWEEPS], out[SOLVED], out[UNCONVERGED] = sweeps, 1.0 if m > 0 else 0.0, unconverged
    _chart_step(floating, q, v1, dt, q1)
    return OK if _check(q1, v1, joints, nb, nqb, num[BOUND_Q]) else DIVERGED


@njit(inline="always")
def ground_run(step, Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags, Q, V, F, OUT):
    """``TAU.shape[0]`` steps from (q0, v0) under the torques TAU (one row per step, known
    in advance): Q[s + 1], V[s + 1] the state after step s, F[s] and OUT[s] its forces and
    ``out``. Returns the steps taken: all, or s where step s did not answer OK (its state
    Q[s], V[s] and those before kept; the last step's DIVERGED counts as OK: the NumPy loop
    takes that step for its forces only)."""
    steps = TAU.shape[0]
    if (Q.shape[0] != steps + 1 or V.shape[0] != steps + 1 or F.shape[0] != steps
            or OUT.shape[0] != steps or Q.shape[1] != q0.shape[0]
            or V.shape[1] != v0.shape[0]):
        return -BAD_LENGTH
    for i in range(q0.shape[0]):
        Q[0, i] = q0[i]
    for i in range(v0.shape[0]):
        V[0, i] = v0[i]
    for s in range(steps):
        st = step(Pd, Pk, Q[s], V[s], TAU[s], joints, spec, num, lam, flags, Q[s + 1],
                  V[s + 1], F[s], OUT[s])
        if st != OK and not (s == steps - 1 and st == DIVERGED):
            return s
    return steps


# One step kernel and one run kernel per kind of robot (``compiled.KINDS``): the kind's
# mass-matrix and Newton-Euler kernels, set by ``kernels`` before it compiles them (numba
# reads a global when it compiles), and the run calls the kind's step.
chain_crba = chain_rnea = tree_crba = tree_rnea = None
floating_crba = floating_rnea = floating_tree_crba = floating_tree_rnea = None
chain_step_kernel = tree_step_kernel = floating_step_kernel = floating_tree_step_kernel = None


def chain_step(Pd, Pk, q, v, tau, joints, spec, num, lam, flags, q1, v1, forces, out):
    return ground_step(chain_crba, chain_rnea, False, Pd, Pk, q, v, tau, joints, spec, num,
                       lam, flags, q1, v1, forces, out)


def tree_step(Pd, Pk, q, v, tau, joints, spec, num, lam, flags, q1, v1, forces, out):
    return ground_step(tree_crba, tree_rnea, False, Pd, Pk, q, v, tau, joints, spec, num,
                       lam, flags, q1, v1, forces, out)


def floating_step(Pd, Pk, q, v, tau, joints, spec, num, lam, flags, q1, v1, forces, out):
    return ground_step(floating_crba, floating_rnea, True, Pd, Pk, q, v, tau, joints, spec,
                       num, lam, flags, q1, v1, forces, out)


def floating_tree_step(Pd, Pk, q, v, tau, joints, spec, num, lam, flags, q1, v1, forces,
                       out):
    return ground_step(floating_tree_crba, floating_tree_rnea, True, Pd, Pk, q, v, tau,
                       joints, spec, num, lam, flags, q1, v1, forces, out)


def chain_run(Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags, Q, V, F, OUT):
    return ground_run(chain_step_kernel, Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags,
                      Q, V, F, OUT)


def tree_run(Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags, Q, V, F, OUT):
    return ground_run(tree_step_kernel, Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags,
                      Q, V, F, OUT)


def floating_run(Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags, Q, V, F, OUT):
    return ground_run(floating_step_kernel, Pd, Pk, q0, v0, TAU, joints, spec, num, lam,
                      flags, Q, V, F, OUT)


def floating_tree_run(Pd, Pk, q0, v0, TAU, joints, spec, num, lam, flags, Q, V, F, OUT):
    return ground_run(floating_tree_step_kernel, Pd, Pk, q0, v0, TAU, joints, spec, num, lam,
                      flags, Q, V, F, OUT)


_STEPS = {"chain": chain_step, "tree": tree_step, "floating": floating_step,
          "floating_tree": floating_tree_step}
_RUNS = {"chain": chain_run, "tree": tree_run, "floating": floating_run,
         "floating_tree": floating_tree_run}
_KERNELS = {}
STEP_SIGNATURE = i8(Pm, Pm, Vec, Vec, Vec, Mat, Mat, Vec, Mat, i8, Vec, Vec, Mat, Vec)
RUN_SIGNATURE = i8(Pm, Pm, Vec, Vec, Mat, Mat, Mat, Vec, Mat, i8, Mat, Mat,
                   types.Array(f8, 3, "C"), Mat)
NAMES = tuple(f"ground_{what}_{kind}" for what in ("step", "run") for kind in _STEPS)


def kernel(name):
    """The entry point ``name`` (one of NAMES: "ground_step_<kind>", "ground_run_<kind>",
    the kinds of ``compiled.KINDS``), compiled on first use after the core's kernels it
    calls (a run after its kind's step): a single-state entry point (``core/cabi.py``),
    cached in the contacts folder."""
    if name not in _KERNELS:
        g = globals()
        what, kind = name.split("_", 2)[1:]
        if what == "run":
            g[f"{kind}_step_kernel"] = kernel(f"ground_step_{kind}").kernel
        else:
            crba, rnea = compiled.KINDS[kind]
            g[f"{kind}_crba"] = getattr(K, crba).kernel
            g[f"{kind}_rnea"] = getattr(K, rnea).kernel
            compile_internal(("cholesky_factor", "cholesky_solve_factored"))
        _KERNELS[name] = entry(name, (_RUNS if what == "run" else _STEPS)[kind],
                               RUN_SIGNATURE if what == "run" else STEP_SIGNATURE,
                               folder="contacts")
    return _KERNELS[name]


# ------------------------------------------------------------------ Python side
class CompiledGround:
    """The compiled step of a ``GroundContacts`` solver's robot, ground and contacts: its
    tables, made once, and its kind's kernels. ``of`` is the one place that says whether
    it applies; ``step`` and ``run`` answer None (or stop early) where the kernel refuses,
    and the caller takes the NumPy step. The impulses' warm start and the solver's counters
    are the solver's own (``lam`` shared in place), so both steps may alternate."""

    @classmethod
    def of(cls, robot, eq, solver):
        """A ``CompiledGround``, or None where the kernel does not cover this robot and
        model of dissipation: mimic joints or the NumPy backend (``compiled._entry``; the
        solver's ``frames`` are None there too), Coulomb friction (stick-slip, smoothed)."""
        e = compiled._entry(robot)
        if e is None or solver.frames is None or eq.coulomb_on:
            return None
        return cls(e, eq, solver)

    def __init__(self, e, eq, solver):
        self.e, self.solver, self.n, self.k = e, solver, eq.n, solver.k
        self.spec = np.zeros((self.k, SPEC))
        for row, (body, F), radius in zip(self.spec, solver.frames, solver.radius):
            row[BODY], row[FRAME:FRAME + 12], row[RADIUS] = body, F, radius
        ground, num = solver.ground, np.zeros(NUMBERS)
        num[DT], num[HEIGHT], num[B:B + 9] = solver.dt, ground.height, solver.B.ravel()
        num[MU], num[RESTITUTION] = ground.friction, ground.restitution
        num[NEAR], num[ERP_], num[TOL], num[ITERATIONS] = MARGIN, ERP, TOLERANCE, MAX_ITERATIONS
        num[PIVOT], num[BOUND_Q] = STICK_PIVOT, PRISMATIC_BOUND
        self.num = num
        self.joints = np.zeros((JOINT_ROWS, self.n))
        self.joints[BETA] = eq.beta if eq.diss_on else 0.0
        self.joints[SPEED_BOUND], self.joints[PRISMATIC] = eq.speed_bound, eq.prismatic
        self.out = np.empty(ACTIVE + self.k + self.n)
        self.kind = e.kind
        self._step = None

    def step(self, q, v, tau, servo=None):
        """(q1, v1, forces (k, 3), status OK or DIVERGED) of one step, ``out`` its works,
        active contacts and servo torque; None where the kernel refuses (other types or
        lengths, a state it cannot take: the NumPy step answers or raises). ``servo``: a
        ``sim.servo.Servo`` on the joints, or None."""
        if self._step is None:
            self._step = kernel(f"ground_step_{self.kind}")
        j, num = self.joints, self.num
        if servo is not None:
            j[KP], j[KD], j[Q_TARGET], j[QD_TARGET] = servo
        num[SERVO] = servo is not None
        e = self.e
        q1, v1, forces = np.empty(q.shape[0]), np.empty(v.shape[0]), np.empty((self.k, 3))
        st = self._step(e.Pd, e.Pk, q, v, tau, j, self.spec, num, self.solver.lam, e.flags,
                        q1, v1, forces, self.out)
        if st != OK and st != DIVERGED:
            return None
        self.count(self.out[SWEEPS:UNCONVERGED + 1].tolist())
        return q1, v1, forces, st

    def count(self, totals):
        """The solver's counters plus ``totals``: (sweeps, solves, unconverged) of the
        steps taken (``out``'s SWEEPS .. UNCONVERGED, summed over a run)."""
        s = self.solver
        s.iterations += int(totals[0])
        s.solves += int(totals[1])
        s.unconverged += int(totals[2])

    def active(self, out):
        """Which contacts pushed, from ``out`` (a step's, or a run's rows)."""
        return out[..., ACTIVE:ACTIVE + self.k] > 0.0

    def servo_torque(self):
        """The last step's servo torque (n,)."""
        return self.out[ACTIVE + self.k:].copy()

    def run(self, q0, v0, TAU):
        """(steps, Q, V, F, OUT): ``ground_run`` from (q0, v0) under TAU (one row of joint
        torques per step), no servo."""
        e, steps = self.e, TAU.shape[0]
        self.num[SERVO] = 0.0
        Q, V = np.empty((steps + 1, q0.shape[0])), np.empty((steps + 1, v0.shape[0]))
        F, OUT = np.zeros((steps, self.k, 3)), np.zeros((steps, ACTIVE + self.k + self.n))
        done = kernel(f"ground_run_{self.kind}")(
            e.Pd, e.Pk, np.ascontiguousarray(q0, dtype=float),
            np.ascontiguousarray(v0, dtype=float), np.ascontiguousarray(TAU, dtype=float),
            self.joints, self.spec, self.num, self.solver.lam, e.flags, Q, V, F, OUT)
        done = max(int(done), 0)
        self.count(OUT[:done, SWEEPS:UNCONVERGED + 1].sum(axis=0).tolist())
        return done, Q, V, F, OUT
