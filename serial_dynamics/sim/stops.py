"""Hard stops at the joints' finite URDF limits, for the fixed-step methods.

Owns ``JointStops``: the plastic impact of a joint that crosses a limit (``impact``, the
impulse with its active set: a stop only pushes) and the holding of a joint at rest on a
stop at the start of a step (``hold``, an active set like the stick-slip one of
``Equations.modes``).
"""
from __future__ import annotations

import numpy as np

from .equations import REST_SPEED, held


class JointStops:
    """The stops of one robot at its finite joint limits; counts the steps with an impact.

    ``JointStops.of(eq)`` is None when no joint has a finite limit."""

    def __init__(self, eq):
        self.eq = eq
        self.lower = np.asarray(eq.robot.lower, dtype=float)
        self.upper = np.asarray(eq.robot.upper, dtype=float)
        self.impacts = 0         # steps in which a joint reached a stop

    @classmethod
    def of(cls, eq):
        stops = cls(eq)
        return stops if np.any(np.isfinite(stops.lower)) or np.any(np.isfinite(stops.upper)) \
            else None

    def touching(self, q):
        """True when a joint is on (or beyond) one of its stops."""
        return bool(((q >= self.upper) | (q <= self.lower)).any())

    def side(self, q):
        """+1 / -1 for joints on (or beyond) their upper / lower limit, else 0."""
        return np.where(q >= self.upper, 1.0, np.where(q <= self.lower, -1.0, 0.0))

    def hold(self, s):
        """At the start of a step (``StepStart`` s): joints at rest on a stop are held there
        (qdd = 0, as joints stuck by friction) while the stop pushes; one that the stop would
        have to pull is let go, largest pull first. Returns s with the held joints added to
        ``stuck`` and the stops' holding torques to ``delta``."""
        q, qd, sign, stuck = s.q, s.qd, s.sign, s.stuck
        side = self.side(q)
        kept = (side != 0.0) & (np.abs(qd) <= REST_SPEED)
        if not kept.any():
            return s
        eq, robot = self.eq, self.eq.robot
        base = np.zeros(eq.n, dtype=bool) if stuck is None else stuck
        qd = np.where(kept, 0.0, qd)
        eq.calls += 2
        eq.states += 2
        M, b = robot.mass_matrix(q), eq.bias(q, qd, s.w)
        d0 = eq.delta(qd, sign)
        for _ in range(int(kept.sum()) + 1):
            qdd, delta = held(M, s.tau + d0 - b, base | kept, d0)
            pull = np.where(kept & ~base, (delta - d0) * side, 0.0)   # > 0: pulls outward
            i = int(np.argmax(pull))
            if pull[i] <= 0.0:
                break
            kept[i] = False
        stuck = base | kept
        return s._replace(qdd=qdd, delta=delta, stuck=stuck if stuck.any() else None)

    def impact(self, q, qd, energy):
        """Hard stops at the joint limits, after a step: a joint beyond a limit is put back
        on it, and if it moves outward it stops in a plastic impact. The impulse acts at
        the stopped joints S only: M (qd+ - qd) = S^T lambda with qd+_S = 0, so that
        qd+_F = qd_F + M_FF^-1 M_FS qd_S on the free joints F (impulsive dynamics,
        Featherstone 2008, ch. 11). A stop only pushes: a joint whose impulse would pull
        it onto the stop is released, largest pull first (as in ``Equations.modes``),
        and a joint on its stop that the impulse would push through it is stopped too.
        At the next step ``hold`` holds a stopped joint on its stop. Returns (q, qd, dE),
        dE = E(after) - E(before): the work of the stops (kinetic energy lost, and the
        potential energy of the position reset), counted with the dissipated work; 0.0
        unless ``energy``.

        On a floating base (q (n+7), qd the twist and the joint rates, n+6) the joints are
        the last n coordinates and the base is never stopped: the impulse moves it too."""
        robot = self.eq.robot
        nb = qd.shape[0] - self.eq.n                          # the base's rows of v first
        qj = q[q.shape[0] - self.eq.n:]
        hi, lo = qj > self.upper, qj < self.lower                                 # beyond
        if not (hi.any() or lo.any()):
            return q, qd, 0.0
        side = hi * 1.0 - lo
        self.impacts += 1
        E0 = float(robot.kinetic_energy(q, qd) + robot.potential_energy(q)) if energy else 0.0
        q = np.concatenate([q[:q.shape[0] - self.eq.n], np.clip(qj, self.lower, self.upper)])
        stopped = np.r_[np.zeros(nb, dtype=bool), (side != 0.0) & (qd[nb:] * side > 0.0)]
        if stopped.any():                                     # moving outward
            on = np.r_[np.zeros(nb), self.side(q[q.shape[0] - self.eq.n:])]   # beyond or on
            qd = _plastic(robot.mass_matrix(q), qd, stopped, on)
        dE = (float(robot.kinetic_energy(q, qd) + robot.potential_energy(q)) - E0
              if energy else 0.0)
        return q, qd, dE


def _plastic(M, qd, stopped, on):
    """The rates after the plastic impact at the ``stopped`` coordinates, with the active
    set over the stops (``JointStops.impact``); ``on``: +1 / -1 on an upper / lower stop."""
    for _ in range(2 * qd.shape[0]):
        free = ~stopped
        v = qd.copy()
        v[stopped] = 0.0
        if free.any():
            v[free] += np.linalg.solve(M[np.ix_(free, free)], M[np.ix_(free, stopped)] @ qd[stopped])
        pull = np.where(stopped, (M @ (v - qd)) * on, 0.0)    # impulse > 0: pulls
        if np.any(pull > 0.0):
            stopped[int(np.argmax(pull))] = False
            continue
        kicked = free & (v * on > 0.0)                        # pushed out through its stop
        if not kicked.any():
            break
        stopped |= kicked
    return v
