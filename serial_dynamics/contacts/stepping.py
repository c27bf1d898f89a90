"""Unilateral frictional contacts with a ``Ground`` in simulation: a velocity-level
time-stepping scheme (Stewart and Trinkle 1996; Anitescu and Potra 1997) solved by projected
Gauss-Seidel over the Delassus matrix; docs/simulation.md ("Contacts with the ground").

One step of dt from (q, v), in NumPy on the facade's public methods (the reference;
``compiled_step.py`` takes the same step in one compiled call where it covers the robot and
the inputs, ``stepper.GroundStepper.advance`` choosing):

1. the free velocity v_f = v + dt M^-1 (tau + delta - b) (the joints' torques, their
   dissipation, link wrenches; ``GroupRates``);
2. the point contacts within ``MARGIN`` of the ground (plus twice their approach in a step):
   their rows J = [n; t1; t2] J_P (3 a contact, world axes), G = J M^-1 J^T;
3. impulses lambda (3 a contact: normal, two tangents) with u = J v_f + G lambda such that
   lambda_n >= 0, u_n >= u*, lambda_n (u_n - u*) = 0 (the gap may close, never be crossed:
   u* = -phi / dt above the ground, ERP |phi| / dt out of a penetration, -e u_n(v) at an
   impact with restitution e) and |lambda_t| <= mu lambda_n, lambda_t opposite u_t where it
   slides (Coulomb's law, maximum dissipation); by ``sticking`` where every contact
   sticks (one solve), else by ``pgs``;
4. v1 = v_f + M^-1 J^T lambda and q1 = q(dt v1) in the robot's chart (``group.py``'s
   semi-implicit Euler).

The contact forces over the step are lambda / dt; their work over it, lambda . u (their
power at the step's final velocity, as the other forces' in this semi-implicit Euler), is
<= 0 except where ERP pushes a penetrating point out, and is counted in ``work_external``.
The kinetic energy an impact takes (1/2 lambda^T G lambda more) is no work of a force: it
shows in ``energy_balance_error`` as a loss.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dpotrs

from ..core import K, OK
from .contact import check_contacts
from .dense import firm_factor, inverse_factor
from .ground import Ground
from .jacobians import point_frames, point_rows

MARGIN = 0.01            # m: points this close to the ground (plus their approach) are solved
ERP = 0.2                # share of a penetration removed in one step (velocity level)
TOLERANCE = 1e-9         # PGS stops when no impulse changes by more than this, relative
MAX_ITERATIONS = 500
STICK_PIVOT = 1e-6       # G's pivots^2 above this share of its diagonal: the sticking solve


def check_ground(robot, ground, contacts, method):
    """(ground, contacts as a tuple of point contacts with the environment), or a ValueError
    naming the culprit."""
    if not isinstance(ground, Ground):
        raise ValueError(f"ground must be an sd.Ground; got {type(ground).__name__}")
    if method != "semi_implicit_euler":
        raise ValueError(f"contacts with the ground are stepped by a velocity-level "
                         f"time-stepping scheme, semi-implicit Euler: give "
                         f"method='semi_implicit_euler' (and dt), not {method!r}")
    if contacts is None:
        contacts = robot.contact_points()
        if not contacts:
            raise ValueError("this robot's URDF has no <collision> sphere or box to touch the "
                             "ground with; give contacts=[sd.Contact(link, point), ...]")
    contacts = check_contacts(robot, contacts)
    for i, c in enumerate(contacts):
        if c.frame or c.other_link is not None:
            raise ValueError(f"contacts[{i}] ({c}) is a {'frame' if c.frame else 'loop'} "
                             "contact; the ground touches point contacts (sd.Contact(link, "
                             "point, radius=...)) only")
    return ground, contacts


def sticking(G, u0, target, mu):
    """The impulses lam (m, 3) that make every contact stick at once, u = (target, 0, 0)
    (G lam = goal - u0 by G's Cholesky factor), where G is far from singular (each pivot^2
    above ``STICK_PIVOT`` of its largest diagonal entry) and every lam lies in its cone
    (lam_n >= 0, |lam_t| <= mu lam_n): then every condition ``pgs`` solves holds, with u_n at
    its target, and this is its fixed point. Else None (a redundant set, a contact that
    lifts off or slips: ``pgs``)."""
    m = len(target)
    L = firm_factor(G, STICK_PIVOT)
    if L is None:
        return None
    goal = np.zeros((m, 3))
    goal[:, 0] = target
    lam = dpotrs(L, goal.reshape(-1) - u0, lower=1)[0].reshape(m, 3)
    if np.all(lam[:, 0] >= 0.0) and np.all(np.hypot(lam[:, 1], lam[:, 2]) <= mu * lam[:, 0]):
        return lam
    return None


def pgs(G, u0, target, mu, lam, tolerance=TOLERANCE, max_iterations=MAX_ITERATIONS):
    """Projected Gauss-Seidel for the impulses lam (m, 3) [normal, t1, t2] of m contacts:
    u = u0 + G lam (G (3m, 3m) the Delassus matrix, u0 (3m,) the free velocities), with
    lam_n >= 0 and u_n >= target complementary, and lam_t in the disc of radius mu lam_n,
    opposite u_t where on its edge. Each contact, given the others: first its sticking
    impulse, the one that makes u = (target, 0, 0) (its 3 x 3 block of G inverted), kept
    when it lies in the cone; else the normal row by its diagonal, clamped at 0, then the
    tangents by one scalar step 1 / max(G_t1t1, G_t2t2), projected radially on the disc
    (one step size for both keeps lam_t opposite u_t at the fixed point: maximum
    dissipation). From ``lam`` (a warm start). Returns (lam, iterations)."""
    m = lam.shape[0]
    x = lam.reshape(-1).copy()
    u = u0 + G @ x
    d = np.diag(G)
    diag = np.arange(m)
    blocks = np.linalg.pinv(G.reshape(m, 3, m, 3)[diag, :, diag, :])   # (m, 3, 3), one call
    goal = np.zeros((m, 3))
    goal[:, 0] = target                                  # u = (target, 0, 0) where it sticks
    for it in range(1, max_iterations + 1):
        change = 0.0
        for i in range(m):
            r = 3 * i
            old = x[r:r + 3].copy()
            stick = old - blocks[i] @ (u[r:r + 3] - goal[i])
            s0, s1, s2 = stick.tolist()
            if s0 >= 0 and math.hypot(s1, s2) <= mu * s0:
                u += G[:, r:r + 3] @ (stick - old)
                x[r:r + 3] = stick
                change = max(change, np.max(np.abs(stick - old)))
                continue
            x[r] = max(0.0, x[r] - (u[r] - target[i]) / d[r])
            if x[r] != old[0]:
                u += G[:, r] * (x[r] - old[0])
            if mu > 0:
                t = x[r + 1:r + 3] - u[r + 1:r + 3] / max(d[r + 1], d[r + 2])
                norm, bound = np.hypot(t[0], t[1]), mu * x[r]
                if norm > bound:
                    t *= bound / norm
                u += G[:, r + 1:r + 3] @ (t - old[1:])
                x[r + 1:r + 3] = t
            elif x[r + 1] or x[r + 2]:
                u -= G[:, r + 1:r + 3] @ old[1:]
                x[r + 1:r + 3] = 0.0
            change = max(change, np.max(np.abs(x[r:r + 3] - old)))
        if change <= tolerance * max(np.max(np.abs(x)), 1e-300):
            break
    return x.reshape(m, 3), it


class GroundContacts:
    """The contacts' impulses over one step (module docstring), warm-started from the last
    step's. Counters: ``solves``, ``iterations`` (PGS sweeps, all solves together),
    ``unconverged`` (solves that stopped at MAX_ITERATIONS)."""

    def __init__(self, robot, ground, contacts, dt):
        self.robot, self.ground, self.contacts, self.dt = robot, ground, contacts, dt
        self.k = len(contacts)
        self.points = np.array([c.point for c in contacts])
        self.radius = np.array([c.radius for c in contacts])
        t1, t2 = ground.tangents()
        self.B = np.array([ground.normal, t1, t2])         # rows n, t1, t2 (world axes)
        self.lam = np.zeros((self.k, 3))                    # last impulses, contact frames
        self.frames = point_frames(robot, contacts)          # None: the facade's kinematics
        self.solves = self.iterations = self.unconverged = 0

    def _kinematics(self, q):
        """Contact points P (k, 3) and their Jacobians J_P (k, 3, nv), world axes: each point
        a frame of its body for the compiled kernels (``jacobians.point_frames``), else from
        its link's pose and Jacobian."""
        if self.frames is not None:
            model, nv = self.robot.packed_model, self.robot.nv
            P, JP = np.empty((self.k, 3)), np.empty((self.k, 3, nv))
            X, J = np.empty((4, 4)), np.empty((6, nv))
            for i, (body, F) in enumerate(self.frames):
                if (K.frame_pose_one(model, q, body, F, X) != OK
                        or K.frame_jacobian_one(model, q, body, F, J) != OK):
                    raise RuntimeError("a kinematics kernel refused a checked state")
                P[i], JP[i] = X[:3, 3], J[:3]
            return P, JP
        cache, P, JP = {}, [], []
        for c, p in zip(self.contacts, self.points):
            if c.link not in cache:
                cache[c.link] = (self.robot.forward_kinematics(q, c.link),
                                 self.robot.jacobian(q, c.link))
            X, J = cache[c.link]
            r = X[:3, :3] @ p
            P.append(X[:3, 3] + r)
            JP.append(point_rows(J, r))                     # v_P = J_v - [r]x J_w
        return np.array(P), np.array(JP)

    def step(self, q, v, v_free, M):
        """(v1, forces (k, 3) world axes, active (k,), work): the velocity after the step,
        the contact forces over it, which contacts push, and their work (J)."""
        dt, ground = self.dt, self.ground
        P, JP = self._kinematics(q)
        rows = np.einsum("ij,kjn->kin", self.B, JP)          # (k, 3, nv): n, t1, t2 rows
        phi = ground.distance(P, self.radius)
        u_before = rows[:, 0] @ v                           # normal speeds at the start
        near = np.flatnonzero(phi < MARGIN + 2 * dt * np.maximum(-u_before, 0.0))
        forces, active = np.zeros((self.k, 3)), np.zeros(self.k, dtype=bool)
        keep = np.zeros(self.k, dtype=bool)
        keep[near] = True
        self.lam[~keep] = 0.0
        if near.size == 0:
            return v_free, forces, active, 0.0
        J = rows[near].reshape(-1, v.shape[0])
        Ci = inverse_factor(M, "the mass matrix (plus the servo's D)")   # C^-1, M = C C^T
        Y = Ci @ J.T
        G, MiJt = Y.T @ Y, Ci.T @ Y                         # J M^-1 J^T, M^-1 J^T
        u0 = J @ v_free
        p = phi[near]
        # the normal target: close the gap, never cross it; out of a penetration at ERP
        target = np.where(p >= 0.0, -p / dt, -ERP * p / dt)
        ub = u_before[near]
        impact = (ground.restitution > 0) & (ub < 0) & (p + dt * ub < 0)
        target = np.where(impact, np.maximum(target, -ground.restitution * ub), target)
        lam, it = sticking(G, u0, target, ground.friction), 0    # all stick: no sweep
        if lam is None:
            lam, it = pgs(G, u0, target, ground.friction, self.lam[near])
        self.solves, self.iterations = self.solves + 1, self.iterations + it
        self.unconverged += it == MAX_ITERATIONS
        self.lam[near] = lam
        flat = lam.reshape(-1)
        v1 = v_free + MiJt @ flat
        work = flat @ (J @ v1)                     # the impulses' work at the final velocity
        forces[near] = lam @ self.B / dt
        active[near] = lam[:, 0] > 0.0
        return v1, forces, active, work
